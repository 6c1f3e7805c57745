"""Shells of a closed mesh: which bound ``{w > 0}``, which nest, which faces meet and must be arranged.

The policy is described in :mod:`massprops.mesh.solid`; this module carries it
out.  One exact search lists every pair of faces that meet beyond what they
share; with none, shells only nest (or are one), and an exact point-in-solid
test per shell decides; with any, or with faces that count more than once,
the arrangement (:mod:`massprops.mesh.arrangement`) finds the solid.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import _core
from ..core.frame import check_box_range
from ..core import intersect
from ..core.intersect import ExactGeometry, _extension
from ..model.errors import MeshGeometryError
from .solid import Solid, shell_six_volumes, swept_sum, swept_volume

__all__ = ["solid_of", "resolve_shells", "joined_groups"]


_LOADED = []


def _arrangement():
    """:mod:`massprops.mesh.arrangement`, imported when first needed (an import statement inside the
    function costs ~10 us a call; importing it here would slow every start)."""
    if not _LOADED:
        from . import arrangement
        _LOADED.append(arrangement)
    return _LOADED[0]


def _geometry(vertices):
    return ExactGeometry(vertices)


def _snapped(geometry, vertices, faces):
    """Volume the decisions could misjudge: coordinates below 2**-200 of the part were taken as zero."""
    if geometry.moved_vertices.size == 0:
        return 0.0
    return swept_volume(vertices, faces, geometry.moved_vertices, geometry.moved)


def solid_of(mesh, labels, n_shells, *, path=None, repair=False, self_intersection=None, weights=None):
    """The solid ``mesh`` bounds, for a closed mesh (:func:`massprops.mesh.surface.check_shells`).

    Parameters
    ----------
    mesh : TriangleMesh
        Closed (counting ``weights``), repeated faces already merged.
    labels : ndarray, shape (m,), int
        Shell of each face; ``n_shells`` of them.
    repair : bool
        Turn shells wound inside out (inward, outside every other shell) outward instead of refusing.
    self_intersection : bool or None
        False: a one-shell mesh is integrated as it is, without looking for
        faces that cross (its signed volume); otherwise (the default) every
        mesh is searched, at every size.
    weights : ndarray, shape (m,), int, optional
        How many times each face counts (repeated faces), default once.

    Returns
    -------
    Solid
    """
    return resolve_shells(mesh, labels, n_shells, check_self=self_intersection is not False, path=path,
                          repair=repair, weights=weights)


def resolve_shells(mesh, labels, n_shells, *, check_self, path=None, repair=False, weights=None):
    """See :func:`solid_of` (which chooses ``check_self``)."""
    vertices, faces = mesh.vertices, mesh.faces
    if vertices.shape[0]:
        # Shell volumes are compared in mesh units³: they must not underflow or overflow there.  (The box in
        # one compiled pass: numpy's min and max along the rows of (n, 3) are ~10x slower on a small part.)
        low, high = _core.bounding_box(vertices)
        check_box_range([hi - lo for lo, hi in zip(low, high)])    # inf past the largest double: refused later
    repeated = weights is not None and bool(np.any(weights != 1))
    if not check_self and n_shells == 1 and not repeated:
        return Solid(mesh, {"self_intersection": "not checked"})
    geometry = _geometry(vertices)
    # closed: check_shells found every edge used as often each way; faces merged with weights need not be
    pairs, pinched = geometry.crossing_pairs(faces, labels, n_shells, closed=weights is None)
    # A shell of faces that share vertices is one body only when its faces turn once around each vertex;
    # bodies that touch at a vertex or an edge (perhaps one wound inward) are told apart by the arrangement.
    if pairs.size or repeated or pinched != 0:
        return _arranged(mesh, labels, n_shells, geometry, pairs, weights if repeated else None, path)
    if n_shells == 1:
        return Solid(mesh, {"self_intersection": "none"}, swept_volume=_snapped(geometry, vertices, faces),
                     frame=geometry.frame, scaled=geometry.unsnapped)
    return _nested(mesh, labels, n_shells, geometry, path, repair)


def _nested(mesh, labels, n_shells, geometry, path, repair):
    """Shells that do not meet: each bounds ``{w > 0}``, or lies inside others wound alike and adds nothing."""
    vertices, faces = mesh.vertices, mesh.faces
    checks = {"self_intersection": "none"}
    six, bound = shell_six_volumes(vertices, faces, labels, n_shells, geometry.frame)
    zero = _zero_shells(vertices, faces, labels, six, bound)
    live = ~zero
    warnings = []
    if zero.any():
        count = int(zero.sum())
        warnings.append(f"{count} shell{'s' if count > 1 else ''} enclose{'s' if count == 1 else ''} zero volume "
                        "(within rounding: flat, or two-sided): dropped")
    if not live.any():
        raise MeshGeometryError("the solid has zero volume (flat or degenerate: the faces enclose nothing)",
                                path=path, fix="check the export; a surface needs {shell=THICKNESS}")
    flipped = bool(np.all(six[live] < 0))
    sign = -1.0 if flipped else 1.0
    six = six * sign
    if flipped:
        faces = faces[:, ::-1].copy()
    boxes = _shell_boxes(vertices, faces, labels, n_shells)
    units = [[int(s)] for s in np.flatnonzero(live)]
    classes = _classify(geometry, vertices, faces, labels, units, boxes, six, path)
    inside_out = [u for u, (kind, w) in zip(units, classes) if kind < 0 and w == 0]
    if inside_out and repair:
        # Turned outward, the shells change every winding number: classify again.
        faces = faces.copy()
        for unit in inside_out:
            chosen = np.isin(labels, unit)
            faces[chosen] = faces[chosen][:, ::-1]
            six[unit] = -six[unit]
        warnings.append(f"turned {len(inside_out)} inside-out shells outward")
        classes = _classify(geometry, vertices, faces, labels, units, boxes, six, path)
    keep, negative = _decide(units, classes)
    if negative:
        warnings.append(f"{negative} shell{'s are' if negative > 1 else ' is'} wound inward outside every body "
                        "(a negative winding number, as inside a surface turned inside out): not part of the solid "
                        "(repair turns separate bodies outward)")
    dropped = len(units) - len(keep) - negative
    resolved = []
    if dropped:
        checks["dropped_shells"] = dropped
        resolved.append(f"{dropped} shell{'s lie' if dropped > 1 else ' lies'} inside others with the same "
                        "orientation")
    naive = (float(six[live].sum()), float(bound[live].sum()))
    swept = _snapped(geometry, vertices, faces)
    if not resolved and not negative and not zero.any() and not flipped and faces is mesh.faces:
        return Solid(mesh, checks, tuple(warnings), swept, frame=geometry.frame, scaled=geometry.unsnapped)
    kept = faces[np.isin(labels, [u[0] for u in keep])].astype(np.int64)
    extra = dict(resolved=tuple(resolved), naive_six=naive) if resolved else {}
    return Solid(mesh.with_faces(kept), checks, tuple(warnings), swept, faces[zero[labels]], flipped, **extra,
                 frame=geometry.frame, scaled=geometry.unsnapped)


def _decide(units, classes):
    """Units that bound ``{w > 0}``, and how many lie where the winding number is negative."""
    keep, negative = [], 0
    for unit, (kind, w) in zip(units, classes):
        if (kind > 0 and w == 0) or (kind < 0 and w == 1):
            keep.append(unit)
        elif w < 0 or (kind < 0 and w == 0):
            negative += 1
    return keep, negative


def _arranged(mesh, labels, n_shells, geometry, pairs, weights, path):
    """The solid of a soup whose faces meet or repeat, through the exact arrangement (``weights`` None: each
    face counts once)."""
    arrange = _arrangement().arrange
    vertices, faces = mesh.vertices, mesh.faces
    repeats = weights is not None
    weights = np.asarray(weights, dtype=np.int64) if repeats else np.ones(faces.shape[0], dtype=np.int64)
    if repeats:
        six, bound = shell_six_volumes(vertices, np.repeat(faces, weights, axis=0), np.repeat(labels, weights),
                                       n_shells, geometry.frame)
    else:
        six, bound = shell_six_volumes(vertices, faces, labels, n_shells, geometry.frame)
    area = ~geometry.zero_area(faces)
    if area.all():
        # (no face of zero area: the faces as they are, not copies renumbered)
        arrange_faces, arrange_weights, arrange_pairs = faces, weights, pairs
    else:
        index = np.cumsum(area) - 1
        arrange_faces, arrange_weights, arrange_pairs = faces[area], weights[area], index[pairs]
    arranged = arrange(geometry, arrange_faces, arrange_weights, arrange_pairs)
    flipped = False
    if _empty(arranged):
        # Positive nowhere: a surface wound inward as a whole (the file's convention), turned as a whole.
        flipped = True
        faces = faces[:, ::-1].copy()
        six = -six
        arranged = arrange(geometry, faces[area], arrange_weights, arrange_pairs)
        if _empty(arranged):
            raise MeshGeometryError("the solid has zero volume: the faces enclose nothing (every region they wind "
                                    "around cancels)", path=path,
                                    fix="check the export; a surface needs {shell=THICKNESS}")
    # (one shell: every pair is within it)
    within = labels[pairs[:, 0]] == labels[pairs[:, 1]] if n_shells > 1 else None
    resolved = []
    crossing = pairs.shape[0] if within is None else int(within.sum())
    if crossing:
        resolved.append(f"the surface crosses itself ({crossing} pair{'s' if crossing != 1 else ''} of faces)")
    if within is not None and not within.all():
        met = np.unique(labels[pairs[~within]])
        inward = int(np.count_nonzero(six[met] < 0))
        if inward:
            resolved.append(f"{inward} cavit{'ies' if inward > 1 else 'y'} (a shell wound inward) "
                            f"cross{'' if inward > 1 else 'es'} a body's surface")
        resolved.append(f"{met.size} shells meet")
    if repeats:
        resolved.append("faces repeat")
    warnings = []
    unsure = np.flatnonzero(np.abs(six) <= bound)
    flat = _flat_shells(geometry, faces, labels, unsure, ~area) if unsure.size else 0
    if flat:
        warnings.append(f"{flat} shell{'s' if flat > 1 else ''} enclose{'s' if flat == 1 else ''} zero volume "
                        "(flat, or folded onto itself): the region each encloses is empty or cancels")
    if arranged.negative:
        warnings.append("some regions are wound inward (a negative winding number, as inside a surface turned "
                        "inside out): they are not part of the solid")
    checks = {"self_intersection": "resolved" if crossing else "none"}
    combined, swept = _with_pieces(geometry, vertices, arranged)
    return Solid(mesh.with_faces(np.vstack([arranged.faces, arranged.pieces]), combined), checks, tuple(warnings),
                 _snapped(geometry, vertices, faces) + swept, flipped=flipped, resolved=tuple(resolved),
                 naive_six=(float(six.sum()), float(bound.sum())), frame=geometry.frame,
                 source=mesh.with_faces(faces))


def _with_pieces(geometry, vertices, arranged):
    """The vertices with the cut pieces' new corners appended (mesh units), and the volume their rounding may sweep.

    A new corner is its exact value rounded to nearest in the scaled frame
    (its error is known, :attr:`Arrangement.rounding`), then moved to mesh
    units (times a power of two, exact) and added to the frame's reference:
    that addition's error is found exactly (Knuth's two-sum), so a corner
    that lands on the grid of the input moves by nothing.
    """
    if arranged.points.shape[0] == 0:
        return vertices, 0.0
    frame = geometry.frame
    # One compiled pass (isect/swept.c) for the corners in mesh units, each one's move (its rounding plus the
    # addition's exact error, Knuth's two-sum) and the terms of the swept volume's bound for cut pieces (see
    # swept_volume: per face around a moved corner, per wall no reversed edge cancels, its cone from the
    # reference); numpy sums them (swept_sum).
    combined, faces, walls, _ = _extension().swept(
        np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(arranged.points, dtype=np.float64),
        np.ascontiguousarray(arranged.rounding, dtype=np.float64), math.ldexp(1.0, frame.scale_exp),
        np.ascontiguousarray(frame.reference, dtype=np.float64), np.ascontiguousarray(arranged.pieces, dtype=np.int64))
    combined = np.frombuffer(combined, dtype=np.float64).reshape(-1, 3)
    return combined, swept_sum(np.frombuffer(faces, dtype=np.float64), np.frombuffer(walls, dtype=np.float64))


def _flat_shells(geometry, faces, labels, shells, zero_area):
    """How many of ``shells`` lie in one plane (exactly); ``zero_area`` flags the faces of zero area."""
    flat = 0
    for shell in shells.tolist():
        mine = labels == shell
        usable = np.flatnonzero(mine & ~zero_area)
        corners = np.unique(faces[mine])
        if usable.size == 0:
            flat += 1
            continue
        a, b, c = geometry.vertices[faces[usable[0]]]
        points = np.stack([np.broadcast_to(a, (corners.size, 3)), np.broadcast_to(b, (corners.size, 3)),
                           np.broadcast_to(c, (corners.size, 3)), geometry.vertices[corners]], axis=1)
        flat += int(not np.any(intersect.orient3d_signs(points)))
    return flat


def _empty(arranged):
    return arranged.faces.size == 0 and arranged.pieces.size == 0


def _zero_shells(vertices, faces, labels, six, bound):
    """Shells whose volume is zero within its bound (an unsure one is integrated on its own first)."""
    from ..core import integrate
    zero = np.abs(six) <= bound
    for shell in np.flatnonzero(zero):
        moments = integrate(vertices, faces[labels == shell], order=0)
        zero[shell] = abs(moments.det_sum) <= moments.det_error
        if not zero[shell]:
            six[shell] = moments.det_sum * 2.0 ** (3 * moments.scale_exp)
    return zero


def _shell_boxes(vertices, faces, labels, n_shells):
    """Per shell: lowest and highest coordinate (n_shells, 2, 3), over the vertices its faces use."""
    corners = vertices[faces]
    order = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[order], np.arange(n_shells))
    low = np.full((n_shells, 3), np.inf)
    high = np.full((n_shells, 3), -np.inf)
    present = np.bincount(labels, minlength=n_shells) > 0
    if present.any():
        low[present] = np.minimum.reduceat(corners.min(axis=1)[order], starts[present], axis=0)
        high[present] = np.maximum.reduceat(corners.max(axis=1)[order], starts[present], axis=0)
    return np.stack([low, high], axis=1)


def joined_groups(shells, meeting):
    """Groups of shells joined by meeting pairs (each a list, ascending); lone shells are groups of one."""
    parent = {int(s): int(s) for s in shells}

    def root(s):
        while parent[s] != s:
            parent[s] = parent[parent[s]]
            s = parent[s]
        return s

    for a, b in meeting.tolist():
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    groups = {}
    for s in parent:
        groups.setdefault(root(s), []).append(s)
    return [sorted(g) for _, g in sorted(groups.items())]


def _classify(geometry, vertices, faces, labels, units, boxes, six, path):
    """For each unit: (sign of its shells' volumes, 0 when mixed; the winding number just outside it).

    The winding number of the other shells is taken at a vertex of one of the
    unit's faces of non-zero area: no other shell's surface passes through it
    (their faces do not meet the unit's), so the exact ray test applies.
    """
    zero_area = geometry.zero_area(faces)
    points = []
    for unit in units:
        usable = np.flatnonzero(np.isin(labels, unit) & ~zero_area)
        if usable.size == 0:
            raise MeshGeometryError("a shell has only faces of zero area", path=path, fix="check the export")
        points.append(int(faces[usable[0], 0]))
    points = np.array(points, dtype=np.int64)
    location = vertices[points]
    winding = np.zeros(len(units), dtype=np.int64)
    for k, unit in enumerate(units):
        for shell in unit:
            box = boxes[shell]
            inside = np.flatnonzero(np.all((box[0] <= location) & (location <= box[1]), axis=1))
            inside = inside[inside != k]
            if inside.size:
                winding[inside] += geometry.winding(faces[labels == shell], points[inside])
    kinds = []
    for unit in units:
        signs = np.sign(six[unit])
        kinds.append(int(signs[0]) if np.all(signs == signs[0]) else 0)
    return list(zip(kinds, winding.tolist()))
