"""STL, binary and ASCII, read with numpy alone (no trimesh import).

Binary STL coordinates are float32: they are widened to float64 exactly, so
every later computation sees the values the file holds.  ASCII coordinates are
parsed with Python's correctly rounded ``float``.
"""

from __future__ import annotations

import mmap
import os
import re

import numpy as np

from ..errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .registry import register_format

_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_HEADER = 84
_BLOCK = 1 << 18                           # records per pass: 13 MB of the file
_DROP = getattr(mmap, "MADV_DONTNEED", None)
_VERTEX = re.compile(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)")


def read(path):
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        head = f.read(_HEADER)
    if size == 0:
        raise MeshFormatError("the file is empty", path=path, fix="re-export the mesh")
    if len(head) >= _HEADER:
        count = int.from_bytes(head[80:84], "little")
        if size == _HEADER + count * _RECORD.itemsize:
            return _read_binary(path, count)
    if head.lstrip()[:5].lower() == b"solid":
        return _read_ascii(path)
    if len(head) < _HEADER:
        raise MeshFormatError(f"too short for binary STL ({size} bytes, a header needs 84)", path=path,
                              fix="re-export the mesh")
    expected = _HEADER + count * _RECORD.itemsize
    raise MeshFormatError(
        f"binary STL header says {count} triangles ({expected} bytes) but the file has {size} bytes",
        path=path, fix="the file is truncated or not an STL; re-export it")


def _read_binary(path, count):
    if count == 0:
        raise MeshFormatError("the STL holds no triangles", path=path, fix="export the part as a closed surface")
    # Passed as a temporary, so from_corners holds the only reference and can free it.
    return TriangleMesh.from_corners(_binary_corners(path, count), source_dtype=np.float32)


def _binary_corners(path, count):
    """The corners (3·count, 3) float32 of a binary STL, with -0.0 made +0.0 (as welding needs).

    The file is mapped, not read: strided passes copy the corners (36 of
    every 50 bytes) straight from the page cache.  Pages already copied are
    dropped from the mapping as it goes, so only the corners stay resident.
    """
    corners = np.empty((count, 3, 3), dtype=np.float32)
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mapped:
        if len(mapped) < _HEADER + count * _RECORD.itemsize:
            raise MeshFormatError("the file ended early", path=path, fix="re-export the mesh")
        records = np.frombuffer(mapped, dtype=_RECORD, count=count, offset=_HEADER)
        for start in range(0, count, _BLOCK):
            stop = min(count, start + _BLOCK)
            np.add(records["corners"][start:stop], np.float32(0.0), out=corners[start:stop])
            if _DROP is not None:
                done = (_HEADER + stop * _RECORD.itemsize) // mmap.PAGESIZE * mmap.PAGESIZE
                mapped.madvise(_DROP, 0, done)
        del records                   # the map cannot close while an array views it
    return corners.reshape(-1, 3)


def _read_ascii(path):
    with open(path, "rb") as f:
        text = f.read()
    found = _VERTEX.findall(text)
    if not found or len(found) % 3:
        what = "no 'vertex' lines" if not found else f"{len(found)} vertices, not a multiple of 3"
        raise MeshFormatError(f"not a valid ASCII STL ({what})", path=path, fix="re-export the mesh")
    try:
        corners = np.array(found, dtype=np.float64)
    except ValueError:
        raise MeshFormatError("ASCII STL has a vertex coordinate that is not a number", path=path,
                              fix="re-export the mesh") from None
    return TriangleMesh.from_triangles(corners.reshape(-1, 3, 3))


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


register_format("stl", [".stl"], read)
