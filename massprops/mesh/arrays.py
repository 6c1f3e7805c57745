"""Meshes handed over in memory: ``(vertices, faces)`` arrays, and objects that carry them.

What the Python API accepts besides a path: a :class:`TriangleMesh` or
:class:`VolumeMesh` as is; any object with ``vertices`` and ``faces`` (a
``trimesh.Trimesh``) or ``vertices`` and ``triangles`` (Open3D's
``TriangleMesh``, as arrays); a ``(vertices, faces)`` pair of arrays or
lists, with faces of any integer type; an ``(m, 3, 3)`` array of triangle
corners (numpy-stl's ``vectors``, or an object carrying them).  The vertices are welded by exact
coordinates, as every reader welds them (trimesh keeps an STL's corners
apart), and unused vertices drop out.  Anything else raises a ``TypeError``
or ``ValueError`` that names the argument and what was expected.
"""

from __future__ import annotations

import os

import numpy as np

from ..model.errors import ArgumentTypeError, OptionError
from .surface import TriangleMesh

__all__ = ["as_mesh", "mesh_from_arrays", "mesh_from_triangles", "is_path", "SOURCE_FORMS"]

SOURCE_FORMS = ("a path, a TriangleMesh, a trimesh.Trimesh or trimesh.Scene, an object with vertices and faces, "
                "a (vertices, faces) pair, or an (m, 3, 3) array of triangles")


def is_path(value):
    return isinstance(value, (str, bytes, os.PathLike))


def _array(value, name, argument):
    try:
        array = np.asarray(value)
    except (ValueError, TypeError):
        array = None
    if array is None or array.dtype == object:
        raise ArgumentTypeError(f"{argument}: {name} must be an array of numbers (ragged lists or other objects "
                                f"cannot be), got {type(value).__name__}")
    return array


def mesh_from_arrays(vertices, faces, *, argument="source"):
    """A welded :class:`TriangleMesh` from vertex coordinates and triangle indices.

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
        Coordinates, any real dtype; float32 values are kept exactly (and
        their precision is reported as the input resolution).
    faces : array_like, shape (m, 3)
        Indices into ``vertices``, any integer dtype, counter-clockwise seen
        from outside.
    argument : str
        The argument's name, for messages.

    Raises
    ------
    TypeError
        Not arrays of numbers; faces that are not integers.
    ValueError
        Wrong shapes, no faces, or indices outside ``vertices``.
    """
    vertices = _array(vertices, "vertices", argument)
    faces = _array(faces, "faces", argument)
    if vertices.dtype.kind not in "fiu":
        raise ArgumentTypeError(f"{argument}: vertices must be real numbers, got dtype {vertices.dtype}")
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise OptionError(f"{argument}: vertices must have shape (n, 3), got {vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3:
        hint = " (polygons: triangulate them first)" if faces.ndim == 2 and faces.shape[1] > 3 else ""
        raise OptionError(f"{argument}: faces must have shape (m, 3), triangles, got {faces.shape}{hint}")
    if faces.dtype.kind not in "iu":
        raise ArgumentTypeError(f"{argument}: faces must be integer vertex indices, got dtype {faces.dtype}",
                                fix="cast them, e.g. faces.astype(np.int64), if they are whole numbers")
    if faces.shape[0] == 0:
        raise OptionError(f"{argument}: there are no faces")
    low, high = int(faces.min()), int(faces.max())
    if low < 0 or high >= vertices.shape[0]:
        bad = low if low < 0 else high
        raise OptionError(f"{argument}: faces refer to vertex {bad}, but the vertices are numbered 0 to "
                          f"{vertices.shape[0] - 1}")
    coordinates = vertices if vertices.dtype in (np.float32, np.float64) else vertices.astype(np.float64)
    return TriangleMesh.from_triangles(coordinates[faces.astype(np.int64, copy=False)])


def mesh_from_triangles(triangles, *, argument="source"):
    """A welded :class:`TriangleMesh` from an ``(m, 3, 3)`` array of triangle corners (numpy-stl's ``vectors``)."""
    corners = _array(triangles, "triangles", argument)
    if corners.dtype.kind not in "fiu":
        raise ArgumentTypeError(f"{argument}: triangle corners must be real numbers, got dtype {corners.dtype}")
    if corners.ndim != 3 or corners.shape[1:] != (3, 3):
        raise OptionError(f"{argument}: triangles must have shape (m, 3, 3), got {corners.shape}")
    if corners.shape[0] == 0:
        raise OptionError(f"{argument}: there are no triangles")
    return TriangleMesh.from_triangles(corners if corners.dtype in (np.float32, np.float64)
                                       else corners.astype(np.float64))


def _is_triangle_array(source):
    """An ``(m, 3, 3)`` array, or a list of triangles (not a two-item (vertices, faces) pair)."""
    if isinstance(source, np.ndarray):
        return source.ndim == 3
    if isinstance(source, (list, tuple)) and len(source) != 2 and source:
        try:
            return np.asarray(source).ndim == 3
        except (ValueError, TypeError):
            return False
    return False


def as_mesh(source, *, argument="source"):
    """The mesh that an in-memory ``source`` describes (see the module's list); paths are the caller's."""
    from .volume import VolumeMesh
    if isinstance(source, (TriangleMesh, VolumeMesh)):
        return source
    if hasattr(source, "vertices") and (hasattr(source, "faces") or hasattr(source, "triangles")):
        faces = source.faces if hasattr(source, "faces") else source.triangles
        return mesh_from_arrays(source.vertices, faces, argument=argument)
    if hasattr(source, "vectors") and not hasattr(source, "vertices"):          # numpy-stl's mesh.Mesh
        return mesh_from_triangles(source.vectors, argument=argument)
    if _is_triangle_array(source):
        return mesh_from_triangles(source, argument=argument)
    if isinstance(source, (tuple, list)):
        if any(is_path(item) for item in source):
            raise ArgumentTypeError(f"{argument}: a list of paths; mass_properties takes one source",
                                    fix="call it once per file, [mass_properties(p) for p in paths], or use "
                                        "massprops.batch.run.run_batch for a report over many files")
        if len(source) == 2:
            return mesh_from_arrays(*source, argument=argument)
    raise ArgumentTypeError(f"{argument}: expected {SOURCE_FORMS}; got {type(source).__name__}")
