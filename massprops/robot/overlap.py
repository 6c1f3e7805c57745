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
  and boxes) that may overlap one another, and none of them a mesh, are their
  union, computed by :mod:`massprops.robot.curved` (closed forms; prisms and
  other shapes on a certified grid refined until the bound is at most
  ``tolerance`` of the link's mass and inertia; when it stays above, the
  group is computed again through inner and outer polyhedra as below, boxes
  as their triangles, and the tighter bound kept; else a warning says how far
  it got).

* **Curved primitives meeting meshes** (and boxes) of one density: first what
  needs no tessellation, certified: a mesh whose every exactly placed vertex
  is inside a primitive (floats with a margin over the vertex's move and
  rounding, else exact rationals ``y = R⁻¹ (x − t)``) lies in it, the
  primitive being convex: counted once; a primitive that a plane separates
  from every mesh's vertices (support functions with a margin) and from the
  other primitives is counted whole.  The rest is united through polyhedra
  (:mod:`massprops.robot.tessellate`): ``P_in ⊂ P ⊂ P_out`` for each curved
  primitive ``P``, with ``n`` points around each circle, placed like a mesh
  (their construction's rounding added to each vertex's move).  With ``M``
  the meshes and boxes, ``X_in = M ∪ ⋃ P_in`` and ``X_out = M ∪ ⋃ P_out`` go
  through the same exact pipeline, as do each ``P_in`` and ``P_out`` alone;
  every volume below is taken at the end of its bound that makes the result
  larger.  ``X_in ⊂ U ⊂ X_out`` (``U`` the union wanted), so

  - *between*: the middle of ``X_in`` and ``X_out`` is within ``W/2`` of
    ``U``'s volume, ``W = vol X_out − vol X_in``, and each first (second)
    moment about ``ref`` within ``W/2 · ρ`` (``W/2 · ρ²``), ``ρ`` the farthest
    any vertex of ``X_out`` (plus its move) is from ``ref`` in any axis;
  - *sharp*: ``E = X_in + Σ (P − P_in)`` (``P`` in closed form) counts the
    bands ``B_j = P_j \\ P_j,in`` in full, where ``U`` counts them only outside
    ``X_in`` and each other: the excess is ``f(B) = Σ vol B_j − vol(⋃ B_j \\
    X_in)``.  ``f`` grows with each ``B_j`` (a point added to one adds 1 to the
    sum and at most 1 to the union), and ``B_j ⊂ P_j,out \\ P_j,in``, so
    ``0 ≤ f(B) ≤ w = Σ (vol P_j,out − vol P_j,in) − W``: the bands that lie in
    the other geometries.  ``U``'s volume is ``E − w/2 ± w/2``, each moment
    within ``w ρ`` or ``w ρ²``.

  The smaller of ``w`` and ``W/2`` is taken.  Every other source is in the
  pipeline's bounds: the arrangement's, the placement's and the
  construction's rounding (swept volume of the moved vertices, as for
  meshes), and the closed forms'.  ``n`` starts at 16 and jumps to where the
  bound, which falls as ``1/n²``, should meet the tolerance, up to 1024
  points around, 2¹⁹ triangles on the inner polyhedra and ``_TIME_BUDGET``
  seconds of the process's processor time, not wall time (each mesh's triangles cut at their edges' midpoints, exactly,
  until few polyhedron edges cross one: the arrangement's time grows with
  their square); then a warning
  says to what the mass and inertia are known.  Convergence is quadratic in
  ``n``, but only where ``P``'s surface lies outside the others (``w``) or
  inside them (``W``): a primitive half in a mesh keeps about half its band,
  about 1e-5 of a sphere's volume at the budget.

