"""The union of shells that intersect, through manifold3d, checked and bounded.

manifold3d computes the union in floating point: the vertices where
surfaces cross are rounded, and it may re-triangulate.  Its result is not
trusted as it comes:

1. Every output triangle carries the index of the original triangle it came
   from (manifold's face IDs, which we set to the original face numbers).
2. Every new vertex is placed exactly, in rationals, from the original
   coordinates: it lies in the planes of all original triangles its output
   triangles came from.  Where three of those planes are independent it is
   a corner of the union, their common point, rounded once.  Where they span
   only a line (a point along a crease) or a plane (a point inside a flat
   fan), its position along that line or in that plane changes no integral:
   the exact surface has it at the nearest point there, and manifold's
   vertex is kept.
3. The union surface with the exact vertices is checked: closed and
   consistently wound (every edge once each way), every output triangle in
   the plane of its original triangle and wound the same way, and its
   corners (original vertices, union corners) inside that triangle.  A failed
   check refuses the file with a one-line reason.
4. The vertices integrated are off their exact places by ``δ_v`` (rounding,
   or manifold's distance from the crease or plane): that sweeps at most
   ``δ_v · ΣA/3`` of volume (ΣA the areas of the triangles around it,
   enlarged for the other moved vertices).  The sum is the ``swept_volume``
   the caller adds to the error bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..errors import MeshGeometryError
from .solid import swept_volume
from ..core.topology import edge_balance

__all__ = ["United", "unite_shells"]


@dataclass(frozen=True)
class United:
    """A union of shells: its faces over the old vertices and ``new_vertices`` (numbered from ``offset``)."""

    faces: np.ndarray
    new_vertices: np.ndarray
    swept_volume: float
    volume: float


def _manifold(path, count):
    try:
        import manifold3d
    except ImportError:
        raise MeshGeometryError(f"{count} shells intersect; their union needs manifold3d", path=path,
                                fix="pip install manifold3d") from None
    return manifold3d


def _refuse(reason, unit, path):
    raise MeshGeometryError(f"shells {', '.join(map(str, unit))} intersect and their union could not be "
                            f"verified ({reason})", path=path,
                            fix="unite the bodies in a modeller, or export them as separate files")


def unite_shells(vertices, faces, labels, unit, *, offset, path=None):
    """The union of the shells ``unit`` (each closed, outward, free of self-intersections).

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
    faces : ndarray, shape (m, 3), int
    labels : ndarray, shape (m,)
        Shell of each face.
    unit : list of int
        The shells to unite.
    offset : int
        Index the first new vertex will have in the caller's vertex array.

    Returns
    -------
    United
    """
    manifold3d = _manifold(path, len(unit))
    parts = []
    for shell in unit:
        ids = np.flatnonzero(labels == shell)
        used, local = np.unique(faces[ids], return_inverse=True)
        mesh = manifold3d.Mesh64(vert_properties=np.ascontiguousarray(vertices[used], dtype=np.float64),
                                 tri_verts=np.ascontiguousarray(local.reshape(-1, 3), dtype=np.uint64),
                                 face_id=np.ascontiguousarray(ids, dtype=np.uint64))
        part = manifold3d.Manifold(mesh)
        if part.status() != manifold3d.Error.NoError:
            _refuse(f"manifold3d rejects shell {shell}: {part.status().name}", unit, path)
        parts.append(part)
    result = manifold3d.Manifold.batch_boolean(parts, manifold3d.OpType.Add)
    if result.status() != manifold3d.Error.NoError:
        _refuse(f"manifold3d: {result.status().name}", unit, path)
    out = result.to_mesh64()
    out_vertices = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
    out_faces = np.asarray(out.tri_verts, dtype=np.int64).reshape(-1, 3)
    origin = np.asarray(out.face_id, dtype=np.int64)
    if out_faces.shape[0] == 0 or origin.shape[0] != out_faces.shape[0] or origin.max() >= faces.shape[0] \
            or origin.min() < 0 or not np.all(np.isin(labels[origin], unit)):
        _refuse("its faces do not map to the original triangles", unit, path)
    return _checked_union(vertices, faces, unit, out_vertices, out_faces, origin, offset, float(result.volume()),
                          path)


def _checked_union(vertices, faces, unit, out_vertices, out_faces, origin, offset, volume, path):
    """Map manifold's output onto exact vertices, verify it, and bound the rounding."""
    index = {tuple(v): int(i) for i, v in zip(np.unique(faces[origin]).tolist(),
                                                vertices[np.unique(faces[origin])].tolist())}
    mapped = np.array([index.get(tuple(v), -1) for v in out_vertices.tolist()], dtype=np.int64)
    new = np.flatnonzero(mapped < 0)
    around = _incident(out_faces, out_vertices.shape[0])
    exact, corners = {}, set()
    rounded = np.zeros((new.size, 3))
    moved = np.zeros(new.size)
    size = float(np.max(np.ptp(vertices[np.unique(faces[origin])], axis=0)))
    for k, v in enumerate(new.tolist()):
        point, corner = _exact_vertex(vertices, faces, np.unique(origin[around[v]]), out_vertices[v])
        if point is None:
            _refuse(f"a new vertex near {out_vertices[v].tolist()} is on no intersection of the original "
                    "triangles", unit, path)
        rounded[k] = [float(c) for c in point] if corner else out_vertices[v]
        if float(np.max(np.abs(rounded[k] - out_vertices[v]))) > 1e-6 * size:
            _refuse(f"a new vertex is {float(np.max(np.abs(rounded[k] - out_vertices[v]))):.3g} from the "
                    "exact intersection", unit, path)
        exact[v] = point
        if corner:
            corners.add(v)
        moved[k] = _distance_up(point, rounded[k])
    mapped[new] = offset + np.arange(new.size)
    united = mapped[out_faces]
    _verify(vertices, faces, out_faces, united, origin, exact, corners, unit, path)
    swept = swept_volume(np.vstack([vertices, rounded]), united, mapped[new], moved)
    return United(united, rounded, swept, volume)


