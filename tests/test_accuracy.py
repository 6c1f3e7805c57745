"""The accuracy report, input resolution, principal-axis angle bounds and physical validity."""

import csv
import io
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import massprops.cli
from conftest import random_rotation
from massprops.validation import accuracy, solids
from massprops import mass_properties
from massprops.io.stl import write_binary
from massprops.mesh.surface import TriangleMesh
from massprops.model.principal import axis_angle_bounds, physical_checks, principal


# -- the extreme-case table --------------------------------------------------

@pytest.fixture(scope="module")
def extreme_rows():
    return accuracy.extreme_rows(quick=True)


def test_extreme_table_massprops_within_1e12_and_bound_covers(extreme_rows):
    names = [row["case"] for row in extreme_rows]
    assert any("1e+08" in n for n in names) and any("float32" in n for n in names)
    assert any("1e-09" in n for n in names) and any("needle" in n for n in names)
    for row in extreme_rows:
        assert row["massprops_exact"]["rel_max"] <= 1e-12, row
        assert row["bound_covers"], row
        assert row["massprops_physical"], row


def test_extreme_table_renders_every_row(extreme_rows):
    table = accuracy.markdown_table(extreme_rows, "extreme")
    lines = table.strip().splitlines()
    assert len(lines) == 2 + len(extreme_rows)
    assert all(line.count("|") == len(accuracy.EXTREME_COLUMNS) + 1 for line in lines)
    records = list(csv.DictReader(io.StringIO(accuracy.csv_text(extreme_rows))))
    assert [r["case"] for r in records] == [r["case"] for r in extreme_rows]
    assert float(records[0]["massprops_exact_rel_max"]) == extreme_rows[0]["massprops_exact"]["rel_max"]


def test_relative_errors_are_exact():
    from fractions import Fraction
    reference = {"volume": Fraction(1, 3), "center_of_mass": [Fraction(0)] * 3,
                 "inertia_com": [[Fraction(1, 10) if i == j else 0 for j in range(3)] for i in range(3)]}
    values = {"volume": 1 / 3, "center_of_mass": np.zeros(3), "inertia_com": np.eye(3) * 0.1}
    errors = accuracy.relative_errors(values, reference, size=1.0)
    assert errors["volume"] == float(abs(Fraction(1 / 3) - Fraction(1, 3)))
    assert errors["rel_inertia_com"] == float(abs(Fraction(0.1) - Fraction(1, 10)) / Fraction(1, 10))
    assert errors["center_of_mass"] == 0.0


def test_tessellation_converges_to_the_smooth_solid():
    rows = accuracy.tessellation_rows(levels=(100, 1000), names=("sphere", "torus", "cone"))
    for coarse, fine in zip(rows[::2], rows[1::2]):
        assert coarse["case"] == fine["case"] and fine["triangles"] > coarse["triangles"]
        # Against the polyhedron massprops is exact to rounding; against the
        # smooth solid both tools share the tessellation error, which shrinks.
        assert fine["massprops_exact"]["rel_max"] <= 1e-12 and fine["bound_covers"]
        assert fine["massprops_smooth"]["rel_max"] < coarse["massprops_smooth"]["rel_max"] / 4
        assert abs(fine["massprops_smooth"]["rel_max"] - fine["trimesh_smooth"]["rel_max"]) < 1e-6


# -- input resolution ----------------------------------------------------------

def _far_box(tmp_path, size=(1.0, 1.0, 1.0), center=1e5):
    path = tmp_path / "far.stl"
    write_binary(str(path), solids.box(size, (center, center, -center)).triangles)
    return path


def test_float32_far_from_origin_reports_its_quantisation_step(tmp_path):
    result = mass_properties(_far_box(tmp_path))
    resolution = result.properties.error.input_resolution
    step = float(np.spacing(np.float32(1e5)))            # 2**-7 between 65536 and 131072
    assert step == 2.0 ** -7
    assert resolution["coordinates"] == step / 2
    area = result.properties.surface_area
    assert area == 6.0
    assert resolution["volume"] == pytest.approx(math.sqrt(3) * step / 2 * area, rel=1e-12)
    assert any("float32" in w and f"{step:.2g}" in w for w in result.warnings)
    # A given total mass does not move; the derived density does, and the inertia with it.
    heavy = mass_properties(_far_box(tmp_path), mass=7.0).properties.error.input_resolution
    assert heavy["mass"] == 0.0 and heavy["inertia_com"] > 7.0 * resolution["inertia_com"]
    # The same coordinates held as float64 resolve a billion times finer, and nothing is said.
    mesh = solids.box((1.0, 1.0, 1.0), (1e5, 1e5, -1e5))
    fine = mass_properties(mesh)
    assert fine.properties.error.input_resolution["coordinates"] == float(np.spacing(1e5)) / 2
    assert not fine.warnings


