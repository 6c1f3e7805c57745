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

from .errors import OpenMeshError
from .topology import match_edges

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
    representative, _, balance = match_edges(faces, n)
    unmatched = balance[representative] != 0
    rows = np.flatnonzero(unmatched)
    tails = faces.ravel()[rows]
    following = rows + 1
    following[rows % 3 == 2] -= 3
    heads = faces.ravel()[following]
    edges = np.unique(np.sort(np.column_stack([tails, heads]), axis=1), axis=0)
    return np.unique(edges), edges


def _tolerance(vertices, source_dtype):
    storage = np.dtype(source_dtype).type if np.dtype(source_dtype).kind == "f" else np.float64
    largest = float(np.abs(vertices).max()) if vertices.size else 0.0
    return NOISE_ULPS * float(np.spacing(storage(largest)))


def weld_noise(mesh, *, path=None):
    """Weld boundary vertices that differ by noise, or raise the open-mesh refusal with the gap sizes.

    Returns
    -------
    Welded

    Raises
    ------
    OpenMeshError
        The gaps are wider than noise (or welding does not close the mesh).
    """
    from scipy.spatial import cKDTree

    vertices, faces = mesh.vertices, mesh.faces
    boundary, edges = _boundary_vertices(faces, vertices.shape[0])
    points = vertices[boundary]
    tree = cKDTree(points)
    tolerance = _tolerance(vertices, mesh.source_dtype)
    pairs = tree.query_pairs(tolerance, p=np.inf, output_type="ndarray")
    if pairs.size:
        target = _clusters(boundary.size, pairs)
        welded_faces = _relabel(faces, boundary, target)
        _, _, balance = match_edges(welded_faces, vertices.shape[0])
        if not np.any(balance):
            movers = np.flatnonzero(target != np.arange(boundary.size))
            survivors = np.unique(target[movers])
            # Every face that used a merged vertex now uses its survivor: the survivors' neighbourhoods
            # moved by at most the distance between the merged points.
            distance = np.max(np.abs(points[movers] - points[target[movers]]), axis=1) * np.sqrt(3.0)
            moved = np.zeros(boundary.size)
            np.maximum.at(moved, target[movers], distance)
            return Welded(mesh.with_faces(welded_faces), boundary[survivors], moved[survivors] * (1 + 1e-12),
                          int(movers.size))
    problem, widest = _gap_message(vertices, edges, points, tree)
    fix = "close the holes, pass --repair, or treat it as a sheet with --shell THICKNESS"
    extent = float(np.max(np.ptp(vertices, axis=0))) if vertices.size else 0.0
    if 0.0 < widest <= 1e-6 * extent:
        fix = (f"the gaps are tiny: weld vertices closer than {widest:.2g} (e.g. trimesh's merge_vertices, "
               "MeshLab's 'Merge Close Vertices'), or pass --repair")
    raise OpenMeshError(problem, path=path, fix=fix)


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


def _gap_message(vertices, edges, points, tree):
    """``mesh is open: N boundary edges``, with the widest gap a boundary vertex has to another's (and that gap)."""
    count = edges.shape[0]
    message = f"mesh is open: {count} boundary edges"
    if points.shape[0] < 2:
        return message, 0.0
    extent = float(np.max(np.ptp(vertices, axis=0))) or 1.0
    # The nearest other boundary vertex that is not the far end of one of its own boundary edges.
    k = min(points.shape[0], 8)
    distance, index = tree.query(points, k=k)
    boundary = np.unique(edges)
    neighbours = {}
    for a, b in edges.tolist():
        neighbours.setdefault(a, set()).add(b)
        neighbours.setdefault(b, set()).add(a)
    widest = 0.0
    for i, row in enumerate(index.tolist()):
        own = neighbours.get(int(boundary[i]), set())
        gaps = [d for d, j in zip(distance[i].tolist()[1:], row[1:]) if j < boundary.size
                and int(boundary[j]) not in own]
        if gaps:
            widest = max(widest, gaps[0])
    if widest == 0.0:
        return message, 0.0
    return (f"{message}; boundary vertices lie up to {widest:.3g} ({widest / extent:.1e} of the part's size) "
            "from the nearest other one", widest)
