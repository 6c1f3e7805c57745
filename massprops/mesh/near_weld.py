"""Open edges whose ends differ by CAD noise: weld them, or say how wide the gaps are.

Vertices are welded by exact coordinates.  CAD exports sometimes leave a
coordinate that is "zero" as 1e-18 on one side of an edge and 0.0 on the
other: exactly welded, the surface is open along such seams, although no
gap is wider than the coordinates' own rounding.  When every boundary
vertex lies within a few units in the last place of the part's largest
coordinate (:data:`NOISE_ULPS`) of another, they are welded, the result must
then be closed, and the displacement goes into the error bound (like the
input's own resolution).  Otherwise the mesh is refused with the number of
boundary edges and the widest gap, so the user knows whether to weld or to
fill holes.
"""

from __future__ import annotations

import numpy as np

from ..model.errors import OpenMeshError
from ..core import edge_summary
from .surface import distinct_faces

__all__ = ["NOISE_ULPS", "Welded", "weld_noise"]

# Boundary vertices this many units in the last place (of the largest coordinate, in the
# precision the file stored) apart or closer are welded.
NOISE_ULPS = 4


class Welded:
    """A mesh closed by welding near-coincident vertices, and how far they moved."""

    def __init__(self, mesh, moved_vertices, moved, count):
        self.mesh = mesh
        self.moved_vertices = moved_vertices       # vertex indices (of ``mesh``) whose coordinates changed
        self.moved = moved                         # bound on each one's move, mesh units
        self.count = count                         # vertices merged into others


def _boundary_vertices(faces, n):
    """Vertices at the ends of unmatched edges, and the number of such (undirected) edges."""
    found = edge_summary(faces, n, arrays=True)
    edges = found.edge_vertices[found.balance != 0]          # (lower, higher), sorted
    return np.unique(edges), edges


def _tolerance(vertices, source_dtype):
    storage = np.dtype(source_dtype).type if np.dtype(source_dtype).kind == "f" else np.float64
    largest = float(np.abs(vertices).max()) if vertices.size else 0.0
    return NOISE_ULPS * float(np.spacing(storage(largest)))


def weld_noise(mesh, *, path=None, refusal=None):
    """Weld boundary vertices that differ by noise, or raise the open-mesh refusal with the gap sizes.

    ``refusal``: the error the exact check raised; raised again when the
    surface has duplicated faces (that is its problem, not a gap).

    Returns
    -------
    Welded

    Raises
    ------
    OpenMeshError
        The gaps are wider than noise (or welding does not close the mesh).
    """
    vertices, faces = mesh.vertices, mesh.faces
    boundary, edges = _boundary_vertices(faces, vertices.shape[0])
    points = vertices[boundary]
    welded = _welded_within(mesh, boundary, points, _tolerance(vertices, mesh.source_dtype))
    if welded is not None:
        return welded
    if refusal is not None and distinct_faces(faces).size < faces.shape[0]:
        raise refusal
    extent = float(np.max(np.ptp(vertices[np.unique(faces)], axis=0)))
    # Would welding a little more close it?  Then say how little; else describe the openings.
    gaps = _nearest_unjoined(points, np.searchsorted(boundary, edges))
    small = gaps[gaps <= _SMALL_GAP * extent]
    if small.size and _welded_within(mesh, boundary, points, float(small.max())) is not None:
        widest = float(small.max())
        raise OpenMeshError(f"mesh is open: {edges.shape[0]} boundary edges along gaps at most {widest:.2g} wide",
                            path=path, fix=f"weld vertices closer than {widest:.2g} (trimesh's merge_vertices, "
                                           "MeshLab's 'Merge Close Vertices'), or pass {repair}")
    raise OpenMeshError(_openings(edges, points), path=path,
                        fix="close the holes, pass {repair}, or treat it as a sheet with {shell=THICKNESS}")


# Gaps up to this fraction of the part's size are reported as such (a tolerance weld would close them).
_SMALL_GAP = 1e-4


