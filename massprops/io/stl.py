"""STL, binary and ASCII: read by the compiled core straight into a welded mesh (no trimesh import).

Binary STL coordinates are float32: they are widened to float64 exactly, so
every later computation sees the values the file holds.  ASCII coordinates
are read as Python's correctly rounded ``float`` reads them.  See
:func:`massprops.core.read_stl` for how the two are told apart.
"""

from __future__ import annotations

import numpy as np

from ..core import read_stl
from ..mesh.surface import TriangleMesh
from .registry import register_format

_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


_SINGLE, _DOUBLE = np.dtype(np.float32), np.dtype(np.float64)


def read(path):
    vertices, faces, binary = read_stl(path)
    # every field by position: the record's quickest construction (a batch reads one file per part)
    return TriangleMesh(vertices, faces, _SINGLE if binary else _DOUBLE, (), None)


def write_binary(path, triangles, header=b"massprops"):
    """Write triangles (m, 3, 3) as binary STL (float32, as the format holds)."""
    triangles = np.asarray(triangles, dtype=np.float64)
    records = np.zeros(triangles.shape[0], dtype=_RECORD)
    records["corners"] = triangles
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    records["normal"] = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    with open(path, "wb") as f:
        f.write(header[:80].ljust(80, b" "))
        f.write(np.uint32(triangles.shape[0]).tobytes())
        records.tofile(f)


register_format("stl", [".stl"], read, unpacks=False)
