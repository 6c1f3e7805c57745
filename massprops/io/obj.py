"""Wavefront OBJ: read by the compiled core straight into a welded mesh (no trimesh import).

One reader with one behaviour (:func:`massprops.core.read_obj`): ``v`` and
``f`` statements, indented or not, corners ``i``, ``i/t``, ``i//n``,
``i/t/n``, negative indices, polygons fanned; coordinates exactly as
Python's ``float`` reads them; errors name their line.  Vertices are welded
by exact coordinates (a closed surface that repeats its corners per face,
for per-face normals or UV seams, is closed) and vertices no face uses take
no part.
"""

from __future__ import annotations

import numpy as np

from ..core import read_obj
from ..mesh.surface import TriangleMesh, unused_note
from .registry import register_format


_DOUBLE = np.dtype(np.float64)


def read(path):
    vertices, faces, ignored = read_obj(path)
    # every field by position: the record's quickest construction (a batch reads one file per part)
    return TriangleMesh(vertices, faces, _DOUBLE, unused_note(ignored), None)


def write(path, vertices, faces, comment=""):
    """Write ``v`` and ``f`` lines; coordinates with ``repr``, so they read back bit for bit."""
    lines = [f"# {comment}\n"] if comment else []
    lines += ["v %r %r %r\n" % (float(x), float(y), float(z)) for x, y, z in np.asarray(vertices, dtype=float)]
    lines += ["f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in np.asarray(faces).tolist()]
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.writelines(lines)


register_format("obj", [".obj"], read, unpacks=False)
