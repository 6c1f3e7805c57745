"""The STL and OBJ readers, through the public API: values as written, and hostile files refused in one line.

Coordinates are compared with what Python's ``float`` makes of the same text
(correctly rounded), or with the float32 values a binary STL holds; welding
may renumber vertices, so meshes are compared triangle by triangle.
"""

import os
import struct
import subprocess
import sys
import threading

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.validation import solids
from massprops import mass_properties
from massprops.model.errors import MeshFormatError
from massprops.io import read
from massprops.io.stl import write_binary


def _triangles(mesh):
    return mesh.vertices[mesh.faces]


def _write(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


# --- OBJ: numbers ------------------------------------------------------------------------------

def _obj_of_tokens(tokens):
    """An OBJ whose faces use the tokens, three per vertex, and the triangles float() makes of them."""
    tokens = tokens + [b"0"] * (-len(tokens) % 9)
    lines = [b"v " + b" ".join(tokens[k:k + 3]) for k in range(0, len(tokens), 3)]
    lines += [b"f %d %d %d" % (k + 1, k + 2, k + 3) for k in range(0, len(lines), 3)]
    expected = np.array([float(t) for t in tokens]).reshape(-1, 3, 3)
    return b"\n".join(lines) + b"\n", expected


def _assert_reads_as_float(tmp_path, tokens):
    text, expected = _obj_of_tokens(tokens)
    mesh = read(_write(tmp_path, "numbers.obj", text))
    assert np.array_equal(_triangles(mesh), expected), [t for t in tokens][:5]


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(finite, min_size=1, max_size=60),
       st.sampled_from(["%r", "%.17g", "%.16g", "%.9f", "%.3E", "%.0f", "%.20f", "%.25e", "%.18g", "%.6g"]))
def test_obj_coordinates_are_what_float_reads(tmp_path_factory, values, fmt):
    _assert_reads_as_float(tmp_path_factory.mktemp("obj"), [(fmt % v).encode() for v in values])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["", "-", "+"]), st.text("0123456789", min_size=1, max_size=21),
                          st.text("0123456789", max_size=24), st.sampled_from(["", "e", "E-", "e+", "e-"]),
                          st.integers(0, 400)), min_size=1, max_size=40))
def test_random_digit_strings_read_as_float(tmp_path_factory, parts):
    tokens = [f"{s}{w}.{f}{m}{e if m else ''}".encode() for s, w, f, m, e in parts]
    _assert_reads_as_float(tmp_path_factory.mktemp("obj"), tokens)


def test_midpoints_between_doubles_and_edge_tokens_read_as_float(tmp_path):
    from decimal import Decimal, getcontext
    getcontext().prec = 80
    rng = np.random.default_rng(7)
    tokens = []
    for value in np.concatenate([rng.uniform(0.5, 100.0, 60), 10.0 ** rng.uniform(-12, 17, 60),
                                 2.0 ** np.arange(-30, 60, 7)]):
        below, above = Decimal(float(value)), Decimal(float(np.nextafter(value, np.inf)))
        middle = (below + above) / 2
        for near in (middle, middle.next_plus(), middle.next_minus()):
            tokens += [f"{near:.{k}e}".encode() for k in (15, 17, 19, 22)]
    tokens += [b"-0", b"+.5", b".5", b"5.", b"00012.3400", b"0" * 30 + b"1.5", b"7" * 20, b"0." + b"7" * 20,
               b"1e5", b"1E-5", b"1e+05", b"1.7976931348623157e308", b"2.2250738585072014e-308",
               b"4.9406564584124654e-324", b"2e-324", b"123456789012345678.9", b"9007199254740993",
               b"18446744073709551615"]
    _assert_reads_as_float(tmp_path, tokens)


@pytest.mark.parametrize("token", [b"0x1p3", b"1_0", b"1e", b"--5", b"1.2.3", b".", b"nan(1)", b"1,5", b"e5"])
def test_tokens_float_refuses_are_refused(tmp_path, token):
    path = _write(tmp_path, "bad.obj", b"v 0 0 0\nv 1 0 0\nv " + token + b" 1 0\nf 1 2 3\n")
    with pytest.raises(MeshFormatError, match=r"line 3: cannot read"):
        read(path)


# --- OBJ: statements ----------------------------------------------------------------------------