* **Otherwise** (different densities, meshes not read as closed surfaces,
  ``on_open``, a union that failed its checks) the geometries stay whole.  Two
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
import time
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U
from ..model.errors import MassPropsError, option
from ..mesh.shells import joined_groups
from ..model.combine import combine_parts
from .units import volume_text
from .model import PRIMITIVES
from .tessellate import CURVED

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
    pairs = [(i, j, volume) for i, j, volume in pairs if volume > 0 and not _apart(pieces[i], pieces[j])]
    joined = [(i, j) for i, j, _ in pairs if _joinable(pieces[i], pieces[j])]
    unresolved = [(i, j, v) for i, j, v in pairs if (i, j) not in set(joined)]
    warnings, parts = [], []
    for group in joined_groups(range(len(pieces)), np.array(joined, dtype=np.int64).reshape(-1, 2)):
        members = [pieces[k] for k in group]
        if len(group) == 1:
            parts.append(members[0].props)
            continue
        meshes = any(m.kind not in PRIMITIVES for m in members)
        curved = any(m.kind in CURVED for m in members)
        try:
            if not curved:
                part, facts, said = _united(link_name, members, repair)
            elif not meshes:
                part, facts, said = _curved_union(link_name, members, tolerance)
            else:
                part, facts, said = _mixed(link_name, members, repair, tolerance)
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


def _curved_union(link_name, members, tolerance):
    """``(parts, facts, warnings)``: the union of a group of primitives, computed (see the module docstring)."""
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
        raise MassPropsError("its bound exceeds its volume")
    twice = total.volume - found.raw.volume
    said = []
    if twice > found.raw.e_volume + total.e_volume:
        said.append(f"link {link_name!r}: geometries {_names(members)} overlap by {volume_text(twice)}: the link is their "
                    "union, each point counted once (checks.overlap)")
    placed = combine_parts([props])
    relative = max(placed.error.mass / placed.mass, placed.error.inertia_com / max(float(np.abs(
        placed.inertia_com).max()), 1e-300))
    if relative > tolerance:
        # The grid converges linearly; polyhedra inside and around the curved ones, through the exact arrangement,
        # converge quadratically: taken when tighter.
        curved = [m for m in members if m.kind in CURVED]
        boxes = [m for m in members if m.kind not in CURVED]
        if all(m.surface is not None for m in boxes):
            try:
                part, facts, words = _tessellated(link_name, boxes, curved, False, tolerance)
            except MassPropsError:
                part = None
            if part is not None and facts["relative"] < relative:
                facts["united"] = True
                return part, facts, words
        said.append(f"link {link_name!r}: the overlap of geometries {_names(members)} is computed to within "
                    f"{relative:.1e} of the link's mass and inertia, not the {tolerance:g} asked "
                    "({tolerance}): " + ("the refinement stopped at its budget" if found.spent else
                                         "members modelled on a common axis they are off by more than rounding"))
    return [props], {"overlap": max(twice, 0.0), "united": True}, said


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


def _joinable(a, b):
    """United (not kept whole): one positive density, each a closed surface (mesh, box) or a curved primitive."""
    def eligible(piece):
        return piece.surface is not None or (piece.kind in CURVED and piece.props.density > 0)
    return eligible(a) and eligible(b) and a.props.density == b.props.density


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


# -- curved primitives meeting meshes -------------------------------------------------

_FACE_BUDGET = 1 << 19          # triangles of the inner polyhedra together, at the finest refinement
_FIRST_SEGMENTS = 16            # points around each circle at the first refinement
_TIME_BUDGET = 2.0              # seconds of processor time a union may take to refine (a level is not started
                                # beyond it); processor time, not wall time, so that a busy machine gives the same bound
_MOST_SEGMENTS = 1024          # points around at most: a face a ring cuts has as many edges, triangulated


