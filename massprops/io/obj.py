"""Wavefront OBJ, read directly: ``v`` and ``f`` lines, polygons fanned into triangles.

Vertices are welded by exact coordinates (a closed surface that repeats its
corners per face, for per-face normals or UV seams, is closed).

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

import os
import re
import warnings

import numpy as np

from ..errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .registry import register_format
from .decimals import PAD as _PAD                 # bytes kept free around the text for the decimal windows

_VERTEX = re.compile(rb"^v[ \t]+([^\n]*)", re.M)
_FACE = re.compile(rb"^f[ \t]+([^\n]*)", re.M)
_SLASHED = re.compile(rb"/[^ \t\r\n]*")


def read(path):
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        padded = bytearray(_PAD + size + 1 + _PAD)   # read once, with room for the decimal windows
        padded[_PAD + size] = 10                      # the last line ends, as if the file ended in a newline
        complete = f.readinto(memoryview(padded)[_PAD:_PAD + size]) == size and not f.read(1)
    mesh = _read_padded(padded, size) if complete else None
    return mesh if mesh is not None else _read_general(path)


def _read_general(path):
    """The layouts the plain reader declines: regular expressions, else line by line (which names errors)."""
    with open(path, "rb") as f:
        text = f.read()
    mesh = _read_common_layout(text)
    if mesh is None:
        mesh = _read_lines(text.splitlines(), path)
    if mesh.faces.size and mesh.faces.max() >= mesh.vertices.shape[0]:
        _read_lines(text.splitlines(), path)      # names the offending line
    return mesh


def _read_plain_layout(text):
    """Comment lines, ``v x y z`` lines, other lines (``vt``, ``vn``, ``s``, ...), then only ``f`` lines; or None.

    Faces are triangles with positive indices, corners as ``i``, ``i/t``,
    ``i/t/n`` or ``i//n``.  Other layouts (interleaved, polygons, groups
    between faces, indented lines) return None.
    """
    return _read_padded(bytes(_PAD) + text + b"\n" + bytes(_PAD), len(text))


def _read_padded(padded, size):
    """:func:`_read_plain_layout` of the ``size`` bytes after the first ``_PAD`` of ``padded`` (then ``\\n``)."""
    buf = np.frombuffer(padded, dtype=np.uint8)
    blocks = _blocks(buf, size)
    if blocks is None:
        return None
    from . import decimals
    vertex_lines, face_lines, face_end = blocks
    tokens = _line_tokens(buf, vertex_lines[:-1], vertex_lines[-1])
    coordinates = None if tokens is None else decimals.token_values(buf, *tokens)
    faces = None if coordinates is None else _face_corners(buf, face_lines, face_end, decimals)
    if faces is None or faces.min() < 1 or faces.max() > coordinates.size // 3:
        return None
    return TriangleMesh.from_indexed(coordinates.reshape(-1, 3), faces.reshape(-1, 3) - 1)


def _blocks(buf, size):
    """Starts of the ``v`` lines (and of the line after), of the ``f`` lines, and the end of the last; or None.

    Plain: one run of ``v`` lines, then one run of ``f`` lines up to the end
    (blank lines aside); no other line that ``bytes.split`` would start
    with ``v`` or ``f``, no indented line, no lone CR (``bytes.splitlines``
    splits there).
    """
    body = buf[_PAD:_PAD + size + 1]
    if buf[_PAD + size] != 10 or np.any(buf[np.flatnonzero(body == 13) + _PAD + 1] != 10):
        return None
    line_starts = np.flatnonzero(body == 10)
    line_starts[1:] = line_starts[:-1] + 1 + _PAD
    line_starts[0] = _PAD
    first, second = buf[line_starts], buf[line_starts + 1]
    spaced = (second == 32) | (second == 9)
    vertex, face = np.flatnonzero((first == 118) & spaced), np.flatnonzero((first == 102) & spaced)
    if not vertex.size or not face.size or vertex[-1] >= face[0]:
        return None
    blank = (first == 10) | ((first == 13) & (second == 10))
    stray = ((first == 118) | (first == 102)) & ~spaced & (second <= 32) | (first <= 32) & ~blank
    if (vertex[-1] - vertex[0] + 1 != vertex.size or np.any(stray[:face[0]])
            or not np.all(blank[face[-1] + 1:]) or face[-1] - face[0] + 1 != face.size):
        return None
    after = line_starts[face[-1] + 1] if face[-1] + 1 < line_starts.size else _PAD + size + 1
    return line_starts[vertex[0]:vertex[-1] + 2], line_starts[face[0]:face[-1] + 1], after


def _line_tokens(buf, line_starts, end):
    """Starts and ends of the three words after the tag on each line (from ``line_starts`` to ``end``), or None.

    Words are split as ``bytes.split`` splits them: at spaces and tabs; a
    line ends at ``\\n`` or ``\\r\\n``.
    """
    separator = np.flatnonzero(buf[line_starts[0]:end] <= 32)
    separator += line_starts[0]
    kind = buf[separator]
    if np.count_nonzero(kind == 32) + line_starts.size != separator.size:
        return _spaced_tokens(buf, line_starts, separator, kind)
    if separator.size != 4 * line_starts.size:
        return None
    separator = separator.reshape(-1, 4)
    starts = separator[:, :3] + 1
    ends = separator[:, 1:]
    if not (np.array_equal(separator[:, 0], line_starts + 1) and np.all(ends > starts)):
        return None
    return starts.ravel(), ends.ravel()


def _spaced_tokens(buf, line_starts, separator, kind):
    """:func:`_line_tokens` where tabs, CR or runs of separators occur."""
    newline = kind == 10
    if not np.all(newline | (kind == 32) | (kind == 9) | ((kind == 13) & (buf[separator + 1] == 10))):
        return None                               # other control characters split lines or words otherwise
    starts = np.concatenate(([line_starts[0]], separator[:-1] + 1))
    words = separator > starts
    starts, separator = starts[words], separator[words]
    if starts.size != 4 * line_starts.size:
        return None
    starts, ends = starts.reshape(-1, 4), separator.reshape(-1, 4)
    if not (np.array_equal(starts[:, 0], line_starts) and np.array_equal(ends[:, 0], line_starts + 1)):
        return None
    return starts[:, 1:].ravel(), ends[:, 1:].ravel()


def _face_corners(buf, line_starts, end, decimals):
    """The vertex numbers (1-based) of ``f`` lines of three corners each, or None.

    Corners may carry ``/t``, ``/t/n`` or ``//n``: the number is what
    precedes the first slash (a corner ending in a slash is declined).
    """
    tokens = _line_tokens(buf, line_starts, end)
    if tokens is None:
        return None
    starts, ends = tokens
    lengths = ends - starts
    if np.any(buf[line_starts[0]:end] == ord("/")):
        slash = decimals.first_byte_at(buf, starts, ord("/"))
        if np.any(buf[ends - 1] == ord("/")) or np.any((slash == 8) & (lengths > 8) & (buf[starts + 8] != ord("/"))):
            return None
        lengths = np.minimum(lengths, slash)
    return decimals.small_integers(buf, starts, lengths)


def _numbers(chunks, dtype):
    """The numbers in ``chunks`` (whitespace-separated), or an empty array if any is not a number."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            return np.fromstring(b" ".join(chunks), dtype=dtype, sep=" ")
        except ValueError:
            return np.zeros(0, dtype=dtype)


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
    return TriangleMesh.from_indexed(coordinates.reshape(-1, 3), faces.reshape(-1, 3) - 1)


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
    return TriangleMesh.from_indexed(np.array(vertices, dtype=np.float64).reshape(-1, 3),
                                     np.array(faces, dtype=np.int64))


def write(path, vertices, faces, comment=""):
    """Write ``v`` and ``f`` lines; coordinates with ``repr``, so they read back bit for bit."""
    lines = [f"# {comment}\n"] if comment else []
    lines += ["v %r %r %r\n" % (float(x), float(y), float(z)) for x, y, z in np.asarray(vertices, dtype=float)]
    lines += ["f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in np.asarray(faces).tolist()]
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.writelines(lines)


register_format("obj", [".obj"], read, text=True)