TETRA = solids.tetrahedron(((0.1, 0.2, 0.3), (1.3, 0.1, 0.2), (0.4, 1.7, 0.1), (0.2, 0.5, 1.9)))


def _tetra_lines(indent="", corner="%d", extra=""):
    vertices = [f"{indent}v {x!r} {y!r} {z!r}{extra}" for x, y, z in TETRA.vertices.tolist()]
    faces = [f"{indent}f " + " ".join(corner % (i + 1) for i in face) for face in TETRA.faces.tolist()]
    return vertices, faces


@pytest.mark.parametrize("corner", ["%d", "%d/1", "%d//1", "%d/1/1", "%d/-1/", "%d/"])
@pytest.mark.parametrize("indent", ["", "  ", "\t "])
@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
@pytest.mark.parametrize("extra", ["", " 1.0", " 0.5 0.25 1", " 1 0.5 0.25 1"])
def test_obj_statement_forms(tmp_path, corner, indent, newline, extra):
    vertices, faces = _tetra_lines(indent, corner, extra)
    text = newline.join(["# comment", "o part", "vt 0 0", "vn 0 0 1", *vertices, "s off", *faces]) + newline
    mesh = read(_write(tmp_path, "forms.obj", text))
    assert np.array_equal(_triangles(mesh), _triangles(TETRA))


def test_obj_negative_indices_polygons_comments_and_continuations(tmp_path):
    text = ("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
            "v 0 0 1 # a comment after the numbers\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
            "f -8 -5 -6 -7\n"                              # bottom quad, relative
            "f 5 6 7 8 # top\n"
            "f 1 2 \\\n  6 5\n"                            # a statement continued on the next line
            "f 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n")
    result = mass_properties(_write(tmp_path, "cube.obj", text))
    assert result.triangles == 12 and result.properties.volume == 1.0
    assert result.checks["closed"] and result.checks["shells"] == 1


def test_indented_faces_of_a_second_body_count(tmp_path):
    """Issue 15: a two-body file whose second body's lines are indented has volume 2, not 1."""
    lines = []
    for k, offset in enumerate((0.0, 3.0)):
        box = solids.box((1.0, 1.0, 1.0), (offset, 0.0, 0.0))
        indent = "   " if k else ""
        lines += [f"{indent}v {x!r} {y!r} {z!r}" for x, y, z in box.vertices.tolist()]
        lines += [f"{indent}f " + " ".join(str(8 * k + i + 1) for i in face) for face in box.faces.tolist()]
    result = mass_properties(_write(tmp_path, "two.obj", "\n".join(lines)))
    assert result.properties.volume == 2.0 and result.checks["shells"] == 2


def test_obj_repeating_corners_per_face_is_welded(tmp_path):
    """Per-face vertices (as exporters with normals write them) weld by coordinates into a closed mesh."""
    box = solids.box((1.0, 2.0, 3.0), (0.5, -1.0, 2.0))
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in _triangles(box).reshape(-1, 3).tolist()]
    lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(12)]
    result = mass_properties(_write(tmp_path, "soup.obj", "\n".join(lines)))
    assert result.properties.volume == 6.0 and result.checks["closed"]


_CORNER = st.tuples(st.integers(0, 12), st.booleans(), st.sampled_from(["", "/7", "//3", "/2/9", "/"]),
                    st.sampled_from([" ", "  ", "\t", " \t "]))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.tuples(st.integers(0, 239), _CORNER), min_size=3, max_size=9), min_size=1, max_size=30),
       st.sampled_from(["\n", "\r\n"]), st.booleans())
def test_obj_corners_of_any_width_are_the_vertices_they_name(tmp_path_factory, faces, newline, last_newline):
    """Corners as written by any exporter (leading zeros to 12+ digits, negative, with texture and normal
    numbers, any blanks between them) name the vertices the format says: the triangles are the fan of
    each face's corners, taken from the vertex table by hand."""
    points = np.arange(240 * 3, dtype=float).reshape(240, 3) * 0.5 + np.array([1.0, -2.0, 3.0]) * 1e-3
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in points.tolist()]
    expected = []
    for face in faces:
        words = []
        for index, (zeros, negative, tail, blank) in face:
            number = f"-{240 - index}" if negative else f"{index + 1:0{zeros + len(str(index + 1))}d}"
            words.append(number + tail + blank)
        lines.append("f " + "".join(words).rstrip(" \t"))
        corners = [index for index, _ in face]
        expected += [points[[corners[0], corners[k], corners[k + 1]]] for k in range(1, len(corners) - 1)]
    text = newline.join(lines) + (newline if last_newline else "")
    mesh = read(_write(tmp_path_factory.mktemp("obj"), "corners.obj", text))
    assert np.array_equal(_triangles(mesh), np.array(expected))


