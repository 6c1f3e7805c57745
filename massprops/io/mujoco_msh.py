"""``.msh`` files: MuJoCo's binary mesh, or Gmsh's (through meshio), told apart by their content.

MuJoCo's binary layout: four little-endian int32 counts ``nvertex, nnormal,
ntexcoord, nface``, then float32 arrays of 3·nvertex coordinates, 3·nnormal
normals, 2·ntexcoord texture coordinates, and int32 ``3·nface`` vertex
indices.  The file's size must be exactly that.  A Gmsh file starts with the
ASCII line ``$MeshFormat`` (both its text and binary variants).
"""

from __future__ import annotations

import os

import numpy as np

from ..model.errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .registry import register_format

__all__ = ["read", "read_mujoco"]

_COUNTS = 16


def read(path):
    with open(path, "rb") as f:
        head = f.read(64)
    if head.lstrip().startswith(b"$MeshFormat") or head.lstrip().startswith(b"$Comments"):
        from .meshio_formats import read as read_meshio
        return read_meshio(path)
    return read_mujoco(path)


def read_mujoco(path):
    """Read a MuJoCo binary ``.msh`` (float32 vertices, welded by exact coordinates)."""
    size = os.path.getsize(path)
    if size < _COUNTS:
        raise MeshFormatError(f"too short for a MuJoCo .msh ({size} bytes; the counts alone take 16) and not a "
                              "Gmsh file", path=path, fix="re-export the mesh")
    with open(path, "rb") as f:
        head = f.read(_COUNTS)
    nvertex, nnormal, ntexcoord, nface = (int(v) for v in np.frombuffer(head, dtype="<i4"))
    expected = _COUNTS + 4 * (3 * nvertex + 3 * nnormal + 2 * ntexcoord + 3 * nface)
    # The counts are checked against the file's size before the rest is read.
    if min(nvertex, nnormal, ntexcoord, nface) < 0 or expected != size:
        raise MeshFormatError(f"not a MuJoCo binary .msh (counts {nvertex}, {nnormal}, {ntexcoord}, {nface} call "
                              f"for {expected} bytes, the file has {size}) nor a Gmsh file", path=path,
                              fix="re-export the mesh, or convert it to STL")
    data = np.fromfile(path, dtype="<u1", count=size)
    if nface == 0:
        raise MeshFormatError("the MuJoCo .msh has no faces (MuJoCo would use the convex hull of its points)",
                              path=path, fix="export the mesh with its faces")
    start = _COUNTS
    vertices = data[start:start + 12 * nvertex].view("<f4").reshape(-1, 3)
    start += 4 * (3 * nvertex + 3 * nnormal + 2 * ntexcoord)
    faces = data[start:start + 12 * nface].view("<i4").reshape(-1, 3).astype(np.int64)
    if faces.min() < 0 or faces.max() >= nvertex:
        raise MeshFormatError(f"a face refers to vertex {int(faces.max() if faces.max() >= nvertex else faces.min())}"
                              f" of {nvertex}", path=path, fix="re-export the mesh")
    return TriangleMesh.from_indexed(np.ascontiguousarray(vertices.astype(np.float32)), faces,
                                     source_dtype=np.float32)


register_format("msh", [".msh"], read)
