"""The per-file steps after integration give exactly what their plain formulations give.

- input resolution from the compiled bounding box and farthest vertex against the
  direct per-vertex formulas (``|x − c|`` over every vertex);
- the report's JSON conversion and CSV writer against the general ones
  (recursive isinstance conversion, ``csv.DictWriter``).
"""

import csv
import io
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops import report
from massprops.validation import solids
from massprops import mass_properties
from massprops.mesh.surface import TriangleMesh
from massprops.model.resolution import _largest_squared_distance, coordinate_resolution, vertex_box

seeds = st.integers(0, 2 ** 32 - 1)


def _random_points(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 3000))
    scale = 10.0 ** rng.integers(-4, 5, size=3)
    points = rng.normal(size=(n, 3)) * scale + rng.normal(size=3) * 10.0 ** rng.integers(-2, 6)
    center = rng.normal(size=3) * scale * rng.choice([0.1, 1.0, 100.0])     # sometimes outside the points
    return points, center


@settings(max_examples=80, deadline=None)
@given(seeds)
def test_bounding_box_gives_the_per_vertex_extremes(seed):
    points, center = _random_points(seed)
    low, high = vertex_box(points)
    assert list(low) == points.min(axis=0).tolist() and list(high) == points.max(axis=0).tolist()
    assert vertex_box(np.asfortranarray(points)) == (low, high)          # any layout of the rows
    # rounding is monotone: the largest rounded |x − c| sits at a face of the box, bit for bit
    farthest = max(max(h - c, c - lo) for lo, h, c in zip(low, high, center.tolist()))
    assert farthest == float(np.abs(points - center).max())
    assert max(abs(max(high)), abs(min(low))) == float(np.abs(points).max())


@settings(max_examples=80, deadline=None)
@given(seeds)
def test_largest_squared_distance_is_the_rounded_per_vertex_maximum(seed):
    points, center = _random_points(seed)
    _check_largest_squared_distance(points, center)


def _check_largest_squared_distance(points, center):
    expected = max((dx * dx + dz * dz) + dy * dy for dx, dy, dz in (points - center).tolist())
    got = _largest_squared_distance(points, center)
    assert got == expected
    exact = max(sum((Fraction(x) - Fraction(c)) ** 2 for x, c in zip(row, center.tolist())) for row in points.tolist())
    assert abs(Fraction(got) - exact) <= exact * Fraction(6, 2 ** 53)        # five roundings at most


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_resolution_uses_the_largest_coordinate(dtype):
    mesh = solids.box((1.0, 2.0, 0.5), (-300.0, 2.0, 7.0))
    mesh = TriangleMesh(mesh.vertices, mesh.faces, np.dtype(dtype))
    resolution = mass_properties(mesh).properties.error.input_resolution
    assert resolution["coordinates"] == coordinate_resolution(mesh.vertices, dtype)
    assert resolution["coordinates"] == 0.5 * float(np.spacing(dtype(300.5)))


def reference_plain(value):
    """numpy values to plain Python, the general way."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, dict):
        return {k: reference_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [reference_plain(v) for v in value]
    return value


class Checks(dict):
    pass


def test_plain_converts_like_the_general_way():
    value = {"a": np.float64(1.5), "b": [np.int64(3), (np.float32(0.1), "x", None)], "c": np.arange(3.0),
             "d": Checks(ok=np.bool_(True), n=np.int32(2)), "e": [[1.0, -0.0], [np.nan, True]], "f": (1, 2)}
    got, expected = report.plain(value), reference_plain(value)
    assert repr(got) == repr(expected)
    assert [type(x) for x in got["b"][1]] == [float, str, type(None)] and type(got["a"]) is float


@settings(max_examples=60, deadline=None)
@given(st.lists(st.dictionaries(st.sampled_from(report.CSV_COLUMNS),
                                st.one_of(st.text(), st.sampled_from(["a,b", 'say "x"', "line\nbreak", "cr\r"]),
                                          st.floats(allow_nan=False).map(repr), st.integers(), st.booleans(),
                                          st.none())),
                max_size=4))
def test_csv_writer_round_trips_and_matches_dictwriter(rows):
    text = report.to_csv(rows)
    back = list(csv.DictReader(io.StringIO(text, newline="")))
    assert back == [{k: "" if row.get(k) is None else str(row.get(k, "")) for k in report.CSV_COLUMNS}
                    for row in rows]
    if not any("\r" in str(v) for row in rows for v in row.values()):
        # csv.writer leaves a lone carriage return unquoted (the row then splits); elsewhere the same text
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=report.CSV_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        assert text == buffer.getvalue()


def test_csv_writer_refuses_unknown_columns():
    with pytest.raises(ValueError, match="not in the CSV columns"):
        report.to_csv([{"file": "a.stl", "colour": "red"}])


def test_error_dict_with_principal_keeps_key_order():
    props = mass_properties(solids.l_bracket(3.0, 1.0, 0.7)).properties
    keys = list(props.error.as_dict())
    assert keys == ["volume", "mass", "center_of_mass", "inertia_com", "principal_moments", "principal_axes_rad",
                    "input_resolution"]
    assert props.error.as_dict()["principal_moments"] == props.principal.moments_error > 0
    assert props.error.principal_axes_rad == tuple(props.principal.axes_error)
    assert "principal_moments" not in props.error.as_dict(principal=False)