@pytest.mark.parametrize("text, message", [
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", r"line 4: a face needs at least 3 vertices, this one has 2"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", r"line 4: face corner 4 refers to a vertex that does not exist "
                                              r"\(3 vertices defined before it\)"),
    ("v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n", r"line 2: face corner 2 refers to a vertex that does not exist"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", r"line 4: face corner -4 refers to a vertex that does not exist"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", r"line 4: face corner 0 \(OBJ numbers vertices from 1\)"),
    ("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", r"line 2: cannot read 'v 1 0'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", r"line 4: cannot read 'f 1 2 x'"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/x\n", r"line 4: cannot read"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", r"the OBJ file holds no faces"),
    ("", r"the OBJ file holds no faces"),
])
def test_obj_errors_name_the_line(tmp_path, text, message):
    with pytest.raises(MeshFormatError, match=message) as caught:
        read(_write(tmp_path, "bad.obj", text))
    assert str(caught.value).startswith(str(tmp_path / "bad.obj") + ": ") and " — " in str(caught.value)


def test_a_binary_file_named_obj_is_refused_without_reading_it_whole(tmp_path):
    """The reader's own limit (``massprops.io.read`` refuses sparse files even before it)."""
    from massprops.core import read_obj
    path = tmp_path / "sparse.obj"
    with open(path, "wb") as f:
        f.truncate(300 << 20)                               # 300 MiB of zeros, no line end, no disk used
    with pytest.raises(MeshFormatError, match="longer than .* not a text file"):
        read_obj(path)


# --- STL ------------------------------------------------------------------------------------------

def _ascii_stl(triangles, *, upper=False, bom=False, newline="\n", name="part"):
    lines = [f"solid {name}"]
    for tri in triangles:
        lines += ["  facet normal 0 0 0", "    outer loop"]
        lines += ["      vertex %r %r %r" % tuple(float(x) for x in v) for v in tri]
        lines += ["    endloop", "  endfacet"]
    lines.append(f"endsolid {name}")
    text = newline.join(lines) + newline
    if upper:
        text = text.upper()
    return (b"\xef\xbb\xbf" if bom else b"") + text.encode()


@pytest.mark.parametrize("upper", [False, True])
@pytest.mark.parametrize("bom", [False, True])
@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_ascii_stl_forms(tmp_path, upper, bom, newline):
    triangles = _triangles(TETRA) + [10.0, 20.0, 30.0]
    mesh = read(_write(tmp_path, "part.stl", _ascii_stl(triangles, upper=upper, bom=bom, newline=newline)))
    assert mesh.source_dtype == np.float64
    assert np.array_equal(_triangles(mesh), triangles)


def test_ascii_stl_with_two_solids(tmp_path):
    a, b = solids.box(), solids.box((1.0, 1.0, 1.0), (4.0, 0.0, 0.0))
    path = _write(tmp_path, "two.stl", _ascii_stl(_triangles(a), name="a") + _ascii_stl(_triangles(b), name="b"))
    assert mass_properties(path).properties.volume == 2.0


@pytest.mark.parametrize("text, message", [
    ("solid x\n facet normal 0 0 0\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n vertex 0 1 0\n vertex 1 1 0\n"
     " endloop\n endfacet\nendsolid x\n", r"line 9: a facet with 4 vertices"),
    ("solid x\n facet normal 0 0 0\n outer loop\n vertex 0 0 0\n vertex 1 zero 0\n", r"line 5: a vertex needs three numbers"),
    ("solid x\nendsolid x\n", r"not a valid ASCII STL \(no 'vertex' lines\)"),
    ("solid x\n vertex 0 0 0\n vertex 1 0 0\n", r"2 vertices, not a multiple of 3"),
])
def test_ascii_stl_errors(tmp_path, text, message):
    with pytest.raises(MeshFormatError, match=message):
        read(_write(tmp_path, "bad.stl", text))


