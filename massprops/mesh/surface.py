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

from dataclasses import dataclass, field

import numpy as np

from ..core import distinct_faces, edge_summary, face_groups, shell_determinants, shells, weld_corners
from ..errors import MeshGeometryError, OpenMeshError, WindingError
from ..frames import matvec

__all__ = ["TriangleMesh", "MeshChecks", "check_mesh", "distinct_faces"]


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
    def from_corners(cls, corners, *, source_dtype=None):
        """Weld consecutive triangle corners.

        Parameters
        ----------
        corners : ndarray, shape (3m, 3), float32 or float64
            Corners of triangle k at rows 3k, 3k+1, 3k+2.
        """
        return cls.from_triangles(corners, source_dtype=source_dtype)

    @property
    def triangles(self):
        """ndarray, shape (m, 3, 3): corner coordinates of every face."""
        return self.vertices[self.faces]

    def flipped(self):
        """The same surface with every face's winding reversed."""
        return TriangleMesh(self.vertices, self.faces[:, ::-1].copy(), self.source_dtype)

    def transformed(self, rotation, translation):
        """The mesh with every vertex mapped to ``rotation @ x + translation``."""
        vertices = matvec(rotation, self.vertices) + np.asarray(translation, float)
        return TriangleMesh(vertices, self.faces, np.dtype(np.float64))


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


def signed_volumes_by_shell(vertices, faces, shell_labels, n_shells):
    """Six times the signed volume enclosed by each shell (the integration frame's scaled units; signs matter)."""
    return shell_determinants(vertices, faces, shell_labels, n_shells)[0]


def winding_number(point, triangles):
    """Generalised winding number of a closed surface about ``point``.

    Van Oosterom & Strackee's solid angle per triangle, summed and divided by
    4π: an integer for a closed surface and a point off it.
    """
    r = triangles - point
    norms = np.linalg.norm(r, axis=2)
    a, b, c = r[:, 0], r[:, 1], r[:, 2]
    numerator = np.einsum("ij,ij->i", a, np.cross(b, c))
    denominator = (norms[:, 0] * norms[:, 1] * norms[:, 2]
                   + np.einsum("ij,ij->i", a, b) * norms[:, 2]
                   + np.einsum("ij,ij->i", a, c) * norms[:, 1]
                   + np.einsum("ij,ij->i", b, c) * norms[:, 0])
    return 2.0 * np.arctan2(numerator, denominator).sum() / (4.0 * np.pi)


def check_mesh(mesh, path=None):
    """Check that ``mesh`` bounds a solid: finite, closed, consistently wound.

    Returns
    -------
    MeshChecks

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
    edges = edge_summary(faces, vertices.shape[0])
    degenerate = edges.degenerate_faces
    if not edges.balanced:
        _refuse_unbalanced(faces, edges, path)
    labels, n_shells = shells(faces, vertices.shape[0])
    outside = 0
    if n_shells > 1:
        outside = _inward_shells_outside(vertices, faces, labels, n_shells)
        if outside:
            raise WindingError(
                f"{outside} of {n_shells} shells are wound inward but lie outside every other shell "
                "(a separate body turned inside out)", path=path,
                fix="pass {repair} to orient every shell outward")
    return MeshChecks(closed=True, orientation="consistent", shells=n_shells, boundary_edges=0,
                      duplicate_faces=0, degenerate_faces=degenerate)


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
    duplicates = face_groups(faces).duplicates
    if duplicates:
        raise OpenMeshError(f"{duplicates} faces are duplicated (the same triangle twice)", path=path,
                            fix="remove the duplicates, or pass {repair}")
    if edges.odd:
        raise OpenMeshError(f"mesh is open: {edges.odd} boundary edges", path=path,
                            fix="close the holes, pass {repair}, or treat it as a sheet with {shell=THICKNESS}")
    raise WindingError(f"faces are wound inconsistently: {edges.unbalanced} edges are traversed twice in the same "
                       "direction", path=path, fix="pass {repair} to orient the faces consistently")


def _inward_shells_outside(vertices, faces, labels, n_shells):
    """Count shells whose sign is opposite to the whole and that no other shell encloses."""
    volumes = signed_volumes_by_shell(vertices, faces, labels, n_shells)
    total_sign = np.sign(volumes.sum()) or 1.0
    outside = 0
    for shell in np.flatnonzero(np.sign(volumes) == -total_sign):
        point = vertices[faces[labels == shell][0, 0]]
        others = vertices[faces[labels != shell]]
        # Inside an enclosing shell of the whole's orientation, the winding number is ±1.
        if abs(winding_number(point, others)) < 0.5:
            outside += 1
    return outside