def _mixed(link_name, members, repair, tolerance):
    """``(parts, facts, warnings)`` for meshes, boxes and curved primitives whose boxes meet (module docstring).

    Certified first, no tessellation: a mesh or box whose every vertex lies in a curved primitive is inside it
    (counted once); a curved primitive a plane separates from every mesh and box, and from every other curved
    primitive, is apart (counted whole).
    """
    from .curved import _separated, prims_of
    from .tessellate import apart, inside_all
    solids = [m for m in members if m.kind not in CURVED]
    curved = [m for m in members if m.kind in CURVED]
    said, facts, parts = [], {"overlap": 0.0, "united": True}, []
    prims = dict(zip((id(c) for c in curved), prims_of(curved)))
    kept = []
    for solid in solids:
        host = next((c for c in curved if inside_all(prims[id(c)], solid.surface, solid.placed)), None)
        if host is None:
            kept.append(solid)
            continue
        facts["overlap"] += solid.props.volume
        said.append(f"link {link_name!r}: {solid.kind} {solid.name!r} lies inside {host.kind} {host.name!r} "
                    f"({volume_text(solid.props.volume)}): counted once (checks.overlap)")
    eps = 64 * _U * max(float(np.abs(c.props.pose.translation).max()) + max(float(b - a) for a, b in
                                                                             zip(*c.box)) for c in curved)

    off_solids = {id(c): all(apart(prims[id(c)], s.placed) for s in kept) for c in curved}

    def alone(c):
        return (off_solids[id(c)]
                and all(_box_meet(c.box, d.box) == 0 or _separated(prims[id(c)], prims[id(d)], eps)
                        for d in curved if d is not c))
    loose = [c for c in curved if alone(c)]
    parts += [c.props for c in loose]
    curved = [c for c in curved if not any(c is x for x in loose)]
    touching = [c for c in curved if not off_solids[id(c)]]
    if not touching:                          # the curved ones meet only each other: their own union
        for group, union in ((kept, _united), (curved, None)):
            if len(group) == 1:
                parts.append(group[0].props)
            elif len(group) > 1:
                part, more, words = (union(link_name, group, repair) if union
                                     else _curved_union(link_name, group, tolerance))
                parts += part
                facts["overlap"] += more.get("overlap", 0.0)
                facts["duplicate_shells"] = facts.get("duplicate_shells", 0) + more.get("duplicate_shells", 0)
                said += words
        return parts, facts, said
    part, more, words = _tessellated(link_name, kept, curved, repair, tolerance)
    facts["overlap"] += more["overlap"]
    return parts + part, facts, said + words


def _union_props(placed, density, repair):
    """:class:`MassProperties` (link frame) of the union of placed surfaces, bounds covering their moves."""
    from ..compute import checked_solid
    from ..mesh.solid import swept_volume, widened
    from ..model.properties import MassProperties
    mesh, moved = _combined(placed)
    checked = checked_solid(mesh, repair=repair)
    touched = np.flatnonzero(moved)
    swept = swept_volume(mesh.vertices, mesh.faces, touched, moved[touched])
    moments = widened(checked.moments, mesh.vertices, swept=swept, reach=float(moved.max()))
    return MassProperties.from_moments(moments, density=density)


def _polyhedron(member, segments, outer):
    """The inner or outer polyhedron of a curved primitive, placed: ``(vertices, faces, move bound)``."""
    from ..mesh import TriangleMesh
    from .geometry import Surface
    from .tessellate import tessellation
    vertices, faces, delta = tessellation(member.kind, member.size, segments, outer)
    points, faces, moved = _placed(Surface(TriangleMesh(vertices, faces), np.eye(3), member.props.pose))
    return points, faces, moved + delta * (1 + 1e-6)


