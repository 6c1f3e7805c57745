"""The public surface (issue 25): unit mistakes warned of, option conflicts caught before any file is read."""

from __future__ import annotations

import json

import pytest

from massprops.cli import main
from massprops.io.stl import write_binary
from massprops.validation import solids
from untrusted_files import cube_object, write_3mf


def _cube_stl(path, side=1.0):
    write_binary(path, solids.box((side, side, side)).triangles)
    return str(path)


def _cube_3mf(path):
    write_3mf(path, [cube_object(1)], [(1, 0.0)])          # a unit cube, declared in millimetres
    return str(path)


def _warnings(output):
    return [line for line in output.splitlines() if line.startswith("warning:")]


# ---------------------------------------------------------------- units caught

def test_a_kg_per_m3_density_on_a_mesh_without_unit_is_warned_of_once_and_the_mass_kept(tmp_path, runner):
    files = [_cube_stl(tmp_path / "a.stl"), _cube_stl(tmp_path / "b.stl", 2.0)]
    out = runner.invoke(main, ["props", *files, "--density", "7850", "--format", "json"])
    assert out.exit_code == 0, out.output
    warned = [w for w in _warnings(out.stderr) if "mesh units unknown" in w]
    assert len(warned) == 1 and "--unit mm" in warned[0]
    masses = [obj["mass"] for obj in json.loads(out.stdout)]
    assert masses == [7850.0, 7850.0 * 8]                     # never changed


def test_a_g_per_cm3_density_with_a_unit_is_warned_of_and_kept(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl", 10.0)
    out = runner.invoke(main, ["props", path, "--unit", "mm", "--density", "7.85", "--format", "json"])
    assert out.exit_code == 0, out.output
    (warned,) = _warnings(out.stderr)
    assert "lighter than cork" in warned and "--density 7850" in warned
    assert json.loads(out.stdout)[0]["mass"] == pytest.approx(7.85 * 1e-6, rel=1e-14)


def test_a_density_denser_than_any_solid_with_a_unit_is_warned_of(tmp_path, runner):
    out = runner.invoke(main, ["props", _cube_stl(tmp_path / "a.stl"), "--unit", "m", "--density", "78500000"])
    assert out.exit_code == 0, out.output
    (warned,) = _warnings(out.stderr)
    assert "denser than osmium" in warned


def test_a_file_that_declares_its_unit_gets_the_cork_warning_without_unit_option(tmp_path, runner):
    out = runner.invoke(main, ["props", _cube_3mf(tmp_path / "a.3mf"), "--density", "7.85"])
    assert out.exit_code == 0, out.output
    assert any("lighter than cork" in w for w in _warnings(out.stderr))
    assert not any("mesh units unknown" in w for w in _warnings(out.stderr))


@pytest.mark.parametrize("args", [["--density", "2.7"], [], ["--unit", "mm", "--density", "7850"],
                                  ["--mass", "5"]])
def test_plausible_densities_are_not_warned_of(tmp_path, runner, args):
    out = runner.invoke(main, ["props", _cube_stl(tmp_path / "a.stl"), *args])
    assert out.exit_code == 0, out.output
    assert _warnings(out.stderr) == []


def test_a_batch_mixing_declared_and_undeclared_units_is_warned_of(tmp_path, runner):
    _cube_stl(tmp_path / "a.stl")
    _cube_3mf(tmp_path / "b.3mf")
    out = runner.invoke(main, ["batch", str(tmp_path), "-j", "1", "-q"])
    assert out.exit_code == 0, out.output
    (warned,) = _warnings(out.stderr)
    assert "mixes units" in warned and "mm" in warned and "--unit" in warned


def test_a_batch_with_one_unit_is_not_warned_of(tmp_path, runner):
    _cube_stl(tmp_path / "a.stl")
    _cube_3mf(tmp_path / "b.3mf")
    out = runner.invoke(main, ["batch", str(tmp_path), "-j", "1", "-q", "--unit", "mm", "--density", "7850"])
    assert out.exit_code == 0, out.output
    assert _warnings(out.stderr) == []


# ---------------------------------------------------------------- option conflicts

MISSING = "no_such_dir/missing_part.stl"


@pytest.mark.parametrize("args, named", [
    (["props", MISSING, "--mass", "1", "--density", "7850"], ("--density", "--mass")),
    (["props", MISSING, "--shell", "1", "--density-field", "rho"], ("--shell", "--density-field")),
    (["props", MISSING, "--shell", "1", "--density-map", "a=1"], ("--shell", "--density-map")),
    (["props", MISSING, "--density-field", "rho", "--density-map", "a=1"], ("--density-field", "--density-map")),
    (["props", MISSING, "--density", "2", "--density-field", "rho"], ("--density", "--density-field")),
    (["batch", MISSING, "--mass", "1", "--density", "2"], ("--density", "--mass")),
    (["batch", MISSING, "--timeout", "5", "--scheduler", "local"], ("--timeout", "--scheduler")),
    (["view", MISSING, "-o", "x.html", "--mass", "1", "--density", "2"], ("--density", "--mass")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--rtol", "1e-6", "--steps", "10"],
     ("--rtol", "--steps")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--compare-methods", "--out", "x.csv"],
     ("--compare-methods", "--out")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--mass", "1", "--density", "2"],
     ("--density", "--mass")),
    (["robot", "write", "missing_robot.urdf", "--all", "--links", "arm*", "-o", "x.urdf"], ("--links", "--all")),
    (["robot", "write", "missing_robot.urdf", "-o", "x.urdf", "--in-place"], ("--output", "--in-place")),
])
def test_an_option_conflict_is_a_usage_error_before_any_file_is_read(runner, args, named):
    out = runner.invoke(main, args)
    assert out.exit_code == 2, out.output
    assert all(name in out.stderr for name in named) and "not both" in out.stderr
    assert "missing" not in out.stderr.replace("--", "")
