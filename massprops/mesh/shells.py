"""Shells of a closed mesh: which bound ``{w > 0}``, which repeat or nest, which must be united.

The policy is described in :mod:`massprops.mesh.solid`; this module carries it
out.  On a one-shell mesh it does nothing but the (optional) self-intersection
check; with several shells the work is proportional to the faces of shells
whose bounding boxes meet.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshGeometryError
from .solid import (SELF_INTERSECTION_UP_TO, Solid, refuse_inside_out, refuse_self_intersection, shell_six_volumes,
                    swept_volume)

__all__ = ["solid_of", "resolve_shells", "joined_groups"]


def _geometry(vertices):
    from ..core.intersect import ExactGeometry
    return ExactGeometry(vertices)


def _snapped(geometry, vertices, faces):
    """Volume the decisions could misjudge: coordinates below 2**-200 of the part were taken as zero."""
    if geometry.moved_vertices.size == 0:
        return 0.0
    return swept_volume(vertices, faces, geometry.moved_vertices, geometry.moved)


def _self_checked(geometry, faces, labels, n_shells, path):
    found = geometry.intersections(faces, labels, n_shells, within=True, between=False)
    if found.self_found.any():
        refuse_self_intersection(found.examples, path)


def solid_of(mesh, labels, n_shells, *, path=None, repair=False, self_intersection=None, copies=None):
    """The solid ``mesh`` bounds, for a mesh that passed :func:`massprops.mesh.surface.check_shells`.

    Parameters
    ----------
    mesh : TriangleMesh
        Closed, consistently wound, repeated faces already resolved.
    labels : ndarray, shape (m,), int
        Shell of each face; ``n_shells`` of them.
    repair : bool
        Turn shells wound inside out (inward, outside every other shell) outward instead of refusing.
    self_intersection : bool or None
        Look for faces of one shell that cross; None: up to :data:`SELF_INTERSECTION_UP_TO` faces.
    copies : ndarray, shape (k, 3), optional
        Faces dropped as repeated copies (:func:`without_repeated_faces`): their volume counts in the overlap.

    Returns
    -------
    Solid
    """
    faces = mesh.faces
    check_self = (faces.shape[0] <= SELF_INTERSECTION_UP_TO) if self_intersection is None else bool(self_intersection)
    return resolve_shells(mesh, labels, n_shells, check_self=check_self, path=path, repair=repair, copies=copies)


def resolve_shells(mesh, labels, n_shells, *, check_self, path=None, repair=False, copies=None):
    """See :func:`solid_of` (which chooses ``check_self``).

    ``copies``: faces dropped as repeated copies (their volume counts in the overlap).
    """
    vertices, faces = mesh.vertices, mesh.faces
    checks = {"self_intersection": "not checked"}
    if n_shells == 1 and (copies is None or copies.size == 0):
        swept, frame = 0.0, None
        if check_self:
            geometry = _geometry(vertices)
            _self_checked(geometry, faces, labels, 1, path)
            checks["self_intersection"] = "none"
            swept, frame = _snapped(geometry, vertices, faces), geometry.frame
        return Solid(mesh, checks, swept_volume=swept, frame=frame)
    six, bound = shell_six_volumes(vertices, faces, labels, n_shells)
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
    copy_six, copy_bound = 0.0, 0.0
    if copies is not None and copies.size:
        copy_six, copy_bound = (float(x[0]) for x in shell_six_volumes(
            vertices, copies, np.zeros(copies.shape[0], dtype=np.int64), 1))
        copy_six *= sign
    geometry = _geometry(vertices)
    boxes = _shell_boxes(vertices, faces, labels, n_shells)
    pairs = _box_pairs(boxes, np.flatnonzero(live))
    active = np.zeros(n_shells, dtype=bool)
    active[pairs.ravel()] = True
    within = check_self
    found = None
    if pairs.size or within:
        face_active = live[labels] & (active[labels] | within)
        found = geometry.intersections(faces, labels, n_shells, within=within, between=bool(pairs.size),
                                       active=face_active)
        if within and found.self_found.any():
            refuse_self_intersection(found.examples, path)
    checks["self_intersection"] = "none" if within else "not checked"
    units = joined_groups(np.flatnonzero(live), found.shell_pairs if found is not None else np.zeros((0, 2), int))
    classes = _classify(geometry, vertices, faces, labels, units, boxes, six, path)
    inside_out = [u for u, (kind, w) in zip(units, classes) if kind < 0 and w == 0]
    if inside_out:
        if not repair:
            refuse_inside_out(sum(len(u) for u in inside_out), int(live.sum()), path)
        # Turned outward, the shells change every winding number: classify again.
        faces = faces.copy()
        for unit in inside_out:
            chosen = np.isin(labels, unit)
            faces[chosen] = faces[chosen][:, ::-1]
            six[unit] = -six[unit]
        warnings.append(f"turned {sum(len(u) for u in inside_out)} inside-out shells outward")
        classes = _classify(geometry, vertices, faces, labels, units, boxes, six, path)
    keep, unite = _decide(units, classes, path)
    kept_faces = [faces[np.isin(labels, [s for u in keep for s in u])]]
    new_vertices = np.zeros((0, 3))
    swept = 0.0
    union_six = []
    if unite:
        from .union import unite_shells
        for unit in unite:
            united = unite_shells(vertices, faces, labels, unit, offset=vertices.shape[0] + new_vertices.shape[0],
                                  path=path)
            kept_faces.append(united.faces)
            new_vertices = np.vstack([new_vertices, united.new_vertices])
            swept += united.swept_volume
            union_six.append(6.0 * united.volume)
    dropped = sum(len(u) for u in units if u not in keep and u not in unite)
    if dropped:
        checks["dropped_shells"] = dropped
    resolved = []
    if unite:
        resolved.append(f"{sum(len(u) for u in unite)} shells meet")
    if dropped:
        resolved.append(f"{dropped} shell{'s lie' if dropped > 1 else ' lies'} inside others with the same "
                        "orientation")
    if copy_six:
        resolved.append("shells repeat")
    naive = (float(six[live].sum()) + copy_six, float(bound[live].sum()) + (copy_bound if copy_six else 0.0))
    swept += _snapped(geometry, vertices, faces)
    if not resolved and not zero.any() and not flipped and faces is mesh.faces:
        return Solid(mesh, checks, tuple(warnings), swept, frame=geometry.frame)
    checks_resolved = dict(resolved=tuple(resolved), naive_six=naive) if resolved else {}
    all_faces = np.vstack(kept_faces).astype(np.int64)
    out_vertices = np.vstack([vertices, new_vertices]) if new_vertices.size else vertices
    return Solid(mesh.with_faces(all_faces, out_vertices), checks, tuple(warnings), swept,
                 faces[zero[labels]], flipped, **checks_resolved,
                 frame=geometry.frame if out_vertices is vertices else None)


def _decide(units, classes, path):
    """Units that bound ``{w > 0}``: kept as they are (one shell) or to be united (several)."""
    keep, unite = [], []
    for unit, (kind, w) in zip(units, classes):
        if kind == 0 or (kind < 0 and len(unit) > 1):
            raise MeshGeometryError(f"shells {unit[0]} and {unit[1]} intersect and one is wound inward "
                                    "(a cavity crossing a body's surface)", path=path,
                                    fix="export the part as one closed body, cavities inside it")
        if w < 0:
            raise MeshGeometryError(f"shell {unit[0]} lies where shells wound inward leave a negative winding "
                                    "number", path=path,
                                    fix="orient every body outward and every cavity inward, inside its body "
                                        "({repair} orients separate bodies)")
        if (kind > 0 and w == 0) or (kind < 0 and w == 1):
            (unite if len(unit) > 1 else keep).append(unit)
    return keep, unite


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
    low = np.full((n_shells, 3), np.inf)
    high = np.full((n_shells, 3), -np.inf)
    for k in range(3):
        corner = vertices[faces[:, k]]
        np.minimum.at(low, labels, corner)
        np.maximum.at(high, labels, corner)
    return np.stack([low, high], axis=1)


def _box_pairs(boxes, shells):
    """Pairs (p, 2) of the given shells whose closed boxes meet, lower shell first."""
    if shells.size < 2:
        return np.zeros((0, 2), dtype=np.int64)
    order = shells[np.argsort(boxes[shells, 0, 0], kind="stable")]
    starts = boxes[order, 0, 0]
    pairs = []
    for i, shell in enumerate(order[:-1]):
        reach = np.searchsorted(starts, boxes[shell, 1, 0], side="right")
        others = order[i + 1:reach]
        if others.size == 0:
            continue
        meet = np.all((boxes[others, 0] <= boxes[shell, 1]) & (boxes[shell, 0] <= boxes[others, 1]), axis=1)
        for other in others[meet]:
            pairs.append((min(shell, other), max(shell, other)))
    return np.array(sorted(pairs), dtype=np.int64).reshape(-1, 2)


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