def test_input_resolution_covers_perturbations_within_the_step(tmp_path):
    result = mass_properties(_far_box(tmp_path))
    props, resolution = result.properties, result.properties.error.input_resolution
    delta = resolution["coordinates"]
    mesh = solids.box((1.0, 1.0, 1.0), (1e5, 1e5, -1e5))
    # Every face moved outward by δ: the largest first-order volume change, 6δ.
    grown = mass_properties(solids.box((1 + 2 * delta,) * 3, (1e5, 1e5, -1e5))).properties
    assert 6 * delta <= grown.volume - props.volume <= resolution["volume"]
    rng = np.random.default_rng(7)
    for _ in range(5):
        moved = TriangleMesh(mesh.vertices + rng.uniform(-delta, delta, mesh.vertices.shape), mesh.faces)
        other = mass_properties(moved).properties
        assert abs(other.volume - props.volume) <= resolution["volume"]
        assert np.abs(other.center_of_mass - props.center_of_mass).max() <= resolution["center_of_mass"]
        assert np.abs(other.inertia_com - props.inertia_com).max() <= resolution["inertia_com"]


def test_input_resolution_widens_the_degeneracy_tolerance(tmp_path):
    size = (1.0, 1.0, 1.0 + 2.0 ** -6)                   # corners representable in float32 at 1e5
    coarse = mass_properties(_far_box(tmp_path, size)).properties
    fine = mass_properties(solids.box(size, (1e5, 1e5, -1e5))).properties
    assert np.array_equal(coarse.inertia_com, fine.inertia_com)
    assert fine.principal.degenerate == ((1, 2),)               # x and y; z is the odd axis
    assert coarse.principal.degenerate == ((0, 1, 2),)
    assert coarse.principal.tolerance >= coarse.error.input_resolution["principal_moments"]


# -- principal-axis angle bounds (Davis–Kahan) ---------------------------------

def _angle_to_span(vector, basis):
    """Angle between a unit vector and the span of orthonormal rows ``basis`` (asin: exact when small)."""
    outside = vector - basis.T @ (basis @ vector)
    return math.asin(min(1.0, float(np.linalg.norm(outside))))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10 ** 6), log_gap=st.floats(-6, 0), log_error=st.floats(-12, -4))
def test_axis_angle_bound_covers_a_known_perturbation(seed, log_gap, log_error):
    rng = np.random.default_rng(seed)
    moments = np.sort([1.0, 1.0 + 10 ** log_gap, 1.7 + rng.uniform(0, 0.3)])
    rotation = random_rotation(seed)
    exact = rotation @ np.diag(moments) @ rotation.T
    error = 10 ** log_error
    noise = rng.uniform(-error, error, (3, 3))
    perturbed = exact + 0.5 * (noise + noise.T)          # |E_ij| ≤ error
    found = principal(perturbed, error=error)
    assert len(found.axes_error) == 3
    groups = {k: g for g in found.degenerate for k in g}
    for k in range(3):
        group = groups.get(k, (k,))
        measured = _angle_to_span(rotation[:, k], found.axes[list(group)])
        assert measured <= found.axes_error[k] + 1e-12, (k, measured, found.axes_error, found.degenerate)


def test_axis_angle_bound_is_davis_kahan_over_the_gap():
    bounds = axis_angle_bounds([1.0, 2.0, 4.0], 1e-6)
    assert bounds[0] == pytest.approx(math.asin(1e-6 / (1.0 - 1e-6)), rel=1e-9)
    assert bounds[2] == pytest.approx(math.asin(1e-6 / (2.0 - 1e-6)), rel=1e-9)
    assert axis_angle_bounds([1.0, 1.0 + 1e-7, 3.0], 1e-6)[0] == pytest.approx(math.pi / 2)
    assert axis_angle_bounds([1.0, 1.0, 1.0], 1e-6, [(0, 1, 2)]) == (0.0, 0.0, 0.0)