def _incident(out_faces, n):
    """For each output vertex, the output triangles around it (list of arrays)."""
    corner_face = np.repeat(np.arange(out_faces.shape[0]), 3)
    order = np.argsort(out_faces.ravel(), kind="stable")
    bounds = np.searchsorted(out_faces.ravel()[order], np.arange(n + 1))
    return [corner_face[order[bounds[v]:bounds[v + 1]]] for v in range(n)]


def _q(point):
    return tuple(Fraction(float(c)) for c in point)


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _plane(vertices, face):
    a, b, c = (_q(vertices[i]) for i in face)
    normal = _cross(_sub(b, a), _sub(c, a))
    return normal, _dot(normal, a)


def _exact_vertex(vertices, faces, origins, approximate):
    """Where a new vertex belongs, exactly: ``(point, is_corner)``, or ``(None, False)``.

    The planes of the original triangles ``origins`` around it meet in a
    point (three independent planes): that point, a corner of the union,
    exactly.  Two independent planes meet in a line along which the vertex is
    a collinear point of a crease, and one plane holds a flat fan: moving the
    vertex along that line or in that plane changes no integral, so the exact
    surface has it at the nearest point of the line or plane, ``approximate``
    projected (only its distance from there counts).
    """
    planes = [_plane(vertices, faces[f]) for f in origins.tolist()]
    independent = []
    for normal, offset in planes:
        trial = independent + [(normal, offset)]
        if _rank([n for n, _ in trial]) == len(trial):
            independent = trial
        if len(independent) == 3:
            break
    if len(independent) == 3:
        point = _three_planes(*independent)
        corner = True
    elif independent:
        point, corner = _projection(_q(approximate), independent), False
    else:
        return None, False
    if not all(_dot(n, point) == d for n, d in planes):
        return None, False
    return point, corner


