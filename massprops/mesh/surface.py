"""The triangle-mesh container and the checks a mesh must pass before integration.

A :class:`TriangleMesh` is a welded surface: ``vertices`` (n, 3) float64 in the
mesh's own (local) frame and ``faces`` (m, 3) integer indices, wound so that
the right-hand normal points out of the solid.  Vertices are welded by exact
coordinates only: massprops never merges points that are merely close.

Grouping equal keys (welding vertices, pairing edges, finding duplicate faces)
uses one mechanism, :mod:`massprops.core.grouping`: exact, vectorised, and linear in
the number of keys, so a million-triangle mesh needs no sort.  Edge matching
and shells live in :mod:`massprops.core.topology`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import MeshGeometryError, OpenMeshError, WindingError
from ..frames import matvec
from ..core.grouping import first_of_groups, group_ids, labels_of, point_representatives
from ..core.topology import face_components, match_edges, uses as _uses
from ..core.parallel import PARALLEL_ABOVE, start

__all__ = ["TriangleMesh", "MeshChecks", "group_ids", "check_mesh", "check_shells", "distinct_faces"]


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """A welded triangle surface in its local frame.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
        Vertex coordinates, mesh units, local frame.
    faces : ndarray, shape (m, 3), int64
        Vertex indices of each triangle, counter-clockwise seen from outside.
    source_dtype : numpy dtype
        Precision the coordinates were stored with in the file (float32 for
        binary STL); float32 values are held exactly in float64.
    """

    vertices: np.ndarray
    faces: np.ndarray
    source_dtype: np.dtype = field(default=np.dtype(np.float64))
    notes: tuple = ()
    unit: str | None = None

    @classmethod
    def from_triangles(cls, triangles, *, source_dtype=None):
        """Weld a triangle soup by exact coordinates.

        Parameters
        ----------
        triangles : ndarray, shape (m, 3, 3)
            Corner coordinates of each triangle, local frame.
        """
        triangles = np.asarray(triangles)
        dtype = np.dtype(source_dtype or triangles.dtype)
        # One copy that also turns -0.0 into +0.0, so equal values have equal bits.
        return cls.from_corners(np.add(triangles, 0.0, dtype=np.float32 if triangles.dtype == np.float32
                                       else np.float64).reshape(-1, 3), source_dtype=dtype)

    @classmethod
    def from_corners(cls, corners, *, source_dtype=None):
        """Weld consecutive triangle corners, taking ownership of the array (no copy).

        Parameters
        ----------
        corners : ndarray, shape (3m, 3), float32 or float64, C-contiguous
            Corners of triangle k at rows 3k, 3k+1, 3k+2, with no ``-0.0``
            (add ``0.0`` first); float32 values are welded on their own bits
            and widened to float64 exactly.
        """
        dtype = np.dtype(source_dtype or corners.dtype)
        is_first, representative = first_of_groups(point_representatives(corners))
        vertices = corners[np.flatnonzero(is_first)].astype(np.float64)
        del corners                   # the caller passed it to us: free it before the labels
        return cls(vertices, labels_of(is_first, representative).reshape(-1, 3), dtype)

    @classmethod
    def from_indexed(cls, vertices, faces, *, source_dtype=None, notes=(), unit=None):
        """Weld an indexed mesh by exact coordinates, as :meth:`from_triangles` welds a soup.

        Vertices no face uses are left out (a non-finite one with a note);
        vertices with equal coordinates become one, so a surface that repeats
        its corners per face (per-face normals, UV seams) is closed.

        Parameters
        ----------
        vertices : ndarray, shape (n, 3)
            Coordinates, local frame.
        faces : ndarray, shape (m, 3), int
            Vertex indices; out-of-range indices are left for :func:`check_mesh` to report.
        """
        vertices = np.asarray(vertices)
        faces = np.asarray(faces, dtype=np.int64)
        dtype = np.dtype(source_dtype or (vertices.dtype if vertices.dtype.kind == "f" else np.float64))
        if faces.size and (faces.min() < 0 or faces.max() >= vertices.shape[0]):
            return cls(np.asarray(vertices, dtype=np.float64), faces, dtype, tuple(notes), unit)
        used = np.zeros(vertices.shape[0], dtype=bool)
        used[faces.ravel()] = True
        unused_bad = int(np.count_nonzero(~used & ~np.isfinite(vertices).all(axis=1)))
        if unused_bad:
            notes = (*notes, f"ignored {unused_bad} vertices with NaN or infinite coordinates that no face uses")
        kept = np.flatnonzero(used)
        points = np.add(vertices[kept], 0.0, dtype=np.float32 if vertices.dtype == np.float32 else np.float64)
        is_first, representative = first_of_groups(point_representatives(np.ascontiguousarray(points)))
        labels = labels_of(is_first, representative)
        relabel = np.zeros(vertices.shape[0], dtype=np.int64)
        relabel[kept] = labels
        return cls(points[np.flatnonzero(is_first)].astype(np.float64), relabel[faces], dtype, tuple(notes), unit)

    @property
    def triangles(self):
        """ndarray, shape (m, 3, 3): corner coordinates of every face."""
        return self.vertices[self.faces]

    def flipped(self):
        """The same surface with every face's winding reversed."""
        return TriangleMesh(self.vertices, self.faces[:, ::-1].copy(), self.source_dtype, self.notes, self.unit)

    def transformed(self, rotation, translation):
        """The mesh with every vertex mapped to ``rotation @ x + translation``."""
        vertices = matvec(rotation, self.vertices) + np.asarray(translation, float)
        return TriangleMesh(vertices, self.faces, np.dtype(np.float64), self.notes, self.unit)

    def with_faces(self, faces, vertices=None):
        """A mesh of the same kind with other faces (and vertices), keeping the source precision."""
        return TriangleMesh(self.vertices if vertices is None else vertices, faces, self.source_dtype, self.notes,
                            self.unit)