def test_axes_with_a_large_angle_bound_are_reported_degenerate():
    rotation = random_rotation(11)
    tensor = rotation @ np.diag([1.0, 1.0 + 1e-6, 2.0]) @ rotation.T
    sharp = principal(tensor, error=1e-10)
    assert sharp.degenerate == () and max(sharp.axes_error) < 1e-3
    # Ten times the error: the first two axes could turn by more than 1e-3 rad.
    blurred = principal(tensor, error=1e-9)
    assert blurred.degenerate == ((0, 1),)
    assert 1e-6 < blurred.tolerance


def test_json_reports_axis_angles(tmp_path, runner):
    import json
    path = tmp_path / "bracket.stl"
    write_binary(str(path), solids.l_bracket().triangles)
    out = runner.invoke(massprops.cli.main, ["props", "--format", "json", str(path)])
    assert out.exit_code == 0, out.output
    obj = json.loads(out.output)[0]
    assert len(obj["error"]["principal_axes_rad"]) == 3
    assert all(0 <= a < 1e-6 for a in obj["error"]["principal_axes_rad"])
    assert set(obj["error"]["input_resolution"]) >= {"volume", "center_of_mass", "inertia_com", "principal_moments"}
    assert obj["checks"]["positive_definite"] and obj["checks"]["triangle_inequality"]


# -- physical validity ---------------------------------------------------------

def test_physical_checks():
    assert physical_checks([1.0, 2.0, 3.0], 0.0)["triangle_inequality"]
    assert not physical_checks([1.0, 1.0, 3.0], 1e-3)["triangle_inequality"]
    assert physical_checks([1.0, 1.0, 2.0 + 1e-9], 1e-9)["triangle_inequality"]      # a lamina, within bounds
    assert not physical_checks([-1e-3, 1.0, 1.0], 1e-6)["positive_definite"]
    plate = mass_properties(solids.box((1.0, 1.0, 1e-6), (0.0, 0.0, 100.0)))
    assert plate.checks["triangle_inequality"] and plate.checks["positive_definite"]
    i1, i2, i3 = plate.properties.principal.moments
    assert i1 + i2 >= i3                                   # the float values too, as an engine checks them
    assert not accuracy._physical(np.diag([1.0, 1.0, 2.1]))


# -- the command -----------------------------------------------------------------

@pytest.fixture
def small_report(monkeypatch):
    monkeypatch.setattr(accuracy, "QUICK_LEVELS", (100, 400))
    monkeypatch.setattr(accuracy, "SMOOTH_SOLIDS", ("sphere", "cone"))
    cases = accuracy.extreme_cases(quick=True)
    monkeypatch.setattr(accuracy, "extreme_cases", lambda quick=False: [cases[0], cases[4], cases[12]])


def test_accuracy_command_writes_tables_csv_and_plot(tmp_path, runner, small_report):
    out = runner.invoke(massprops.cli.main, ["accuracy", "--quick", "--out", str(tmp_path)])
    assert out.exit_code == 0, out.output
    report = (tmp_path / "accuracy.md").read_text()
    assert "| solid | triangles |" in report and "| case | triangles |" in report
    assert "offset 1e+08" in report and "float32" in report
    rows = list(csv.DictReader(open(tmp_path / "tessellation.csv")))
    assert [r["case"] for r in rows] == ["sphere", "sphere", "cone", "cone"]
    assert (tmp_path / "accuracy.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_accuracy_command_without_matplotlib(tmp_path, runner, small_report, monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    out = runner.invoke(massprops.cli.main, ["accuracy", "--quick", "--out", str(tmp_path)])
    assert out.exit_code == 1
    assert "pip install 'massprops[plot]'" in out.output and "Traceback" not in out.output
    assert (tmp_path / "accuracy.md").exists() and not (tmp_path / "accuracy.png").exists()
    out = runner.invoke(massprops.cli.main, ["accuracy", "--quick", "--no-plot", "--out", str(tmp_path)])
    assert out.exit_code == 0, out.output
