"""The fast paths give exactly what the general code gives.

- vectorised decimal parsing against Python's correctly rounded ``float``;
- the plain-layout OBJ reader against the line-by-line reader, bit for bit;
- the integer-ratio post-processing of ``MassProperties.from_moments``
  against the same formulas in ``fractions.Fraction`` (an exact oracle);
- one-block grouping against the first row of each group.
"""

from fractions import Fraction

import numpy as np
from hypothesis import given, settings, strategies as st

from massprops.validation import solids
from massprops.core.grouping import group_ids
from massprops.core.integrate import Moments, integrate
from massprops.io import obj
from massprops.io.decimals import parse_decimals
from massprops.properties import MassProperties, unit_factor

finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e30, max_value=1e30)


def _same_as_float(tokens):
    parsed = parse_decimals(b" \n".join(tokens))
    expected = np.array([float(t) for t in tokens])
    assert parsed is not None
    assert parsed.tobytes() == expected.tobytes(), [t for t, a, b in zip(tokens, parsed, expected)
                                                    if a.tobytes() != b.tobytes()][:3]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=200),
       st.sampled_from(["%.17f", "%.17g", "%r", "%.16g", "%.9f", "%.3E", "%.0f", "%.20f", "%.25e"]))
def test_decimals_match_float(values, fmt):
    _same_as_float([(fmt % v).encode() for v in values])


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["", "-", "+"]), st.text("0123456789", min_size=1, max_size=20),
                          st.text("0123456789", max_size=22)), min_size=1, max_size=50))
def test_random_digit_strings_match_float(parts):
    _same_as_float([f"{sign}{whole}.{frac}".encode() for sign, whole, frac in parts])


def test_decimals_near_midpoints_and_declines():
    from decimal import Decimal, getcontext
    getcontext().prec = 60
    rng = np.random.default_rng(3)
    tokens = []
    for value in rng.uniform(0.5, 100.0, 300):
        below, above = Decimal(float(value)), Decimal(float(np.nextafter(value, np.inf)))
        middle = (below + above) / 2
        for near in (middle, middle + Decimal(10) ** -30, middle - Decimal(10) ** -30):
            tokens += [format(near, f".{k}f").encode() for k in (14, 15, 16, 17)]
    _same_as_float(tokens)
    for text in (b"nan", b"inf", b"-", b".", b"1.2.3", b"--5", b"5-", b"1,2", b"0x10", b"1\x0b2", b"1e", b"1e-",
                 b"e5", b"1e5.5", b"1e--5", b"1e5e5", b"1e12345"):
        assert parse_decimals(text) is None, text


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(finite, finite, finite), min_size=3, max_size=30),
       st.integers(0, 2 ** 32 - 1), st.sampled_from(["\n", "\r\n"]), st.booleans(),
       st.sampled_from(["%r", "%.17g", "%.6g", "%.3f"]))
def test_plain_obj_layout_matches_line_reader(points, seed, newline, comment, fmt):
    rng = np.random.default_rng(seed)
    faces = rng.integers(0, len(points), size=(int(rng.integers(1, 20)), 3))
    corner = ["%d", "%d/1", "%d/1/2", "%d//2"]
    lines = (["# exported", "o part"] if comment else []) + ["v " + " ".join(fmt % c for c in p) for p in points]
    lines += ["vt 0 0", "vn 0 0 1", "s off"] if seed % 3 == 0 else []
    lines += ["f " + " ".join(corner[(seed >> (2 * k + 2 * i)) % 4 if seed % 5 else 0] % (v + 1)
                             for k, v in enumerate(f)) for i, f in enumerate(faces)]
    text = newline.join(lines).encode() + (newline.encode() if seed % 2 else b"")
    fast = obj._read_plain_layout(text)
    slow = obj._read_lines(text.splitlines(), "x.obj")
    assert fast is not None
    assert fast.vertices.tobytes() == slow.vertices.tobytes()
    assert np.array_equal(fast.faces, slow.faces)


def test_plain_obj_layout_declines_other_layouts():
    base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
    for text in (base + "f 1 2 3 3\n", base + "f 1/ 2/2 3/3\n", base + "f /1 2 3\n", base + "  v 1 1 1\nf 1 2 3\n",
                 base + "f 1 2 3\nv 0 0 1\n", base + "f -1 -2 -3\n", base + "f 0 1 2\n",
                 "v 0 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "v 0 0 0\nv 1v 0 0\nv 0 1 0\nf 1 2 3\n",
                 base + "f 1 2 x\n", base + "f 1 2 3\ng part\nf 1 2 3\n"):
        assert obj._read_plain_layout(text.encode()) is None, text


def _fraction_post_processing(moments, density, mass, unit):
    """Volume, mass, COM and J_G' from the raw sums with Fractions: the formulas of from_moments."""
    length = Fraction(2) ** moments.scale_exp * unit_factor(unit)
    m0 = Fraction(moments.det_sum)
    volume_s = m0 / 6
    volume = volume_s * length ** 3
    rho = Fraction(density if density is not None else 1) if mass is None else Fraction(mass) / volume
    g = [Fraction(x) / (4 * m0) for x in moments.first]
    com = [float((Fraction(r) + x * Fraction(2) ** moments.scale_exp) * unit_factor(unit))
           for r, x in zip(moments.reference, g)]
    c = [[Fraction(moments.second[i, j]) / 120 - volume_s * g[i] * g[j] for j in range(3)] for i in range(3)]
    trace = c[0][0] + c[1][1] + c[2][2]
    inertia = [[float(((trace if i == j else 0) - c[i][j]) * rho * length ** 5) for j in range(3)]
               for i in range(3)]
    area = float(Fraction(moments.area2) / 2 * length ** 2)
    return float(volume), float(rho * volume), float(rho), area, com, inertia


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(-60, 60), st.sampled_from([None, "mm", "in", "ft"]),
       st.sampled_from(["density", "mass", None]))
def test_ratio_post_processing_matches_fractions(seed, scale_exp, unit, material):
    rng = np.random.default_rng(seed)
    mesh = solids.icosphere(1)
    vertices = mesh.vertices * rng.uniform(0.1, 10.0, size=3) + rng.normal(size=3) * 10.0 ** rng.integers(0, 6)
    raw = integrate(vertices, mesh.faces)
    moments = Moments(raw.reference, raw.scale_exp + scale_exp, 2, raw.det_sum, raw.det_error, raw.first,
                      raw.first_error, raw.second, raw.second_error, raw.area2, raw.faces, 0, 0)
    value = float(rng.uniform(0.01, 1e4))
    density, mass = (value, None) if material == "density" else (None, value) if material == "mass" else (None, None)
    props = MassProperties.from_moments(moments, density=density, mass=mass, unit=unit)
    volume, total, rho, area, com, inertia = _fraction_post_processing(moments, density, mass, unit)
    assert (props.volume, props.mass, props.density, props.surface_area) == (volume, total, rho, area)
    assert props.center_of_mass.tolist() == com
    assert props.inertia_com.tolist() == inertia


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(1, 3000), st.integers(1, 50))
def test_one_block_grouping_labels_first_rows(seed, rows, distinct):
    rng = np.random.default_rng(seed)
    keys = rng.integers(0, distinct, size=(rows, 2)).astype(np.uint64)
    labels, first = group_ids(keys)
    _, expected_first, expected_labels = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(expected_first)                    # labels are numbered by first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    assert np.array_equal(first, np.sort(expected_first))
    assert np.array_equal(labels, rank[expected_labels.ravel()])