def test_binary_stl_holds_the_file_values_and_welds_signed_zeros(tmp_path):
    rng = np.random.default_rng(3)
    triangles = rng.normal(size=(300, 3, 3)).astype(np.float32)
    triangles[::5, 1, 2] = -0.0
    triangles[1::5, 0, 2] = 0.0
    path = tmp_path / "soup.stl"
    write_binary(path, triangles)
    mesh = read(path)
    assert mesh.source_dtype == np.float32
    assert np.array_equal(_triangles(mesh), triangles.astype(np.float64))
    assert mesh.vertices.shape[0] == len({tuple(v) for v in (triangles.reshape(-1, 3) + 0.0).tolist()})


def test_binary_stl_whose_header_says_solid_is_binary(tmp_path):
    box = solids.box((1.0, 2.0, 3.0))
    path = tmp_path / "solid.stl"
    write_binary(path, _triangles(box), header=b"solid exported by a CAD system")
    assert mass_properties(path).properties.volume == 6.0


def test_binary_stl_with_an_extra_byte_says_so(tmp_path):
    """Issue 15: a binary STL whose header starts with "solid", plus one byte, is not called bad ASCII."""
    path = tmp_path / "extra.stl"
    write_binary(path, _triangles(solids.box()), header=b"solid x")
    with open(path, "ab") as f:
        f.write(b"\0")
    with pytest.raises(MeshFormatError, match=r"binary STL header says 12 triangles \(684 bytes\) but the file has "
                                              r"685 bytes"):
        read(path)


def test_a_count_the_file_cannot_hold_is_refused_before_allocating(tmp_path):
    path = _write(tmp_path, "liar.stl", b"x" * 80 + struct.pack("<I", 0xFFFFFFFF) + bytes(50))
    with pytest.raises(MeshFormatError, match=r"header says 4294967295 triangles .* the file has 134 bytes"):
        read(path)


@pytest.mark.parametrize("data, message", [
    (b"", "the file is empty"),
    (b"abc", r"too short for binary STL \(3 bytes"),
    (b"x" * 80 + struct.pack("<I", 0), "holds no triangles"),
])
def test_small_stl_errors(tmp_path, data, message):
    with pytest.raises(MeshFormatError, match=message):
        read(_write(tmp_path, "small.stl", data))


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
@pytest.mark.parametrize("ext", ["stl", "obj"])
def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path, ext):
    from massprops.core import read_obj, read_stl
    path = tmp_path / f"pipe.{ext}"
    os.mkfifo(path)
    outcome = []
    reader = read_stl if ext == "stl" else read_obj
    thread = threading.Thread(target=lambda: outcome.append(pytest.raises(MeshFormatError, reader, path)),
                              daemon=True)
    thread.start()
    thread.join(10)
    assert outcome and "not a regular file" in str(outcome[0].value)


_READ_WHILE_TRUNCATED = """
import sys
from massprops.core import read_stl
from massprops.model.errors import MassPropsError
for _ in range(40):
    try:
        read_stl(sys.argv[1])
    except MassPropsError as error:
        assert "ended early" in str(error) or "header says" in str(error), error
print("survived")
"""


def test_truncating_a_binary_stl_while_it_is_read_is_an_error_not_a_crash(tmp_path):
    """Issue 15: the reader reads with pread, so a file shrinking under it gives an error, never SIGBUS."""
    path = tmp_path / "big.stl"
    sphere = solids.icosphere(6)                                  # 81,920 triangles, 4 MB
    write_binary(path, _triangles(sphere))
    full = path.read_bytes()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    child = subprocess.Popen([sys.executable, "-c", _READ_WHILE_TRUNCATED, str(path)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, env=env)
    while child.poll() is None:
        with open(path, "r+b") as f:
            f.truncate(len(full) // 3)
        with open(path, "r+b") as f:
            f.write(full)
    out, err = child.communicate()
    assert child.returncode == 0, err.decode()[-2000:]
    assert out.strip() == b"survived"


def test_a_line_with_bytes_that_are_not_utf8_is_quoted_in_the_error(tmp_path):
    path = _write(tmp_path, "bytes.obj", b"v \xff.0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshFormatError, match=r"line 1: cannot read 'v \\xff\.0 0 0'"):
        read(path)
