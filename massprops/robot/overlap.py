"""Geometries of one link that may overlap: united as ``props`` unites overlapping shells, or bounded.

A link's solid is the union of its geometries: each point counts once.
Pairs whose boxes in the link frame meet with positive volume (boxes taken
rigorously: exact rationals for a primitive whose rotation is a signed
permutation, else widened by the rounding of the placement) are decided:

* **Meshes and boxes** (a box primitive is exactly 12 triangles) of one
  density are placed in the link frame and go through the pipeline ``props``
  runs on a file (:func:`massprops.compute.checked_solid`: welding, shells,
  exact intersection and nesting tests, the exact arrangement of
  :mod:`massprops.mesh.arrangement`).  Placing a vertex (``R (L x) + t`` in floats) moves
  it by at most ``δ = 9u (|R| |L| |x| + |t|)`` from its exact place: the
  swept-volume bound of :mod:`massprops.mesh.solid` covers it.  Then:

  - nothing met or nested: the geometries are disjoint, exactly; the link is
    the exact per-geometry sum, as before;
  - the volume counted twice by the sum (``Σ V_i − V_union``) is certified
    positive: the link is the union (``checks.overlap``, a warning);
  - otherwise they touch (or overlap by less than the rounding can tell): the
    sum is kept, with bounds that also cover the union (``|sum − union| +
    the union's bound``).

* **Primitives of one density** (sphere, cylinder, capsule, ellipsoid, cone,
  and boxes not united with a mesh) that may overlap one another, and none of
  them a mesh or a geometry of another density, are their union, computed by
  :mod:`massprops.robot.curved` (closed forms; prisms and other shapes on a
  certified grid refined until the bound is at most ``tolerance`` of the
  link's mass and inertia, or a warning says how far it got).

* **Otherwise** (a primitive meeting a mesh, different densities, meshes not
  read as closed surfaces, ``on_open``) the geometries stay whole.  Two
  spheres are decided exactly (``|c₁ − c₂| ≥ r₁ + r₂``); otherwise the volume
  counted twice is at most ``U``, the smaller of the boxes' intersection and
  either volume.  The error bounds are widened to cover the union: a
  double-counted mass ``μ ≤ ρU`` lying in the boxes' intersection ``B`` moves
  the mass by ``μ``, the center of mass by ``μ D / m'`` (``D`` the farthest of
  ``B`` from it per axis, ``m'`` a lower bound of the union's mass) and the
  inertia about it by ``μ R² + m (μ R / m')²`` (``R`` the farthest point of
  ``B``).  ``checks.unresolved_overlap`` holds ``U``; a warning says so when
  ``U`` exceeds the link's volume bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U
from ..model.errors import MassPropsError
from ..mesh.shells import joined_groups
from ..model.combine import combine_parts
from .units import volume_text
from .model import PRIMITIVES

__all__ = ["LinkSolid", "link_solid"]

_TINY = 16 * math.ldexp(1.0, -1074)      # underflow in a placement product
DEFAULT_TOLERANCE = 1e-9                 # relative bound asked of a link's union of overlapping primitives


@dataclass(frozen=True, eq=False)
class LinkSolid:
    """A link's geometries combined: ``props`` (link frame), ``checks`` (JSON-able) and ``warnings``."""

    props: object
    checks: dict
    warnings: tuple = ()


@dataclass(frozen=True, eq=False)
class _Piece:
    name: str
    kind: str
    props: object
    box: list                 # [low, high], each 3 Fractions: contains the geometry
    surface: object = None    # massprops.robot.geometry.Surface, or None (kept whole)
    placed: tuple = ()        # the surface in the link frame: (vertices, faces, move bound per vertex)
    checks: dict | None = None
    size: dict | None = None