def _projection(x, planes):
    """The point nearest to ``x`` on the intersection of one or two independent planes (rationals)."""
    n1, d1 = planes[0]
    if len(planes) == 1:
        t = (d1 - _dot(n1, x)) / _dot(n1, n1)
        return tuple(x[k] + t * n1[k] for k in range(3))
    n2, d2 = planes[1]
    # x + a n1 + b n2 on both planes: a 2×2 system in a, b.
    g11, g12, g22 = _dot(n1, n1), _dot(n1, n2), _dot(n2, n2)
    r1, r2 = d1 - _dot(n1, x), d2 - _dot(n2, x)
    det = g11 * g22 - g12 * g12
    a, b = (r1 * g22 - r2 * g12) / det, (r2 * g11 - r1 * g12) / det
    return tuple(x[k] + a * n1[k] + b * n2[k] for k in range(3))


def _rank(normals):
    if len(normals) == 1:
        return int(any(normals[0]))
    if len(normals) == 2:
        return 2 if any(_cross(normals[0], normals[1])) else 1
    return 3 if _dot(normals[0], _cross(normals[1], normals[2])) != 0 else 2


def _three_planes(p1, p2, p3):
    (n1, d1), (n2, d2), (n3, d3) = p1, p2, p3
    c23, c31, c12 = _cross(n2, n3), _cross(n3, n1), _cross(n1, n2)
    det = _dot(n1, c23)
    return tuple((d1 * c23[k] + d2 * c31[k] + d3 * c12[k]) / det for k in range(3))


def _distance_up(point, rounded):
    """An upper bound on the distance between an exact point and its rounding."""
    squared = sum((p - Fraction(float(r))) ** 2 for p, r in zip(point, rounded))
    return math.sqrt(float(squared)) * (1 + 2.0 ** -48) + 2.0 ** -1070


def _verify(vertices, faces, out_faces, united, origin, exact, corners, unit, path):
    """Closed, consistently wound, each output triangle in its original one's plane, wound alike, and its
    corners (original vertices and union corners) inside that triangle."""
    n = vertices.shape[0] + len(exact) + 1
    uses, balance = edge_balance(united, int(united.max()) + 1 if united.size else n)
    if np.any(balance) or np.any(uses % 2):
        _refuse("the result is not a closed, consistently wound surface", unit, path)
    unchanged = np.all(united == faces[origin], axis=1) | np.all(united == np.roll(faces[origin], 1, axis=1),
                                                                 axis=1) \
        | np.all(united == np.roll(faces[origin], 2, axis=1), axis=1)
    position = {}

    def corner(out_vertex, united_vertex):
        if out_vertex in exact:
            return exact[out_vertex]
        if united_vertex not in position:
            position[united_vertex] = _q(vertices[united_vertex])
        return position[united_vertex]

    for t in np.flatnonzero(~unchanged).tolist():
        a, b, c = (_q(vertices[i]) for i in faces[origin[t]])
        normal = _cross(_sub(b, a), _sub(c, a))
        points = [corner(int(o), int(u)) for o, u in zip(out_faces[t], united[t])]
        for o, x in zip(out_faces[t].tolist(), points):
            if _dot(normal, _sub(x, a)) != 0:
                _refuse(f"a triangle from original face {int(origin[t])} leaves its plane", unit, path)
            if o in exact and o not in corners:
                continue                     # a crease or flat-fan point: free along its line or plane
            for p, q in ((a, b), (b, c), (c, a)):
                if _dot(_cross(_sub(q, p), _sub(x, p)), normal) < 0:
                    _refuse(f"a triangle from original face {int(origin[t])} leaves that face", unit, path)
        if _dot(_cross(_sub(points[1], points[0]), _sub(points[2], points[0])), normal) < 0:
            _refuse(f"a triangle from original face {int(origin[t])} is wound against it", unit, path)
