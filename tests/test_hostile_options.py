"""Option values: checked once, by click, before any file is read; JSON always valid; scenes refuse nonsense.

Also the text output's digits (those the error bound leaves significant) and
the one quaternion conversion (half turns about every axis).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import massprops
from massprops.cli import main
from massprops.model.frames import Pose
from massprops.io.stl import write_binary
from massprops.validation import solids


@pytest.fixture
def boxes(tmp_path):
    paths = []
    for k in range(3):
        paths.append(str(tmp_path / f"box{k}.stl"))
        write_binary(paths[-1], solids.box((1.0 + k, 2.0, 3.0)).triangles)
    return paths


@pytest.mark.parametrize("args, option", [
    (["--translate", "nan", "0", "0"], "--translate"),
    (["--translate", "0", "inf", "0"], "--translate"),
    (["--about", "nan,0,0"], "--about"),
    (["--about", "1,2"], "--about"),
    (["--omega", "0", "nan", "0"], "--omega"),
    (["--rotate", "euler:xyz:nan,0,0"], "--rotate"),
    (["--rotate", "euler:xyz:inf,0,0"], "--rotate"),
    (["--rotate", "quat:nan,0,0,1"], "--rotate"),
    (["--rotate", "foo"], "--rotate"),
    (["--rotate", "matrix:1,0,0,0,1,0,0,0,-1"], "--rotate"),
    (["--density", "-1"], "--density"),
    (["--density", "nan"], "--density"),
    (["--mass", "0"], "--mass"),
    (["--shell", "inf"], "--shell"),
    (["--only", "volume,colour"], "--only"),
    (["--density-map", "steel=nan"], "--density-map"),
    (["--max-unpacked", "-5"], "--max-unpacked"),
    (["--digits", "0"], "--digits"),
])
def test_a_bad_option_is_one_usage_error_before_any_file_is_read(runner, boxes, tmp_path, args, option):
    missing = str(tmp_path / "missing.stl")     # never looked at: the options are refused first
    result = runner.invoke(main, ["props", *boxes, missing, *args, "--format", "json"])
    assert result.exit_code == 2, result.output
    assert result.stderr.count("Error: Invalid value") == 1 and option in result.stderr
    assert "missing.stl" not in result.output and "Traceback" not in result.output and result.stdout == ""


def test_batch_and_scene_and_spin_check_their_options_too(runner, boxes, tmp_path):
    for command in (["batch", *boxes, "-o", str(tmp_path / "r.csv")], ["spin", boxes[0], "--duration", "1",
                                                                       "--omega", "0", "0", "1"]):
        result = runner.invoke(main, [*command, "--translate", "0", "0", "nan"])
        assert result.exit_code == 2 and "--translate" in result.stderr
    assert not (tmp_path / "r.csv").exists()
    result = runner.invoke(main, ["batch", *boxes, "--timeout", "nan"])
    assert result.exit_code == 2 and "--timeout" in result.stderr
    (tmp_path / "s.toml").write_text(f'[parts.a]\nmesh = "{boxes[0]}"\n')
    result = runner.invoke(main, ["scene", str(tmp_path / "s.toml"), "--density", "-2"])
    assert result.exit_code == 2 and "--density" in result.stderr


def test_json_is_valid_when_a_result_overflows(runner, boxes):
    result = runner.invoke(main, ["props", boxes[0], "--translate", "1e308", "0", "0", "--omega", "1e200", "0", "0",
                                  "--format", "json"])
    assert result.exit_code == 0
    [obj] = json.loads(result.stdout, parse_constant=lambda name: pytest.fail(f"{name} in JSON"))
    assert obj["inertia_origin"] == [[None] * 3] * 3 and obj["kinetic_energy"] is None
    assert obj["center_of_mass_global"] == [1e308, *obj["center_of_mass"][1:]]
    assert any("inertia_origin" in w and "null" in w for w in obj["warnings"])
    text = runner.invoke(main, ["props", boxes[0], "--translate", "1e308", "0", "0"]).stdout
    assert "n/a" in text and "written as null" in text


@pytest.mark.parametrize("keys, fragment", [
    ("position = [nan, 0, 0]", "position must be 3 finite numbers"),
    ("position = [0, inf, 0]", "position must be 3 finite numbers"),
    ("rotation = { matrix = [[1, 0, 0], [0, 1], [0, 0, 1]] }", "cannot read rotation"),
    ('rotation = { euler = [inf, 0, 0], sequence = "xyz" }', "cannot read rotation"),
    ("rotation = { quaternion = [nan, 0, 0, 1] }", "cannot read rotation"),
    ("density = nan", "density must be a finite number"),
    ("positions = [[0, 0, 0], [1, nan, 0]]", "positions entry 1 is not 3 finite numbers"),
])
def test_scene_values_that_are_not_finite(runner, boxes, tmp_path, keys, fragment):
    (tmp_path / "s.toml").write_text(f'[parts.a]\nmesh = "{boxes[0]}"\n{keys}\n')
    result = runner.invoke(main, ["scene", str(tmp_path / "s.toml")])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1 and fragment in result.stderr


def test_scene_parts_placed_where_the_totals_overflow(runner, boxes, tmp_path):
    (tmp_path / "s.toml").write_text(f'[parts.a]\nmesh = "{boxes[0]}"\nposition = [1e308, 0, 0]\n'
                                     f'[parts.b]\nmesh = "{boxes[0]}"\nposition = [-1e308, 0, 0]\n')
    result = runner.invoke(main, ["scene", str(tmp_path / "s.toml"), "--format", "json"])
    assert result.exit_code == 1 and result.stdout == ""
    assert "totals overflow double precision" in result.stderr and result.stderr.count("\n") == 1


@pytest.mark.parametrize("scale, fragment", [(1e300, "scales volumes beyond double precision"),
                                             (1e100, "beyond double precision"),
                                             (1e-300, "singular or not finite")])
def test_a_glb_node_scaled_beyond_double_precision(runner, tmp_path, scale, fragment):
    import trimesh
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(), transform=np.diag([scale, scale, scale, 1.0]))
    scene.export(tmp_path / "s.glb")
    result = runner.invoke(main, ["scene", str(tmp_path / "s.glb")])
    assert result.exit_code == 1 and fragment in result.stderr and "Traceback" not in result.output
    assert result.stderr.count("\n") == 1


# ---------------------------------------------------------------- quaternions

_AXES = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, -1, 0), (1, 1, 0), (0, 1, -1), (1, 0, -1), (1, 1, 1), (-1, 1, 1),
         (1, -2, 3), (3, 2, -1)]


@pytest.mark.parametrize("axis", _AXES)
def test_half_turns_come_back_about_the_same_axis(axis):
    n = np.array(axis, float) / np.linalg.norm(axis)
    rotation = 2 * np.outer(n, n) - np.eye(3)         # a half turn about n, by Rodrigues' formula
    quat = Pose.from_matrix(rotation).as_quat()
    assert quat[0] == pytest.approx(0.0, abs=1e-15)
    assert abs(float(quat[1:] @ n)) == pytest.approx(1.0, rel=1e-15)   # ±n: the same half turn
    np.testing.assert_allclose(Pose.from_quat(quat).rotation, rotation, atol=2e-15)
    assert Pose.from_matrix(rotation).as_quat(scalar_first=False)[3] == quat[0]


def test_quaternions_round_trip_for_random_rotations():
    for seed in range(50):
        q = np.random.default_rng(seed).normal(size=4)
        q = q / np.linalg.norm(q) * (1 if q[0] >= 0 else -1)
        np.testing.assert_allclose(Pose.from_quat(q).as_quat(), q, atol=1e-15)


# ---------------------------------------------------------------- digits of the text output

def test_text_shows_only_the_digits_the_bound_leaves_significant(runner, tmp_path):
    from massprops.report import significant
    assert significant(1e-19, 1e-14) == "0" and significant(-3e-15, 1e-14) == "0"
    assert significant(1 / 3, 1e-9) == "0.333333333"
    assert significant(1234.5678901234, 1e-9 * 1234.5678901234) == "1234.56789"   # 1234.567890: 10 digits
    assert significant(2.0 / 3.0, 1e-9, digits=4) == "0.6667"
    assert significant(None) == "n/a"
    # a cube centred on the origin: its center of mass is rounding noise below the bound, shown as 0
    cube = solids.box((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)).transformed(Pose.from_quat([0.9, 0.1, 0.3, -0.2]).rotation,
                                                                    np.zeros(3))
    write_binary(tmp_path / "cube.stl", cube.triangles)
    [obj] = json.loads(runner.invoke(main, ["props", str(tmp_path / "cube.stl"), "--format", "json"]).stdout)
    assert 0 < max(map(abs, obj["center_of_mass"])) <= obj["error"]["center_of_mass"]   # JSON: full precision
    text = runner.invoke(main, ["props", str(tmp_path / "cube.stl")]).stdout
    assert "center of mass         [ 0,  0,  0]" in text
    volume = obj["volume"]
    shown = next(line for line in text.splitlines() if line.strip().startswith("volume")).split()[1]
    # the digits before the last are within the bound; the last is rounded at the bound's power of ten
    last_digit = 10.0 ** math.ceil(math.log10(obj["error"]["volume"]))
    assert abs(float(shown) - volume) <= obj["error"]["volume"] + last_digit / 2 and len(shown) < len(repr(volume))
    longer = runner.invoke(main, ["props", str(tmp_path / "cube.stl"), "--digits", "17"]).stdout
    assert f"{obj['center_of_mass'][0]:.17g}" in longer


def test_library_messages_name_keywords_and_the_cli_names_options(runner, tmp_path):
    box = solids.box()
    open_box = massprops.TriangleMesh(box.vertices, box.faces[1:])
    with pytest.raises(massprops.MassPropsError) as raised:
        massprops.mass_properties(open_box)
    assert "repair=True" in str(raised.value) and "shell=THICKNESS" in str(raised.value)
    assert "--" not in str(raised.value)
    write_binary(tmp_path / "open.stl", open_box.triangles)
    result = runner.invoke(main, ["props", str(tmp_path / "open.stl")])
    assert "--repair" in result.stderr and "--shell THICKNESS" in result.stderr and "repair=True" not in result.stderr