def _welded_within(mesh, boundary, points, tolerance):
    """The mesh with boundary vertices within ``tolerance`` (every coordinate) welded, if that closes it."""
    pairs = _close_pairs(points, tolerance)
    if not pairs.size:
        return None
    target = _clusters(boundary.size, pairs)
    welded_faces = _relabel(mesh.faces, boundary, target)
    if not edge_summary(welded_faces, mesh.vertices.shape[0]).balanced:
        return None
    movers = np.flatnonzero(target != np.arange(boundary.size))
    survivors = np.unique(target[movers])
    # Every face that used a merged vertex now uses its survivor: the survivors' neighbourhoods
    # moved by at most the distance between the merged points.
    distance = np.max(np.abs(points[movers] - points[target[movers]]), axis=1) * np.sqrt(3.0)
    moved = np.zeros(boundary.size)
    np.maximum.at(moved, target[movers], distance)
    return Welded(mesh.with_faces(welded_faces), boundary[survivors], moved[survivors] * (1 + 1e-12),
                  int(movers.size))


def _nearest_unjoined(points, local_edges):
    """For each boundary point, the distance to the nearest other one no boundary edge joins it to."""
    joined = {(a, b) for a, b in local_edges.tolist()} | {(b, a) for a, b in local_edges.tolist()}
    n = points.shape[0]
    nearest = np.full(n, np.inf)
    if n > 4096:
        from scipy.spatial import cKDTree          # only for large open meshes, on the way to a refusal
        distance, index = cKDTree(points).query(points, k=min(n, 8))
        for i in range(n):
            for d, j in zip(distance[i].tolist()[1:], index[i].tolist()[1:]):
                if (i, j) not in joined:
                    nearest[i] = d
                    break
        return nearest
    for start in range(0, n, 256):
        block = np.linalg.norm(points[start:start + 256, None, :] - points[None, :, :], axis=2)
        rows = np.arange(start, min(n, start + 256))
        block[rows - start, rows] = np.inf
        for a, b in local_edges.tolist():
            if start <= a < start + 256:
                block[a - start, b] = np.inf
            if start <= b < start + 256:
                block[b - start, a] = np.inf
        nearest[start:start + 256] = block.min(axis=1)
    del joined
    return nearest


def _close_pairs(points, tolerance):
    """Pairs (k, 2) of points no farther apart than ``tolerance`` in every coordinate.

    Sorted along x, such pairs sit in runs of neighbours less than
    ``tolerance`` apart in x; with noise-sized tolerances the runs are short.
    """
    order = np.argsort(points[:, 0], kind="stable")
    x = points[order, 0]
    near = np.diff(x) <= tolerance
    pairs = []
    start = None
    for i, close in enumerate(np.append(near, False).tolist()):
        if close and start is None:
            start = i
        elif not close and start is not None:
            run = order[start:i + 1]
            for a in range(run.size):
                gap = np.max(np.abs(points[run[a + 1:]] - points[run[a]]), axis=1)
                pairs += [(int(run[a]), int(b)) for b in run[a + 1:][gap <= tolerance]]
            start = None
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def _clusters(n, pairs):
    """For each of n points, the smallest index of its cluster (pairs joined transitively)."""
    parent = np.arange(n)
    changed = True
    while changed:
        low = np.minimum(parent[pairs[:, 0]], parent[pairs[:, 1]])
        before = parent.copy()
        np.minimum.at(parent, pairs[:, 0], low)
        np.minimum.at(parent, pairs[:, 1], low)
        parent = parent[parent]
        changed = not np.array_equal(before, parent)
    return parent


def _relabel(faces, boundary, target):
    relabel = np.arange(int(faces.max()) + 1)
    relabel[boundary] = boundary[target]
    return relabel[faces]


def _loops(edges):
    """Label of the boundary loop (connected set of boundary edges) of each boundary vertex, and the count."""
    vertices = np.unique(edges)
    labels = np.unique(_clusters(vertices.size, np.searchsorted(vertices, edges)), return_inverse=True)[1]
    return labels, int(labels.max()) + 1


def _openings(edges, points):
    """``mesh is open: N boundary edges around K openings``, with the widest one's extent."""
    labels, loops = _loops(edges)
    widest = max(float(np.max(np.ptp(points[labels == k], axis=0))) for k in range(loops))
    if loops == 1:
        return f"mesh is open: {edges.shape[0]} boundary edges around one opening {widest:.3g} across"
    return f"mesh is open: {edges.shape[0]} boundary edges around {loops} openings, the widest {widest:.3g} across"