@dataclass(frozen=True)
class MeshChecks:
    """What validation found; reported under ``checks`` in the JSON output."""

    closed: bool
    orientation: str
    shells: int
    boundary_edges: int
    duplicate_faces: int
    degenerate_faces: int
    inward_shells_outside: int = 0

    def as_dict(self):
        return dict(self.__dict__)


# Above this many faces the shells are found after the edges, not beside them, to bound the peak memory.
_THREADED_CHECK_UP_TO = 1 << 22


def check_mesh(mesh, path=None):
    """Check that ``mesh`` bounds a solid: finite, closed, consistently wound (see :func:`check_shells`)."""
    return check_shells(mesh, path)[0]


def check_shells(mesh, path=None):
    """Check that ``mesh`` bounds a solid: finite, closed, consistently wound; and find its shells.

    Returns
    -------
    checks : MeshChecks
    labels : ndarray, shape (m,), int64
        The shell (connected component of faces sharing vertices) of each face.
    two_faces_an_edge : bool
        Every edge is used by exactly two faces.  Then no face can repeat
        another in the same orientation (its edges would be used four times),
        and a face repeated reversed is a shell of two faces on its own.

    Raises
    ------
    MeshGeometryError
        No faces, or non-finite coordinates.
    OpenMeshError
        Some edge is not matched by a reverse edge (holes, duplicated faces).
    WindingError
        Closed, but faces (or a whole separate shell) wound the wrong way.
    """
    vertices, faces = mesh.vertices, mesh.faces
    if faces.shape[0] == 0:
        raise MeshGeometryError("the file holds no triangles", path=path,
                                fix="export the part as a closed surface mesh")
    if faces.min() < 0 or faces.max() >= vertices.shape[0]:
        raise MeshGeometryError("a face refers to a vertex that does not exist", path=path,
                                fix="re-export the mesh")
    if not np.isfinite(vertices).all():
        _refuse_non_finite(vertices, faces, path)
    degenerate = int(np.count_nonzero((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2])
                                      | (faces[:, 2] == faces[:, 0])))
    # Shells are found in a second thread while the edges are matched.
    components = start(face_components, faces, vertices.shape[0],
                       threaded=PARALLEL_ABOVE < faces.shape[0] <= _THREADED_CHECK_UP_TO)
    representative, direction, balance = match_edges(faces, vertices.shape[0])
    if np.any(balance):
        components()                  # let the shells' thread finish before refusing
        _refuse_unbalanced(faces, _uses(representative), balance, path)
    # 3m directed edges in pairs: exactly 3m/2 edges when no edge is used more than twice.
    distinct = int(np.count_nonzero(representative == np.arange(representative.size, dtype=representative.dtype)))
    del representative, direction, balance    # a balanced mesh needs them no more: free them before the shells
    labels, n_shells = components()
    return MeshChecks(closed=True, orientation="consistent", shells=n_shells, boundary_edges=0,
                      duplicate_faces=0, degenerate_faces=degenerate), labels, 2 * distinct == 3 * faces.shape[0]


def _refuse_non_finite(vertices, faces, path):
    """Raise for non-finite coordinates of vertices that faces use (unused ones do not matter)."""
    used = np.zeros(vertices.shape[0], dtype=bool)
    used[faces.ravel()] = True
    bad = used & ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise MeshGeometryError(
            f"{int(bad.sum())} vertices have NaN or infinite coordinates "
            f"(first: vertex {int(np.flatnonzero(bad)[0])})", path=path,
            fix="re-export the mesh; non-finite coordinates cannot be repaired")


def distinct_faces(faces):
    """Indices (ascending) of the first face of each set of vertices: duplicates left out."""
    _, first = group_ids(np.sort(faces, axis=1).astype(np.uint64))
    return np.sort(first)


def _duplicate_faces(faces):
    return faces.shape[0] - distinct_faces(faces).size


def _refuse_unbalanced(faces, uses, balance, path):
    duplicates = _duplicate_faces(faces)
    odd = int(np.count_nonzero(uses % 2))
    if duplicates:
        raise OpenMeshError(f"{duplicates} faces are duplicated (the same triangle twice)", path=path,
                            fix="remove the duplicates, or pass {repair}")
    if odd:
        raise OpenMeshError(f"mesh is open: {odd} boundary edges", path=path,
                            fix="close the holes, pass {repair}, or treat it as a sheet with {shell=THICKNESS}")
    flipped = int(np.count_nonzero(balance))
    raise WindingError(f"faces are wound inconsistently: {flipped} edges are traversed twice in the same "
                       "direction", path=path, fix="pass {repair} to orient the faces consistently")

