"""Wavefront OBJ, read directly: ``v`` and ``f`` lines, polygons fanned into triangles.

A direct reader keeps the coordinates exactly as written (correctly rounded
``float``), names a bad face index with its line, and avoids importing trimesh.
Indices may be negative (relative) and carry ``/vt/vn`` parts, which are ignored.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshFormatError
from ..mesh import TriangleMesh
from . import register_format


def read(path):
    vertices, faces = [], []
    with open(path, "rb") as f:
        for number, raw in enumerate(f, 1):
            parts = raw.split()
            if not parts:
                continue
            tag = parts[0]
            try:
                if tag == b"v":
                    vertices.append((float(parts[1]), float(parts[2]), float(parts[3])))
                elif tag == b"f":
                    ids = [int(p.split(b"/")[0]) for p in parts[1:]]
                    ids = [i - 1 if i > 0 else len(vertices) + i for i in ids]
                    if len(ids) < 3 or min(ids) < 0 or max(ids) >= len(vertices) or 0 in (
                            int(p.split(b"/")[0]) for p in parts[1:]):
                        raise MeshFormatError(
                            f"line {number}: face refers to vertex {parts[1:]!r} but only "
                            f"{len(vertices)} vertices are defined before it", path=path,
                            fix="re-export the mesh")
                    faces.extend((ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1))
            except (ValueError, IndexError):
                raise MeshFormatError(f"line {number}: cannot read {raw.strip()[:60]!r}", path=path,
                                      fix="re-export the mesh") from None
    if not faces:
        raise MeshFormatError("the OBJ file holds no faces", path=path, fix="export the part as a closed surface")
    return TriangleMesh(np.array(vertices, dtype=np.float64).reshape(-1, 3), np.array(faces, dtype=np.int64))


register_format("obj", [".obj"], read)