def _subdivided(placed, longest, most=1 << 12):
    """A placed surface ``(vertices, faces, moves)`` with each triangle cut into 4 at its edges' midpoints until no
    edge is longer than ``longest`` (or the faces would pass ``most``): the same surface, each new vertex within
    the larger move of its edge's ends, plus the rounding of ``(a + b) / 2`` (at most ``u |a + b| / 2`` a
    coordinate), of the exact midpoint of the exact ends.  A face a fine polyhedron crosses
    is then cut by few of its edges, which the arrangement resolves in time linear, not quadratic, in them."""
    points, faces, moved = placed
    while faces.shape[0] * 4 <= most:
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        lengths = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)
        if float(lengths.max()) <= longest:
            break
        keys = np.sort(edges, axis=1)
        unique, index = np.unique(keys, axis=0, return_inverse=True)
        index = index.reshape(-1)
        middle = (points[unique[:, 0]] + points[unique[:, 1]]) / 2
        reach = (np.maximum(moved[unique[:, 0]], moved[unique[:, 1]])
                 + _U * np.linalg.norm(middle, axis=1) * (1 + 8 * _U))
        base = points.shape[0]
        m = faces.shape[0]
        ab, bc, ca = (base + index[:m], base + index[m:2 * m], base + index[2 * m:])
        a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
        faces = np.vstack([np.column_stack([a, ab, ca]), np.column_stack([ab, b, bc]),
                           np.column_stack([ca, bc, c]), np.column_stack([ab, bc, ca])]).astype(np.int64)
        points = np.vstack([points, middle])
        moved = np.concatenate([moved, reach])
    return points, faces, moved


def _meeting_reach(surfaces, outer, ref):
    """The farthest, per axis, from ``ref`` that a band ``P_j,out \\ P_j,in`` inside another geometry can be: over
    the intersections of each outer polyhedron's box with every other geometry's box (vertices ± moves)."""
    boxes = [(p[0].min(axis=0) - p[2].max(), p[0].max(axis=0) + p[2].max()) for p in surfaces + outer]
    first = len(surfaces)
    reach = 0.0
    for j in range(first, len(boxes)):
        for i in range(len(boxes)):
            if i == j:
                continue
            low, high = np.maximum(boxes[i][0], boxes[j][0]), np.minimum(boxes[i][1], boxes[j][1])
            if np.all(high >= low):
                reach = max(reach, float(np.maximum(np.abs(low - ref), np.abs(high - ref)).max()))
    return reach * (1 + 4 * _U)