def link_solid(link_name, results, *, repair=False, tolerance=DEFAULT_TOLERANCE):
    """The union of a link's geometries (see the module docstring).

    Parameters
    ----------
    results : list of (Geometry, MassProperties, GeometryResult)
        Each geometry with volume, its properties at its pose in the link frame.

    Returns
    -------
    LinkSolid
    """
    checks = {"overlap": 0.0, "duplicate_shells": 0, "unresolved_overlap": 0.0}
    if len(results) == 1:
        return LinkSolid(combine_parts([results[0][1]]), checks)
    pieces = [_piece(geometry, props, result) for geometry, props, result in results]
    pairs = [(i, j, _box_meet(pieces[i].box, pieces[j].box)) for i in range(len(pieces))
             for j in range(i + 1, len(pieces))]
    pairs = [(i, j, volume) for i, j, volume in pairs if volume > 0]
    unitable = [(i, j) for i, j, _ in pairs if _unitable(pieces[i], pieces[j])]
    warnings, parts = [], []
    unresolved = [(i, j, v) for i, j, v in pairs if (i, j) not in set(unitable) and not _apart(pieces[i], pieces[j])]
    clusters = _clusters(pieces, unitable, unresolved)
    clustered = {k for cluster in clusters for k in cluster}
    unresolved = [(i, j, v) for i, j, v in unresolved if i not in clustered]
    for cluster in clusters:
        part, said, facts = _curved_union(link_name, [pieces[k] for k in cluster], tolerance)
        parts.append(part)
        warnings += said
        checks["overlap"] += facts["overlap"]
        checks.setdefault("united", []).append([pieces[k].name for k in cluster])
    for group in joined_groups(range(len(pieces)), np.array(unitable, dtype=np.int64).reshape(-1, 2)):
        members = [pieces[k] for k in group]
        if len(group) == 1:
            if group[0] not in clustered:
                parts.append(members[0].props)
            continue
        try:
            part, facts, said = _united(link_name, members, repair)
        except MassPropsError as exc:
            warnings.append(f"link {link_name!r}: geometries {_names(members)} may overlap, but their union failed "
                            f"({exc.problem}): each is counted whole")
            unresolved += [(i, j, v) for i, j, v in pairs if i in group and j in group]
            parts += [m.props for m in members]
            continue
        parts += part
        checks["overlap"] += facts.get("overlap", 0.0)
        checks["duplicate_shells"] += facts.get("duplicate_shells", 0)
        if "united" in facts:
            checks.setdefault("united", []).append([m.name for m in members])
        warnings += said
    total = combine_parts(parts)
    if unresolved:
        summed = total
        total, bound = _bounded(summed, [(pieces[i], pieces[j], v) for i, j, v in unresolved], pieces)
        checks["unresolved_overlap"] = bound
        if bound > summed.error.volume:
            pairs_text = ", ".join(f"{pieces[i].name!r} ({pieces[i].kind}) and {pieces[j].name!r} ({pieces[j].kind})"
                                   for i, j, _ in unresolved)
            warnings.append(f"link {link_name!r}: geometries {pairs_text} may overlap: each is counted whole, at "
                            f"most {bound:.3g} m³ twice (checks.unresolved_overlap); the error bounds cover their "
                            "union")
    return LinkSolid(total, checks, tuple(warnings))


def _clusters(pieces, unitable, unresolved):
    """Groups of primitives of one density whose overlaps are computed (:mod:`massprops.robot.curved`).

    A group joins the primitives that may overlap; it is computed when none
    of them may also overlap a mesh, a geometry of another density, or is a box
    united with others through the arrangement.
    """
    def eligible(piece):
        return piece.kind in PRIMITIVES and piece.props.density > 0
    united = {k for pair in unitable for k in pair}
    curved = [(i, j) for i, j, _ in unresolved if eligible(pieces[i]) and eligible(pieces[j])
              and pieces[i].props.density == pieces[j].props.density]
    blocked = {k for i, j, _ in unresolved if (i, j) not in set(curved) for k in (i, j)} | united
    groups = joined_groups(range(len(pieces)), np.array(curved, dtype=np.int64).reshape(-1, 2))
    return [sorted(int(k) for k in group) for group in groups
            if len(group) > 1 and not any(k in blocked for k in group)]


