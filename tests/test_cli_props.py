"""`massprops props` through click's CliRunner: outputs, options, and every bad input."""

import json

import numpy as np
import pytest

from badfiles import make_bad_files
from conftest import random_rotation
from massprops.validation import solids
from massprops.cli import main
from massprops.io.stl import write_binary
from massprops.report import CSV_COLUMNS

SPEC_KEYS = {"file", "triangles", "volume", "mass", "density", "surface_area", "center_of_mass", "inertia_com",
             "principal_moments", "principal_axes", "degenerate", "center_of_mass_global", "inertia_com_global",
             "inertia_origin", "error", "checks", "warnings", "elapsed_s"}
ERROR_KEYS = {"volume", "mass", "center_of_mass", "inertia_com", "principal_moments"}
CHECK_KEYS = {"closed", "orientation", "shells", "boundary_edges"}


@pytest.fixture
def bracket(tmp_path):
    mesh = solids.l_bracket(3.0, 1.0, 0.7)
    rotation = random_rotation(41)
    path = tmp_path / "bracket.stl"
    write_binary(path, mesh.vertices[mesh.faces] @ rotation.T + [10.0, 20.0, 30.0])
    return path


def props_json(runner, *args):
    result = runner.invoke(main, ["props", *map(str, args), "--format", "json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_json_has_every_spec_key(runner, bracket):
    [obj] = props_json(runner, bracket)
    assert SPEC_KEYS <= obj.keys()
    assert ERROR_KEYS <= obj["error"].keys()
    assert CHECK_KEYS <= obj["checks"].keys()
    assert obj["checks"]["closed"] is True and obj["checks"]["shells"] == 1
    assert obj["triangles"] == 20 and obj["warnings"] == []
    assert np.shape(obj["inertia_com"]) == (3, 3) and np.shape(obj["principal_axes"]) == (3, 3)
    assert obj["mass"] == obj["volume"] and obj["density"] == 1


def test_text_output_shows_bounds(runner, bracket):
    result = runner.invoke(main, ["props", str(bracket)])
    assert result.exit_code == 0
    assert "volume" in result.stdout and "±" in result.stdout and "principal moments" in result.stdout


def test_pose_options(runner, bracket):
    [plain] = props_json(runner, bracket)
    [posed] = props_json(runner, bracket, "--rotate", "euler:zyx:30,-20,45", "--translate", 1, 2, 3)
    from massprops.model.frames import Pose
    rotation = Pose.from_euler("zyx", [30, -20, 45]).rotation
    com, inertia = np.array(plain["center_of_mass"]), np.array(plain["inertia_com"])
    np.testing.assert_allclose(posed["center_of_mass_global"], rotation @ com + [1, 2, 3], rtol=1e-14)
    np.testing.assert_allclose(posed["inertia_com_global"], rotation @ inertia @ rotation.T, atol=1e-13)
    r = rotation @ com + [1, 2, 3]
    origin = rotation @ inertia @ rotation.T + plain["mass"] * (r @ r * np.eye(3) - np.outer(r, r))
    np.testing.assert_allclose(posed["inertia_origin"], origin, rtol=1e-12)
    assert posed["center_of_mass"] == plain["center_of_mass"]


def test_about_point(runner, bracket):
    [obj] = props_json(runner, bracket, "--about", "1,2,3")
    r = np.array(obj["center_of_mass"]) - [1, 2, 3]
    expected = np.array(obj["inertia_com"]) + obj["mass"] * (r @ r * np.eye(3) - np.outer(r, r))
    np.testing.assert_allclose(obj["inertia_about"][0]["inertia"], expected, rtol=1e-12)


def test_omega_gives_momentum_and_energy(runner, bracket):
    [obj] = props_json(runner, bracket, "--omega", 0.5, -1.0, 2.0, "--rotate", "quat:0.9,0.1,0.3,-0.2")
    inertia, omega = np.array(obj["inertia_com"]), np.array([0.5, -1.0, 2.0])
    np.testing.assert_allclose(obj["angular_momentum"]["local"], inertia @ omega, rtol=1e-14)
    rotation = np.array(obj["pose"]["rotation"])
    np.testing.assert_allclose(obj["angular_momentum"]["global"], rotation @ inertia @ omega, rtol=1e-13)
    assert obj["kinetic_energy"] == pytest.approx(0.5 * omega @ inertia @ omega, rel=1e-14)


def test_units_density_and_mass(runner, bracket):
    [plain] = props_json(runner, bracket)
    [si] = props_json(runner, bracket, "--unit", "mm", "--density", 7850)
    assert si["volume"] == pytest.approx(plain["volume"] * 1e-9, rel=1e-15)
    assert si["mass"] == pytest.approx(plain["volume"] * 1e-9 * 7850, rel=1e-15)
    np.testing.assert_allclose(si["inertia_com"], np.array(plain["inertia_com"]) * 7850 * 1e-15, rtol=1e-14)
    np.testing.assert_allclose(si["center_of_mass"], np.array(plain["center_of_mass"]) * 1e-3, rtol=1e-15)
    [by_mass] = props_json(runner, bracket, "--mass", 2.0)
    assert by_mass["mass"] == 2.0
    assert by_mass["density"] == pytest.approx(2.0 / plain["volume"], rel=1e-15)


def test_only_volume_forms_no_second_moments(runner, bracket, monkeypatch):
    import massprops.core as integrate
    orders = []
    real = integrate.integrate
    monkeypatch.setattr(integrate, "integrate", lambda *a, **k: orders.append(k.get("order")) or real(*a, **k))
    [obj] = props_json(runner, bracket, "--only", "volume")
    assert orders == [0]
    assert "volume" in obj and "inertia_com" not in obj and "center_of_mass" not in obj


def test_csv_header_is_the_spec(runner, bracket):
    result = runner.invoke(main, ["props", str(bracket), "--format", "csv"])
    header, row = result.stdout.splitlines()
    assert header.split(",") == CSV_COLUMNS
    assert row.split(",")[1] == "ok"


def test_inward_mesh_is_flipped_with_a_warning(runner, tmp_path, bracket):
    mesh = solids.l_bracket(3.0, 1.0, 0.7).flipped()
    path = tmp_path / "inward.stl"
    write_binary(path, mesh.triangles)
    outward = tmp_path / "outward.stl"
    write_binary(outward, solids.l_bracket(3.0, 1.0, 0.7).triangles)
    [obj] = props_json(runner, path)
    [ref] = props_json(runner, outward)
    assert obj["volume"] == pytest.approx(ref["volume"], rel=1e-15) and obj["volume"] > 0
    np.testing.assert_allclose(obj["inertia_com"], ref["inertia_com"], rtol=0,
                               atol=obj["error"]["inertia_com"] + ref["error"]["inertia_com"])
    assert any("inward" in w for w in obj["warnings"])


def test_repair_says_what_it_changed(runner, tmp_path):
    box = solids.box((1.0, 2.0, 3.0))
    faces = box.faces.copy()
    faces[0] = faces[0, ::-1]
    path = tmp_path / "miswound.stl"
    write_binary(path, box.vertices[faces])
    assert runner.invoke(main, ["props", str(path)]).exit_code == 1
    [obj] = props_json(runner, path, "--repair")
    assert obj["volume"] == pytest.approx(6.0, rel=1e-15)
    assert any("re-oriented" in w for w in obj["warnings"])


def test_check_trimesh(runner, bracket):
    [obj] = props_json(runner, bracket, "--check-trimesh")
    assert max(obj["trimesh"]["relative_difference"].values()) < 1e-10


def test_each_bad_input_gives_one_line(runner, tmp_path):
    for path, fragment in make_bad_files(tmp_path).items():
        result = runner.invoke(main, ["props", path])
        assert result.exit_code == 1, (path, result.output)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1, (path, result.stderr)
        assert lines[0].startswith(f"error: {path}: "), lines
        assert fragment.lower() in lines[0].lower(), (fragment, lines[0])
        assert "Traceback" not in result.output and result.stdout.strip() == ""


def test_good_and_bad_together(runner, tmp_path, bracket):
    bad = make_bad_files(tmp_path)
    result = runner.invoke(main, ["props", str(bracket), *bad, "--format", "json"])
    assert result.exit_code == 1
    [obj] = json.loads(result.stdout)
    assert obj["file"] == str(bracket)
    assert len(result.stderr.strip().splitlines()) == len(bad)


def test_bad_rotation_option(runner, bracket):
    result = runner.invoke(main, ["props", str(bracket), "--rotate", "matrix:1,0,0,0,1,0,0,0,2"])
    assert result.exit_code == 2                  # a usage error, before any file is read
    assert "--rotate" in result.stderr and "orthonormal" in result.stderr


def test_unknown_only_quantity_is_a_usage_error(runner, bracket):
    result = runner.invoke(main, ["props", str(bracket), "--only", "colour"])
    assert result.exit_code == 2 and "colour" in result.output


@pytest.mark.parametrize("fmt", ["text", "json", "csv"])
@pytest.mark.parametrize("only", ["volume", "mass", "center_of_mass", "inertia", "principal", "surface_area"])
def test_only_in_every_format(runner, bracket, fmt, only):
    result = runner.invoke(main, ["props", str(bracket), "--only", only, "--format", fmt])
    assert result.exit_code == 0, result.output
    assert result.stderr == ""


def test_obj_polygons_and_relative_indices(runner, tmp_path):
    """Quads fan into triangles; negative indices count back from the last vertex; /vt/vn parts ignored."""
    path = tmp_path / "mixed.obj"
    path.write_text("v 0 0 0\nv 2 0 0\nv 2 3 0\nv 0 3 0\nv 0 0 4\nv 2 0 4\nv 2 3 4\nv 0 3 4\n"
                    "f 1 4 3 2\nf 5/1 6/2 7/3 8/4\nf -8//1 -7//2 -3//3 -4//4\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n")
    [obj] = props_json(runner, path)
    assert obj["volume"] == 24.0 and obj["triangles"] == 12
