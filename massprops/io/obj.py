"""Wavefront OBJ, read directly: ``v`` and ``f`` lines, polygons fanned into triangles.

A direct reader keeps the coordinates exactly as written (correctly rounded
decimal conversion), names a bad face index with its line, and avoids
importing trimesh.  Indices may be negative (relative) and carry ``/vt/vn``
parts, which are ignored.

Three readers, fastest first, each declining what it cannot read exactly:
the plain layout (``v`` lines, other lines, then only triangle ``f`` lines,
as exporters write them) is cut into blocks with byte operations and its
decimals converted by :mod:`massprops.io.decimals`; the common layout (all
vertices before all faces, triangles with positive indices) by regular
expressions and numpy; anything else line by line.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from ..errors import MeshFormatError
from ..mesh import TriangleMesh
from . import register_format

_VERTEX = re.compile(rb"^v[ \t]+([^\n]*)", re.M)
_FACE = re.compile(rb"^f[ \t]+([^\n]*)", re.M)
_SLASHED = re.compile(rb"/[^ \t\r\n]*")


def read(path):
    with open(path, "rb") as f:
        text = f.read()
    mesh = _read_plain_layout(text)
    if mesh is None:
        mesh = _read_common_layout(text)
    if mesh is None:
        mesh = _read_lines(text.splitlines(), path)
    if mesh.faces.size and mesh.faces.max() >= mesh.vertices.shape[0]:
        _read_lines(text.splitlines(), path)      # names the offending line
    return mesh


def _numbers(chunks, dtype):
    """The numbers in ``chunks`` (whitespace-separated), or an empty array if any is not a number."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            return np.fromstring(b" ".join(chunks), dtype=dtype, sep=" ")
        except ValueError:
            return np.zeros(0, dtype=dtype)


def _tagged_numbers(block, tag, dtype):
    """The numbers of ``block`` if every one of its lines is ``TAG n n n`` (and ``tag`` occurs nowhere else).

    Returns None otherwise.  Deleting the tag bytes leaves a plain list of
    numbers: a few passes in C instead of a regular expression per line.
    """
    block = block.rstrip()
    lines = block.count(b"\n") + 1
    if not block.startswith(tag + b" ") or block.count(b"\n" + tag + b" ") + 1 != lines \
            or block.count(tag) != lines:
        return None
    from .decimals import parse_decimals          # only when an OBJ is read: keeps startup light
    block = block.translate(None, tag)
    numbers = parse_decimals(block) if dtype == np.float64 else None
    if numbers is None:
        numbers = _numbers([block], dtype)
    return numbers if numbers.size == 3 * lines else None


def _read_plain_layout(text):
    """Comment lines, ``v x y z`` lines, other lines (``vt``, ``vn``, ``s``, ...), then only ``f`` lines; or None.

    Faces are triangles with positive indices, corners as ``i``, ``i/t``,
    ``i/t/n`` or ``i//n``.  Other layouts (interleaved, polygons, groups
    between faces, indented lines) return None.
    """
    first_face = text.find(b"\nf ") + 1
    first_vertex = 0 if text.startswith(b"v ") else text.find(b"\nv ") + 1
    if not first_face or (not first_vertex and not text.startswith(b"v ")) or first_vertex > first_face:
        return None
    vertex_end = text.find(b"\n", text.rfind(b"\nv ") + 1) + 1
    if not 0 < vertex_end <= first_face:
        return None
    for other in (b"\n" + text[:first_vertex], b"\n" + text[vertex_end:first_face]):
        # no further vertex or face lines (also not indented or tab-separated) outside the two blocks
        if any(mark in other for mark in (b"\nv\t", b"\nf", b"\n ", b"\n\t")) or other.count(b"\nv ") > 0:
            return None
    coordinates = _tagged_numbers(text[first_vertex:vertex_end], b"v", np.float64)
    faces = None if coordinates is None else _face_corners(text[first_face:])
    if faces is None or faces.min() < 1:
        return None
    return TriangleMesh(coordinates.reshape(-1, 3), faces.reshape(-1, 3) - 1)


