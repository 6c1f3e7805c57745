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

from dataclasses import dataclass

import numpy as np

from ..errors import MeshGeometryError
from .solid import swept_volume
from ..core import edge_summary
from .exact_points import Grid, SignFilter, exact_vertex, on_plane

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
    used = np.unique(faces[origin])
    index = {tuple(v): int(i) for i, v in zip(used.tolist(), vertices[used].tolist())}
    mapped = np.array([index.get(tuple(v), -1) for v in out_vertices.tolist()], dtype=np.int64)
    new = np.flatnonzero(mapped < 0)
    grid = Grid(vertices, used, out_vertices)
    around = _incident(out_faces, out_vertices.shape[0])
    exact, corners = {}, set()
    rounded = np.zeros((new.size, 3))
    moved = np.zeros(new.size)
    size = float(np.max(np.ptp(vertices[used], axis=0)))
    for k, v in enumerate(new.tolist()):
        point, corner = exact_vertex(grid, faces, np.unique(origin[around[v]]), v)
        if point is None:
            _refuse(f"a new vertex near {out_vertices[v].tolist()} is on no intersection of the original "
                    "triangles", unit, path)
        rounded[k] = grid.rounded(point) if corner else out_vertices[v]
        if float(np.max(np.abs(rounded[k] - out_vertices[v]))) > 1e-6 * size:
            _refuse(f"a new vertex is {float(np.max(np.abs(rounded[k] - out_vertices[v]))):.3g} from the "
                    "exact intersection", unit, path)
        exact[v] = point
        if corner:
            corners.add(v)
        moved[k] = grid.distance_up(point, rounded[k])
    mapped[new] = vertices.shape[0] + np.arange(new.size)       # numbered after the old vertices, for now
    united = mapped[out_faces]
    approx = (np.vstack([vertices, rounded]).tolist(), np.concatenate([np.zeros(vertices.shape[0]), moved]).tolist())
    moves, defect = _verify(grid, faces, out_faces, united, origin, exact, corners, approx, unit, path)
    shifted = np.zeros(vertices.shape[0] + new.size)
    shifted[mapped[new]] = moved
    for vertex, outside in moves.items():
        shifted[vertex] += outside
    touched = np.flatnonzero(shifted)
    swept = swept_volume(np.vstack([vertices, rounded]), united, touched, shifted[touched]) + defect
    united[united >= vertices.shape[0]] += offset - vertices.shape[0]
    return United(united, rounded, swept, volume)


def _incident(out_faces, n):
    """For each output vertex, the output triangles around it (list of arrays)."""
    corner_face = np.repeat(np.arange(out_faces.shape[0]), 3)
    order = np.argsort(out_faces.ravel(), kind="stable")
    bounds = np.searchsorted(out_faces.ravel()[order], np.arange(n + 1))
    return [corner_face[order[bounds[v]:bounds[v + 1]]] for v in range(n)]


def _verify(grid, faces, out_faces, united, origin, exact, corners, approx, unit, path):
    """Closed and consistently wound; each output triangle in its original one's plane, wound alike, with its
    corners (original vertices and union corners) inside that triangle.

    manifold's float decisions can leave a corner outside its face, or a
    sliver wound backwards, by amounts of the order of the coordinates'
    rounding.  Those are bounded, not refused: a corner ``ε`` outside is a
    vertex moved by ``ε`` (returned per vertex), a backward sliver of area
    ``a`` changes any integral by at most that of a cone ``2 a · size / 3``
    (returned as a volume).  Anything beyond :data:`_SLACK` of the part's
    size is refused.  Signs are decided in floats where a certified margin
    allows (:class:`SignFilter`), else in integers.

    Returns
    -------
    moves : dict {united vertex: ε}, defect : float (mesh units³)
    """
    edges = edge_summary(united, int(united.max()) + 1)
    if not edges.balanced or edges.odd:
        _refuse("the result is not a closed, consistently wound surface", unit, path)
    own = faces[origin]
    unchanged = np.zeros(united.shape[0], dtype=bool)
    for turn in range(3):
        unchanged |= np.all(united == np.roll(own, turn, axis=1), axis=1)
    moves, defect, size = {}, 0.0, grid.size
    for t in np.flatnonzero(~unchanged).tolist():
        face = faces[origin[t]].tolist()
        plane = grid.plane(face)
        signs = SignFilter(approx, face, plane[0])
        points = [exact[o] if o in exact else grid.original(u)
                  for o, u in zip(out_faces[t].tolist(), united[t].tolist())]
        for o, u, point in zip(out_faces[t].tolist(), united[t].tolist(), points):
            if (o in exact and o not in corners) or (o not in exact and u in face):
                continue       # free along its crease or fan (on its planes by construction); a corner of the face
            if o not in exact and not on_plane(plane, point):
                _refuse(f"a triangle from original face {int(origin[t])} leaves its plane", unit, path)
            if signs.inside(u):
                continue
            outside = grid.outside(point, [grid.original(i)[0] for i in face], plane[0])
            if outside > _SLACK * size:
                _refuse(f"a triangle from original face {int(origin[t])} leaves that face", unit, path)
            if outside:
                moves[u] = max(moves.get(u, 0.0), outside)
        if signs.wound_along(united[t].tolist()):
            continue
        area = grid.signed_area(points, plane[0])
        if area < 0:
            if -area > _SLACK * size * size:
                _refuse(f"a triangle from original face {int(origin[t])} is wound against it", unit, path)
            defect += 2.0 * -area * size / 3.0
    return moves, defect


# What manifold's float decisions may leave, relative to the part's size (lengths; areas its square).
_SLACK = 1e-9
