"""The triangle-mesh container and the checks a mesh must pass before integration.

A :class:`TriangleMesh` is a welded surface: ``vertices`` (n, 3) float64 in the
mesh's own (local) frame and ``faces`` (m, 3) integer indices, wound so that
the right-hand normal points out of the solid.  Vertices are welded by exact
coordinates only: massprops never merges points that are merely close.

Welding, edge matching, shells and duplicate faces are done by the compiled
core (:mod:`massprops.core`); this module keeps the container and the policy
of the checks.
"""

from __future__ import annotations

from dataclasses import field

import numpy as np

from ..model.records import record
from ..core import _core, distinct_faces, face_groups, weld_corners, weld_indexed
from ..core.arrays import as_points
from ..core.topology import edge_shells
from ..model.errors import MeshGeometryError, OpenMeshError, WindingError
from ..model.frames import matvec

__all__ = ["TriangleMesh", "MeshChecks", "check_mesh", "check_shells", "distinct_faces", "unused_note"]


def unused_note(ignored):
    """The note for ``ignored`` vertices that no face uses and whose coordinates are not finite (or none)."""
    return (f"ignored {ignored} vertices with NaN or infinite coordinates that no face uses",) if ignored else ()


@record(eq=False)
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
        triangles : ndarray, shape (m, 3, 3), float32 or float64
            Corner coordinates of each triangle, local frame; float32 values
            are welded on their own bits and widened to float64 exactly.
        source_dtype : numpy dtype, optional
            The precision the file stored (default: the array's).
        """
        triangles = np.asarray(triangles)
        vertices, faces = weld_corners(triangles)
        return cls(vertices, faces, np.dtype(source_dtype or triangles.dtype))

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
        welded, renumbered, ignored = weld_indexed(vertices, faces)
        return cls(welded, renumbered, dtype, (*notes, *unused_note(ignored)), unit)

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


@record
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


def check_mesh(mesh, path=None):
    """Check that ``mesh`` bounds a solid: finite, closed, consistently wound (see :func:`check_shells`)."""
    return check_shells(mesh, path)[0]


def check_shells(mesh, path=None):
    """Check that ``mesh`` bounds a solid: finite, closed, consistently wound; and find its shells.

    Returns
    -------
    checks : MeshChecks
    labels : ndarray, shape (m,), int64
        The shell (connected component of faces sharing vertices) of each face (read-only).
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
    # The shells' union-find runs beside the edges' matching, which checks the indices (issue 24: no passes of
    # their own); for an open or misoriented mesh the shells are not used, and the refusal is the edges'.
    try:
        edges, labels, n_shells = edge_shells(faces, vertices.shape[0])
    except IndexError:
        raise MeshGeometryError("a face refers to a vertex that does not exist", path=path,
                                fix="re-export the mesh") from None
    if not _core.all_finite(as_points(vertices)):          # one compiled pass, no array of flags
        _refuse_non_finite(vertices, faces, path)
    if not edges.balanced:
        _refuse_unbalanced(faces, edges, path)
    if labels is None:
        # Every label is 0: one zero seen m times (read-only, no memory), not 8 bytes a face held while the
        # self-intersection search runs, the peak of a large mesh (issue 24).
        labels = _zeros(faces.shape[0])
    # Balanced, so every edge is used an even number of times: exactly twice when none is used more.
    two_faces_an_edge = edges.max_uses <= 2 and edges.collapsed == 0
    # closed, orientation, shells, boundary_edges, duplicate_faces, degenerate_faces, inward_shells_outside: every
    # field by position, the record's quickest construction (once a part in a batch)
    return MeshChecks(True, "consistent", n_shells, 0, 0, edges.degenerate_faces, 0), labels, two_faces_an_edge


def _zeros(m):
    """``m`` read-only int64 zeros that share one element (what ``numpy.broadcast_to(0, (m,))`` gives, in a
    fraction of its microseconds)."""
    zeros = np.ndarray((m,), dtype=np.int64, buffer=_ZERO, strides=(0,))
    zeros.flags.writeable = False
    return zeros


_ZERO = np.zeros(1, dtype=np.int64)


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


def _refuse_unbalanced(faces, edges, path):
    groups = face_groups(faces)
    if groups.duplicates:
        # A closed soup may repeat faces; this one does not close, and repeated faces may be why.
        repeated = np.flatnonzero(np.bincount(groups.labels) > 1)[0]
        first, second = np.flatnonzero(groups.labels == repeated)[:2]
        unmatched = edges.odd or edges.unbalanced
        raise OpenMeshError(f"mesh is open: face {second} is face {first} duplicated (the same triangle twice), and "
                            f"{unmatched} edge{'s are' if unmatched != 1 else ' is'} not matched by a reverse edge",
                            path=path, fix="remove the extra copies, or pass {repair}")
    if edges.odd:
        raise OpenMeshError(f"mesh is open: {edges.odd} boundary edges", path=path,
                            fix="close the holes, pass {repair}, or treat it as a sheet with {shell=THICKNESS}")
    raise WindingError(f"faces are wound inconsistently: {edges.unbalanced} edges are traversed twice in the same "
                       "direction", path=path, fix="pass {repair} to orient the faces consistently")
