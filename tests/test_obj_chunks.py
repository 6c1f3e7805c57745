"""OBJ files of a few MiB, which the reader cuts into parts read on several threads.

Each file is dense with what a cut could break (line ends of every kind,
statements continued on the next line, comments that swallow the next line,
corners with slashes and negative indices, long lines), so that wherever the
parts begin, every value and the order of vertices and faces must be those of
reading the file from its start.  The oracle is a plain Python reading of the
same bytes (``bytes.splitlines``, ``float``) and a weld by first use.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.core import read_obj, weld_indexed
from massprops.io import read
from massprops.model.errors import MeshFormatError

BLANKS = b" \t\x0b\x0c"
SIZE = 2_300_000            # bytes: more than two parts of 1 MiB
FORMATS = ["%r", "%.17g", "%.6f", "%.3e", "%.9g", "%.0f"]
ENDS = [b"\n", b"\n", b"\r\n", b"\r\n", b"\r"]


def _number(rng):
    value = float(rng.choice([rng.normal(0, 100), rng.uniform(-1, 1) * 10.0 ** rng.integers(-8, 9), 0.0, -0.0]))
    return (FORMATS[rng.integers(len(FORMATS))] % value).encode()


def _corner(rng, defined):
    vertex = int(rng.integers(1, defined + 1))
    index = vertex if rng.random() < 0.6 else vertex - defined - 1          # negative: counted back
    return (b"%d" % index) + [b"", b"/3", b"//-2", b"/1/7", b"/"][rng.integers(5)]


def _statements(rng, size):
    """Lines (without their ends) of an OBJ of about `size` bytes whose faces use earlier vertices."""
    lines, defined, total = [], 0, 0
    while total < size:
        kind = rng.random()
        if defined < 3 or kind < 0.35:
            line = b"v " + b" ".join(_number(rng) for _ in range(3 + 4 * (rng.random() < 0.1)))
            if rng.random() < 0.1:
                line += b" # a comment"
            defined += 1
            group = [line]
        elif kind < 0.7:
            corners = [_corner(rng, defined) for _ in range(int(rng.integers(3, 6)))]
            if rng.random() < 0.2:                        # continued on the next line
                cut = int(rng.integers(1, len(corners)))
                group = [b"f " + b" ".join(corners[:cut]) + b" \\" + b" " * int(rng.integers(0, 3)),
                         b"  " + b" ".join(corners[cut:])]
            else:
                group = [b"f " + b" ".join(corners)]
        elif kind < 0.8:                                  # a comment that swallows the next line
            group = [b"# note \\", b"v 1 2 3" if rng.random() < 0.5 else b"f 1 2 3"]
        elif kind < 0.803:
            group = [b"# " + b"x" * int(rng.integers(70_000, 140_000))]      # longer than the reader's look-ahead
        else:
            group = [[b"", b"   ", b"vt 0.5 0.5", b"vn 0 0 1", b"o part", b"g", b"s off", b"usemtl steel",
                      b"# plain comment", b"\t"][rng.integers(10)]]
        if rng.random() < 0.1:
            group = [b"  " + line for line in group]
        lines += group
        total += sum(len(line) + 1 for line in group)
    return lines


def _join(rng, lines):
    data = b""
    parts = []
    for k, line in enumerate(lines):
        end = ENDS[rng.integers(len(ENDS))]
        if end == b"\r" and k + 1 < len(lines) and lines[k + 1] == b"":
            end = b"\n"                                   # "\r" then an empty "\n" line would be one "\r\n"
        parts += [line, end]
    data = b"".join(parts)
    return data


def _oracle(data):
    """(vertices, faces) as read from the start: statements, float(), fans, weld by first use."""
    lines = data.splitlines()
    points, corners, k = [], [], 0
    while k < len(lines):
        text = lines[k]
        while text.rstrip(BLANKS).endswith(b"\\") and k + 1 < len(lines):
            text = text.rstrip(BLANKS)[:-1] + b" " + lines[k + 1]
            k += 1
        k += 1
        words = text.split()
        words = words[:next((i for i, w in enumerate(words) if w.startswith(b"#")), len(words))]
        if words and words[0] == b"v":
            points.append(tuple(float(w) for w in words[1:4]))
        elif words and words[0] == b"f":
            given = [int(w.split(b"/")[0]) for w in words[1:]]
            index = [g - 1 if g > 0 else len(points) + g for g in given]
            corners += [(index[0], index[j], index[j + 1]) for j in range(1, len(index) - 1)]
    numbers, vertices, faces = {}, [], []
    for triangle in corners:
        face = []
        for i in triangle:
            key = points[i]
            if key not in numbers:                        # -0.0 == 0.0: one vertex
                numbers[key] = len(vertices)
                vertices.append(tuple(x + 0.0 for x in key))
            face.append(numbers[key])
        faces.append(face)
    return np.array(vertices), np.array(faces, dtype=np.int64)


def _read_with(path, threads):
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MASSPROPS_THREADS", str(threads))
        vertices, faces, _ = read_obj(path)
    return vertices, faces


@settings(max_examples=4, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_file_read_in_parts_is_the_file_read_from_its_start(tmp_path_factory, seed):
    rng = np.random.default_rng(seed)
    data = _join(rng, _statements(rng, SIZE))
    path = tmp_path_factory.mktemp("chunks") / "dense.obj"
    path.write_bytes(data)
    vertices, faces = _oracle(data)
    for threads in (1, 2, 3):
        got_vertices, got_faces = _read_with(path, threads)
        assert np.array_equal(got_faces, faces), threads
        assert got_vertices.tobytes() == vertices.tobytes(), threads      # bit for bit, +0.0 for -0.0


def _plain_obj(count):
    """Lines of a simple OBJ: `count` triangles, each on its own three vertices."""
    lines = []
    for k in range(count):
        lines += [b"v %r 0.25 %r" % (k * 0.5, k * 1.5), b"v %r 1.25 0.5" % (k * 0.5), b"v 0.75 %r 2" % (k + 0.5)]
        lines.append(b"f -3 %d -1" % (3 * k + 2))
    return lines


def test_the_first_error_of_a_file_read_in_parts_is_reported_with_its_line(tmp_path, monkeypatch):
    lines = _plain_obj(60_000)                            # about 2.5 MB
    first, second = len(lines) // 16 * 4 + 3, len(lines) // 16 * 12 + 3   # face lines a quarter and three in
    assert lines[first].startswith(b"f") and lines[second].startswith(b"f")
    lines[first] = b"f -3 1 %d" % (len(lines))            # a vertex defined only later in the file
    lines[second] = b"f 1 2 x"
    path = tmp_path / "bad.obj"
    path.write_bytes(b"\r\n".join(lines) + b"\r\n")
    monkeypatch.setenv("MASSPROPS_THREADS", "2")
    with pytest.raises(MeshFormatError, match=rf"line {first + 1}: face corner {len(lines)} refers to a vertex "
                                              r"that does not exist"):
        read(path)
    lines[first] = b"f 1 2 3"
    path.write_bytes(b"\r\n".join(lines) + b"\r\n")
    with pytest.raises(MeshFormatError, match=rf"line {second + 1}: cannot read 'f 1 2 x'"):
        read(path)


def test_negative_corners_reach_back_across_parts(tmp_path):
    """Every face of the second half refers back, by negative index, to vertices of the first half."""
    count = 50_000
    vertices = [b"v %r %r %r" % (0.1 * k, 0.2 * k + 1, -0.3 * k) for k in range(3 * count)]
    faces = [b"f %d/1 %d//2 %d" % (-3 * count + 3 * k, -3 * count + 3 * k + 1, -3 * count + 3 * k + 2)
             for k in range(count)]
    data = b"\n".join(vertices + faces) + b"\n"
    path = tmp_path / "back.obj"
    path.write_bytes(data)
    expected_vertices, expected_faces = _oracle(data)
    for threads in (1, 2):
        got_vertices, got_faces = _read_with(path, threads)
        assert np.array_equal(got_faces, expected_faces) and got_vertices.tobytes() == expected_vertices.tobytes()


@pytest.mark.parametrize("threads", [1, 2])
def test_a_large_indexed_mesh_is_welded_by_first_use(threads):
    """330k vertices, all used (enough for the threads to share them out), many of them repeats of
    others (and -0.0 of 0.0), and ten unused ones that are not finite."""
    rng = np.random.default_rng(24)
    distinct = rng.integers(-4, 5, size=(120_000, 3)).astype(float) * 0.25
    distinct[:50, 0] = -0.0
    vertices = distinct[rng.integers(0, len(distinct), size=329_998)]
    vertices[-10:] = np.nan                               # unused, not finite: counted, left out
    faces = np.concatenate([rng.permutation(329_988).reshape(-1, 3), rng.integers(0, 329_988, size=(20_000, 3))])
    numbers, expected_vertices, expected_faces = {}, [], []
    for face in faces.tolist():
        row = []
        for i in face:
            key = tuple(vertices[i])
            if key not in numbers:
                numbers[key] = len(expected_vertices)
                expected_vertices.append(tuple(x + 0.0 for x in key))
            row.append(numbers[key])
        expected_faces.append(row)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MASSPROPS_THREADS", str(threads))
        welded, renumbered, ignored = weld_indexed(vertices, faces)
    assert np.array_equal(renumbered, np.array(expected_faces))
    assert welded.tobytes() == np.array(expected_vertices).tobytes()
    assert ignored == 10