def _curved_union(link_name, members, tolerance):
    """``(props, warnings, facts)``: the union of a group of primitives, computed (see the module docstring)."""
    from .curved import cluster_union, prims_of, props_of, raw_of
    summed = combine_parts([m.props for m in members])
    total = raw_of(summed)
    density = members[0].props.density
    reach = max(float(np.abs(m.props.pose.translation).max()) for m in members) + max(
        abs(float(m.box[1][k] - m.box[0][k])) for m in members for k in range(3))
    j_scale = float(np.abs(summed.inertia_com).max()) / density
    wanted = (tolerance * total.volume / 4, tolerance * total.volume * reach / 8, tolerance * j_scale / 16)
    found = cluster_union(prims_of(members), wanted)
    area = sum(m.props.surface_area for m in members)
    props = props_of(found.raw, density, area)
    if props is None:
        return summed, [f"link {link_name!r}: geometries {_names(members)} overlap and their union could not be "
                        "bounded: each is counted whole"], {"overlap": 0.0}
    twice = total.volume - found.raw.volume
    said = []
    if twice > found.raw.e_volume + total.e_volume:
        said.append(f"link {link_name!r}: geometries {_names(members)} overlap by {volume_text(twice)}: the link is their "
                    "union, each point counted once (checks.overlap)")
    if found.spent:
        relative = max(props.error.mass / props.mass, props.error.inertia_com / max(float(np.abs(
            props.inertia_com).max()), 1e-300))
        said.append(f"link {link_name!r}: the overlap of geometries {_names(members)} is computed to within "
                    f"{relative:.1e} of the link's mass and inertia, not the {tolerance:g} asked "
                    "({tolerance}): the refinement stopped at its budget")
    return props, said, {"overlap": max(twice, 0.0)}


def _names(members):
    names = [repr(m.name) for m in members]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


# -- boxes ------------------------------------------------------------------------

def _piece(geometry, props, result):
    surface = result.surface
    if props.density <= 0 or (result.checks or {}).get("welded_vertices"):
        # No mass to count twice; or a mesh closed by welding its noise, a move bounded in its own frame only.
        surface = None
    placed = _placed(surface) if surface is not None else ()
    return _Piece(geometry.name, geometry.kind, props, _box(geometry, result, placed), surface, placed, result.checks,
                  geometry.size)


def _box(geometry, result, placed):
    """The geometry's box in the link frame, rigorously (Fractions): exact where it can be, else widened."""
    pose = geometry.pose
    if geometry.kind == "sphere" or (geometry.kind != "mesh" and _permutation(pose.rotation)):
        half = _exact_half(geometry)
        centre = [Fraction(float(x)) for x in pose.translation]
        return [[c - h for c, h in zip(centre, half)], [c + h for c, h in zip(centre, half)]]
    if placed:
        points, _, moved = placed
        low, high = (points - moved[:, None]).min(axis=0), (points + moved[:, None]).max(axis=0)
        reach = np.zeros(3)
    else:
        low, high = result.bounds
        corners = np.abs(np.array([low, high]) - pose.translation).max(axis=0)
        # A primitive's box is a few roundings from exact.  A mesh taken by on_open is integrated on its scaled
        # floats p; placing them rounds by at most 5u (|R||p| + |t|), and |R||p| <= sqrt(3) |p| <= 2 |q - t|.
        reach = (8 * _U * np.maximum(np.abs(low), np.abs(high)) if geometry.kind != "mesh"
                 else 9 * _U * (2 * float(np.linalg.norm(corners)) + np.abs(pose.translation))) * (1 + 1e-9)
    reach = reach + _TINY
    return [[Fraction(float(x)) for x in np.nextafter(low - reach, -np.inf)],
            [Fraction(float(x)) for x in np.nextafter(high + reach, np.inf)]]


def _permutation(rotation):
    """Every element exactly 0 or ±1: the rotation maps axes onto axes, and boxes stay exact."""
    return bool(np.all((rotation == 0) | (np.abs(rotation) == 1)))