def _face_corners(block):
    """The vertex numbers (1-based) of ``f`` lines of three corners each, or None.

    Corners may carry ``/t``, ``/t/n`` or ``//n``: slashes become spaces and
    the first integer of each corner is kept, located by counting the
    corner's slashes (an empty field other than ``//`` breaks the count, and
    the block is declined).
    """
    if b"/" not in block:
        return _tagged_numbers(block, b"f", np.int64)
    block = block.rstrip()
    lines = block.count(b"\n") + 1
    if not block.startswith(b"f ") or block.count(b"\nf ") + 1 != lines or block.count(b"f") != lines:
        return None
    block = block.translate(None, b"f")
    buf = np.frombuffer(block, dtype=np.uint8)
    slash = buf == ord("/")
    edges = np.diff((buf > 32).view(np.int8), prepend=np.int8(0), append=np.int8(0))
    starts = np.flatnonzero(edges == 1)
    if starts.size != 3 * lines or slash[starts].any():
        return None
    fields = 1 + np.bincount(np.searchsorted(starts, np.flatnonzero(slash), side="right") - 1,
                             minlength=starts.size)
    doubled = np.flatnonzero(slash[:-1] & slash[1:])
    fields -= np.bincount(np.searchsorted(starts, doubled, side="right") - 1, minlength=starts.size)
    numbers = _numbers([block.replace(b"/", b" ")], np.int64)
    if numbers.size != fields.sum():
        return None
    return numbers[np.cumsum(fields) - fields]


def _read_common_layout(text):
    """Vertices then triangles with positive indices, or None when the file is laid out otherwise."""
    vertex_lines = _VERTEX.findall(text)
    face_lines = _FACE.findall(text)
    first_face = _FACE.search(text)
    last_vertex = max(text.rfind(b"\nv "), text.rfind(b"\nv\t"))
    if not vertex_lines or not face_lines or last_vertex > first_face.start():
        return None
    coordinates = _numbers(vertex_lines, np.float64)
    if coordinates.size != 3 * len(vertex_lines):        # w or colour columns, or garbage
        return None
    joined = b" ".join(face_lines)
    if b"/" in joined:
        joined = _SLASHED.sub(b"", joined)
    faces = _numbers([joined], np.int64)
    if faces.size != 3 * len(face_lines) or faces.min() < 1:   # polygons, relative indices, garbage
        return None
    return TriangleMesh(coordinates.reshape(-1, 3), faces.reshape(-1, 3) - 1)


def _read_lines(lines, path):
    vertices, faces = [], []
    for number, raw in enumerate(lines, 1):
        parts = raw.split()
        if not parts or parts[0] not in (b"v", b"f"):
            continue
        try:
            if parts[0] == b"v":
                vertices.append((float(parts[1]), float(parts[2]), float(parts[3])))
                continue
            given = [int(p.split(b"/")[0]) for p in parts[1:]]
        except (ValueError, IndexError):
            text = raw.strip()[:60].decode(errors="replace")
            raise MeshFormatError(f"line {number}: cannot read {text!r}", path=path,
                                  fix="re-export the mesh") from None
        ids = [i - 1 if i > 0 else len(vertices) + i for i in given]
        if len(ids) < 3 or 0 in given or min(ids) < 0 or max(ids) >= len(vertices):
            raise MeshFormatError(
                f"line {number}: face {' '.join(map(str, given))} refers to a vertex that does not exist "
                f"({len(vertices)} vertices defined before it)", path=path, fix="re-export the mesh")
        faces.extend((ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1))
    if not faces:
        raise MeshFormatError("the OBJ file holds no faces", path=path, fix="export the part as a closed surface")
    return TriangleMesh(np.array(vertices, dtype=np.float64).reshape(-1, 3), np.array(faces, dtype=np.int64))


def write(path, vertices, faces, comment=""):
    """Write ``v`` and ``f`` lines; coordinates with ``repr``, so they read back bit for bit."""
    lines = [f"# {comment}\n"] if comment else []
    lines += ["v %r %r %r\n" % (float(x), float(y), float(z)) for x, y, z in np.asarray(vertices, dtype=float)]
    lines += ["f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in np.asarray(faces).tolist()]
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.writelines(lines)


register_format("obj", [".obj"], read)