def _tessellated(link_name, solids, curved, repair, tolerance):
    """``(parts, facts, warnings)``: the union of meshes and boxes ``solids`` and curved primitives ``curved``
    of one density, refined until its bound is at most ``tolerance`` or the budget is spent (module docstring)."""
    from .curved import Raw, props_of, raw_of
    from .tessellate import faces_for
    density = curved[0].props.density
    summed = combine_parts([m.props for m in solids + curved])
    surfaces = [s.placed for s in solids]
    segments, finest = _FIRST_SEGMENTS, _FIRST_SEGMENTS
    while 2 * finest <= _MOST_SEGMENTS and sum(faces_for(c.kind, 2 * finest) for c in curved) <= _FACE_BUDGET:
        finest *= 2
    largest = max(max(float(b - a) for a, b in zip(*c.box)) for c in curved)
    started = None
    stopped = "triangles"
    while True:
        level_started = time.process_time()
        # Faces of the meshes and boxes cut to a few of the polyhedra's edges across (see _subdivided).
        surfaces = [_subdivided(s.placed, 8 * math.pi * largest / segments) for s in solids]
        inner = [_polyhedron(c, segments, False) for c in curved]
        outer = [_polyhedron(c, segments, True) for c in curved]
        x_in = _union_props(surfaces + inner, density, repair)
        x_out = _union_props(surfaces + outer, density, repair)
        p_in = [_union_props([p], density, False) for p in inner]
        p_out = [_union_props([p], density, False) for p in outer]
        grow = 1 + 16 * _U
        # W: the volume between the two unions; w: the bands P_out \ P_in inside the other geometries.
        band = sum((o.volume + o.error.volume) - (i.volume - i.error.volume) for i, o in zip(p_in, p_out)) * grow
        between = ((x_out.volume + x_out.error.volume) - (x_in.volume - x_in.error.volume)) * grow
        between_low = ((x_out.volume - x_out.error.volume) - (x_in.volume + x_in.error.volume)) / grow
        inside = max(0.0, band - between_low) * grow
        points = np.vstack([p[0] for p in surfaces + outer])
        if inside < between / 2:
            # The sharp estimate union(M, P_in) + Σ (P − P_in) counts the bands inside the others once too
            # often: the union's volume lies in [E − w, E] (its middle taken), every moment within w·reach^k.
            estimate = raw_of(x_in)
            for c, p in zip(curved, p_in):
                estimate = estimate + (raw_of(c.props) - raw_of(p))
            estimate = replace(estimate, volume=estimate.volume - inside / 2,
                               e_volume=estimate.e_volume * grow + inside / 2 + _U * abs(estimate.volume))
            extra, how = inside, "sharp"
        else:
            # The union lies between union(M, P_in) and union(M, P_out): their middle, within W/2·reach^k.
            low, high = raw_of(x_in), raw_of(x_out)
            both = low + high
            estimate = Raw(both.volume / 2, both.first / 2, both.second / 2, both.e_volume / 2, both.e_first / 2,
                           both.e_second / 2, both.ref)
            extra, how = between / 2, "between"
        if how == "sharp":
            reach = _meeting_reach(surfaces, outer, estimate.ref)
        else:
            reach = float(np.abs(points - estimate.ref).max()) + max(float(p[2].max()) for p in surfaces + outer)
        reach *= 1 + 1e-9
        estimate = Raw(estimate.volume, estimate.first, estimate.second,
                       estimate.e_volume + (0.0 if how == "sharp" else extra),
                       estimate.e_first + extra * reach, estimate.e_second + extra * reach * reach, estimate.ref)
        props = props_of(estimate, density, x_in.surface_area)
        if props is None:
            raise MassPropsError("its bound exceeds its volume")
        placed = combine_parts([props])       # as the link combines it: the center's bound reaches the inertia
        relative = max(placed.error.mass / placed.mass,
                       placed.error.inertia_com / max(float(np.abs(placed.inertia_com).max()), 1e-300))
        if relative <= tolerance or segments >= finest:
            break
        # The bound shrinks as 1/n²: jump to where it should meet the tolerance, within the budget of triangles
        # and of time (a level's time taken to grow at most as n², as it does where coplanar faces are cut).
        now = time.process_time()
        if started is None:
            started = now       # the first level, always run, is not charged: it pays for modules' first use
        spent, last = now - started, now - level_started
        affordable = min(finest, segments * math.sqrt(max(0.0, _TIME_BUDGET - spent) / max(last, 1e-3)))
        wanted = segments * math.sqrt(relative / tolerance) * 1.2
        step = min(finest, max(2 * segments, 4 * math.ceil(wanted / 4)), 4 * math.floor(affordable / 4))
        if step <= segments:
            stopped = "time"
            break
        segments = step
    twice = summed.volume - props.volume
    faces = sum(faces_for(c.kind, segments) for c in curved)
    names = _names(solids + curved)
    if twice > props.error.volume + summed.error.volume:
        text = f"link {link_name!r}: geometries {names} overlap by about {volume_text(twice)}; counted once"
    else:
        text = f"link {link_name!r}: geometries {names} touch or overlap by less than their bound; united"
    text += f" (checks.overlap), mass and inertia known to {relative:.1e}"
    if relative > tolerance:
        text += (f", not the {tolerance:g} asked ({option('tolerance')}): the refinement stopped at its budget "
                 + (f"of {_TIME_BUDGET:g} s of processor time" if stopped == "time" else "of triangles")
                 + f", {faces} on the curved ones")
    return [props], {"overlap": max(twice, 0.0), "relative": relative, "segments": segments, "bound": how}, [text]


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