def _exact_half(geometry):
    """Half extents of a primitive's box in link axes, exactly (its rotation is a signed permutation)."""
    size = geometry.size
    kind = geometry.kind
    if kind == "box":
        own = [Fraction(float(x)) / 2 for x in size["size"]]
    elif kind == "sphere":
        return [Fraction(float(size["radius"]))] * 3
    elif kind == "ellipsoid":
        own = [Fraction(float(x)) for x in size["radii"]]
    else:
        r, h = Fraction(float(size["radius"])), Fraction(float(size["length"])) / 2
        own = [r, r, h + (r if kind == "capsule" else 0)]
    rotation = geometry.pose.rotation
    return [sum(abs(Fraction(float(rotation[i, k]))) * own[k] for k in range(3)) for i in range(3)]


def _box_meet(a, b):
    """Volume of the intersection of two boxes (a Fraction; 0 when they meet in less than a volume)."""
    volume = Fraction(1)
    for k in range(3):
        extent = min(a[1][k], b[1][k]) - max(a[0][k], b[0][k])
        if extent <= 0:
            return Fraction(0)
        volume *= extent
    return volume


def _unitable(a, b):
    return a.surface is not None and b.surface is not None and a.props.density == b.props.density


def _apart(a, b):
    """Decided exactly: two spheres that meet in at most a point."""
    if a.kind == b.kind == "sphere":
        d2 = sum((Fraction(float(x)) - Fraction(float(y))) ** 2
                 for x, y in zip(a.props.pose.translation, b.props.pose.translation))
        return d2 >= (_radius(a) + _radius(b)) ** 2
    return False


def _radius(sphere):
    """A sphere's radius, exactly: half its exact box."""
    return (sphere.box[1][0] - sphere.box[0][0]) / 2


# -- union --------------------------------------------------------------------------

def _placed(surface):
    """``(vertices, faces, moved)``: the surface in the link frame, rounded, and a bound on each vertex's move."""
    vertices = surface.mesh.vertices
    points = surface.pose.apply(vertices @ surface.linear.T)
    reach = 9 * _U * ((np.abs(vertices) @ np.abs(surface.linear).T) @ np.abs(surface.pose.rotation).T
                      + np.abs(surface.pose.translation)) * (1 + 1e-9) + _TINY
    return points, surface.mesh.faces, np.linalg.norm(reach, axis=1) * (1 + 1e-9)


def _combined(placed):
    """Placed surfaces ``(vertices, faces, moved)`` as one mesh, and each vertex's move bound.

    Each geometry keeps its own vertices: welding two geometries where they
    share a point would join them into one shell, which the solid machinery
    would then refuse as crossing itself wherever they overlap.
    """
    from ..mesh import TriangleMesh
    points, faces, offset = [], [], 0
    for p, f, _ in placed:
        points.append(p)
        faces.append(f + offset)
        offset += p.shape[0]
    return TriangleMesh(np.vstack(points), np.vstack(faces)), np.concatenate([m for _, _, m in placed])


def _without_copies(members):
    """``(distinct, copies)``: members with their placed surfaces, and members placed exactly like an earlier one."""
    distinct, copies = [], []
    for member in members:
        placed = member.placed
        if any(np.array_equal(placed[0], p[0]) and np.array_equal(placed[1], p[1]) for _, p in distinct):
            copies.append(member)
        else:
            distinct.append((member, placed))
    return distinct, copies


