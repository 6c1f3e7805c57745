"""The bad-input corpus: files that must each be refused with one line naming them.

``make_bad_files(directory)`` writes them and returns ``{path: fragment}``,
where ``fragment`` is a piece of text the error line must contain.  Shared by
the props tests and the batch tests.
"""

from __future__ import annotations

import os

import numpy as np

from massprops.validation import solids
from massprops.io.stl import write_binary


def _write_obj(path, vertices, faces):
    with open(path, "w") as f:
        for v in vertices:
            f.write("v %r %r %r\n" % tuple(float(x) for x in v))
        for face in faces:
            f.write("f " + " ".join(str(int(i) + 1) for i in face) + "\n")


def make_bad_files(directory):
    """Write one file per way an input can be bad; return ``{path: expected message fragment}``."""
    d = str(directory)
    box = solids.box((1.0, 2.0, 3.0))
    out = {}

    def path(name):
        return os.path.join(d, name)

    open(path("empty.stl"), "wb").close()
    out[path("empty.stl")] = "empty"

    write_binary(path("truncated.stl"), box.triangles)
    with open(path("truncated.stl"), "r+b") as f:
        f.truncate(84 + 50 * 5 + 17)
    out[path("truncated.stl")] = "truncated"

    with open(path("zero_count.stl"), "wb") as f:
        f.write(b"\0" * 80 + (0).to_bytes(4, "little"))
    out[path("zero_count.stl")] = "no triangles"

    with open(path("huge_count.stl"), "wb") as f:
        f.write(b"\0" * 80 + (4_000_000_000).to_bytes(4, "little") + b"\0" * 100)
    out[path("huge_count.stl")] = "4000000000 triangles"

    tri = box.triangles.copy()
    tri[3, 1, 2] = np.nan
    write_binary(path("nan.stl"), tri)
    out[path("nan.stl")] = "NaN"

    tri = box.triangles.copy()
    tri[5, 0, 0] = np.inf
    _write_obj(path("inf.obj"), tri.reshape(-1, 3), np.arange(tri.shape[0] * 3).reshape(-1, 3))
    out[path("inf.obj")] = "infinite"

    write_binary(path("open.stl"), box.triangles[:-1])
    out[path("open.stl")] = "open"

    miswound = box.faces.copy()
    miswound[0] = miswound[0, ::-1]
    write_binary(path("miswound.stl"), box.vertices[miswound])
    out[path("miswound.stl")] = "wound inconsistently"

    write_binary(path("duplicate_face.stl"), np.concatenate([box.triangles, box.triangles[:1]]))
    out[path("duplicate_face.stl")] = "duplicated"

    flat = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, 1, 0], [1, 0, 0]]], dtype=float)
    write_binary(path("flat.stl"), flat)
    out[path("flat.stl")] = "zero volume"

    with open(path("bad_index.obj"), "w") as f:
        f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    out[path("bad_index.obj")] = "vertex"

    with open(path("garbage.stl"), "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 3)
    out[path("garbage.stl")] = "STL"

    with open(path("notes.xyz"), "w") as f:
        f.write("not a mesh\n")
    out[path("notes.xyz")] = "unknown mesh format"

    os.mkdir(path("a_directory.stl"))
    out[path("a_directory.stl")] = "directory"

    out[path("missing.stl")] = "no such file"
    return out