def _united(link_name, members, repair):
    """``(parts, facts, warnings)`` for a group of meshes and boxes whose boxes meet (see the module docstring)."""
    from ..compute import checked_solid
    from ..mesh.solid import swept_volume, widened
    from ..model.properties import MassProperties
    distinct, copies = _without_copies(members)
    facts, said = {}, []
    if copies:
        facts = {"overlap": sum(c.props.volume for c in copies), "united": True,
                 "duplicate_shells": sum((c.checks or {}).get("shells", 1) for c in copies)}
        said.append(f"link {link_name!r}: geometries {_names(copies)} repeat others exactly: each point counted "
                    "once (checks.duplicate_shells)")
    parts = [m.props for m, _ in distinct]
    if len(distinct) == 1:
        return parts, facts, said
    mesh, moved = _combined([p for _, p in distinct])
    checked = checked_solid(mesh, repair=repair)
    if not checked.resolved and not any(m.surface.resolved for m, _ in distinct):
        return parts, facts, said                              # nothing met or nested: disjoint, exactly
    touched = np.flatnonzero(moved)
    swept = swept_volume(mesh.vertices, mesh.faces, touched, moved[touched])
    moments = widened(checked.moments, mesh.vertices, swept=swept, reach=float(moved.max()))
    union = MassProperties.from_moments(moments, density=members[0].props.density)
    summed = combine_parts(parts)
    twice = summed.volume - union.volume
    unsure = (summed.error.volume + union.error.volume) * (1 + 1e-9)
    if twice < -unsure:
        raise MassPropsError(f"the union's volume {union.volume:.17g} exceeds the sum of the parts' "
                             f"{summed.volume:.17g}")
    if twice <= unsure:
        return [_within(summed, union)], facts, said            # they touch: the sum, bounded by the union
    nested = [r for r in checked.resolved if "meet" not in r]
    said.append(f"link {link_name!r}: geometries {_names([m for m, _ in distinct])} overlap by {volume_text(twice)}"
                f"{' (' + '; '.join(nested) + ')' if nested else ''}; counted once (checks.overlap)")
    facts = {"overlap": facts.get("overlap", 0.0) + twice, "united": True,
             "duplicate_shells": facts.get("duplicate_shells", 0)}
    return [union], facts, said


def _within(summed, union):
    """The sum's values with bounds that cover the union's exact values: ``|sum − union| + union's bound``."""
    def gap(a, b):
        return float(np.max(np.abs(np.asarray(a, float) - np.asarray(b, float)))) * (1 + 4 * _U)

    error = replace(summed.error,
                    volume=max(summed.error.volume, gap(summed.volume, union.volume) + union.error.volume),
                    mass=max(summed.error.mass, gap(summed.mass, union.mass) + union.error.mass),
                    center_of_mass=max(summed.error.center_of_mass, gap(summed.center_of_mass, union.center_of_mass)
                                       + union.error.center_of_mass),
                    inertia_com=max(summed.error.inertia_com, gap(summed.inertia_com, union.inertia_com)
                                    + union.error.inertia_com))
    return replace(summed, error=error)


# -- kept whole -------------------------------------------------------------------

def _bounded(total, unresolved, pieces):
    """``total`` with bounds covering the union when pairs ``(a, b, box volume)`` each count some volume twice.

    Returns the widened total and ``U``, the volume counted twice at most (m³).
    """
    bound, mass = 0.0, 0.0
    low = [min(max(a.box[0][k], b.box[0][k]) for a, b, _ in unresolved) for k in range(3)]
    high = [max(min(a.box[1][k], b.box[1][k]) for a, b, _ in unresolved) for k in range(3)]
    for a, b, volume in unresolved:
        pair = min(float(volume) * (1 + 2 * _U), a.props.volume + a.props.error.volume,
                   b.props.volume + b.props.error.volume)
        bound += pair
        mass += pair * max(a.props.density, b.props.density)
    bound *= 1 + 4 * _U
    mass *= 1 + 4 * _U
    com = total.center_of_mass
    far = np.maximum(np.abs(np.array([float(x) for x in low]) - com), np.abs(np.array([float(x) for x in high]) - com))
    across = float(far.max()) * (1 + 4 * _U)
    radius = float(np.linalg.norm(far)) * (1 + 4 * _U)
    # The union holds every geometry: its mass is at least the heaviest one's, and at least the sum less μ.
    lowest = max(total.mass - mass, max(p.props.mass for p in pieces) * (1 - 4 * _U))
    moved, turned = 0.0, 0.0                         # no mass counted twice (massless geometries) moves nothing
    if mass > 0 and lowest > 0:
        shift = mass * radius / lowest
        moved = mass * across / lowest * (1 + 1e-9)
        turned = (mass * radius ** 2 + total.mass * shift ** 2) * (1 + 1e-9)
    error = replace(total.error, volume=total.error.volume + bound, mass=total.error.mass + mass,
                    center_of_mass=total.error.center_of_mass + moved, inertia_com=total.error.inertia_com + turned)
    return replace(total, error=error), bound
