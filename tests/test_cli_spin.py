"""``massprops spin`` through click's CliRunner: outputs, files, and refusals."""

import re

import numpy as np
import pytest

import massprops.cli
from massprops.model.frames import Pose

# A 1 × 2 × 3 box, density 1: mass 6, J' = diag(6.5, 5, 2.5) exactly.
BOX_INERTIA = np.diag([6.5, 5.0, 2.5])


def spin(runner, *args):
    return runner.invoke(massprops.cli.main, ["spin", *map(str, args)])


def read_csv(path):
    lines = open(path, encoding="utf-8").read().splitlines()
    return lines[0], np.array([[float(x) for x in line.split(",")] for line in lines[1:]])


def test_torque_free_summary_and_time_series(runner, box, tmp_path):
    out = tmp_path / "traj.csv"
    result = spin(runner, box, "--omega", 0.2, 1.0, 0.1, "--duration", 20, "--samples", 51, "--out", out)
    assert result.exit_code == 0, result.output
    assert "principal moments 2.5 5 6.5" in result.output
    assert "method split6" in result.output
    error = float(re.search(r"ω' error (\S+)", result.output).group(1))
    drift = float(re.search(r"max \|H − H0\| / \|H0\| = (\S+)", result.output).group(1))
    assert error < 1e-8 and drift < 1e-12
    header, table = read_csv(out)
    assert header == "t,wx,wy,wz,qw,qx,qy,qz,Hx,Hy,Hz,K"
    assert table.shape == (51, 12)
    assert table[0, :8].tolist() == [0.0, 0.2, 1.0, 0.1, 1.0, 0.0, 0.0, 0.0]
    assert table[-1, 0] == pytest.approx(20.0, rel=1e-15)
    np.testing.assert_allclose(table[:, 8:11], np.tile(BOX_INERTIA @ [0.2, 1.0, 0.1], (51, 1)), rtol=1e-12)
    np.testing.assert_allclose(table[:, 11], 0.5 * (6.5 * 0.04 + 5.0 + 2.5 * 0.01), rtol=1e-12)


def test_pose_gives_the_initial_attitude_and_world_momentum(runner, box, tmp_path):
    out = tmp_path / "traj.csv"
    result = spin(runner, box, "--omega", 1.0, 0.0, 0.5, "--duration", 1, "--samples", 3, "--out", out,
                  "--rotate", "euler:zyx:30,-20,10", "--method", "DOP853", "--rtol", "1e-11")
    assert result.exit_code == 0, result.output
    _, table = read_csv(out)
    pose = Pose.from_euler("zyx", [30, -20, 10])
    np.testing.assert_allclose(table[0, 4:8], pose.as_quat(), atol=1e-15)
    np.testing.assert_allclose(table[:, 8:11], np.tile(pose.rotation @ BOX_INERTIA @ [1.0, 0.0, 0.5], (3, 1)),
                               rtol=1e-9)


def test_world_torque_momentum_grows_linearly(runner, box, tmp_path):
    out = tmp_path / "traj.csv"
    result = spin(runner, box, "--omega", 0.0, 0.0, 1.0, "--duration", 2, "--torque", 0.5, 0.0, 0.0,
                  "--torque-frame", "world", "--steps", 400, "--samples", 5, "--out", out)
    assert result.exit_code == 0, result.output
    assert "H0 + T t" in result.output and "closed form" not in result.output
    _, table = read_csv(out)
    expected = BOX_INERTIA @ [0.0, 0.0, 1.0] + np.outer(table[:, 0], [0.5, 0.0, 0.0])
    np.testing.assert_allclose(table[:, 8:11], expected, atol=1e-12)


def test_unit_and_density_give_si_moments(runner, box):
    result = spin(runner, box, "--omega", 0, 0, 1, "--duration", 1, "--unit", "mm", "--density", 1000)
    assert result.exit_code == 0, result.output
    # 1 × 2 × 3 mm of density 1000 kg/m³: J = 1000 · 1e-15 · diag(6.5, 5, 2.5) kg·m².
    assert "principal moments 2.5e-12 5e-12 6.5e-12 (SI)" in result.output


def test_plot_writes_png(runner, box, tmp_path):
    png = tmp_path / "traj.png"
    result = spin(runner, box, "--omega", 0.2, 1, 0.1, "--duration", 5, "--plot", png)
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_methods_table_and_plot(runner, box, tmp_path):
    png = tmp_path / "wp.png"
    result = spin(runner, box, "--omega", 0.2, 1, 0.1, "--duration", 2, "--compare-methods", "--plot", png)
    assert result.exit_code == 0, result.output
    rows = [line for line in result.output.splitlines() if line.startswith("| ") and "---" not in line][1:]
    methods = [row.split("|")[1].strip() for row in rows]
    assert sorted(set(methods)) == sorted(["split2", "split4", "split6", "RK45", "DOP853", "Radau", "BDF",
                                           "LSODA"])
    errors = {(row.split("|")[1].strip(), row.split("|")[2].strip()): float(row.split("|")[5]) for row in rows}
    assert errors[("split6", "1e-10")] < 1e-9 and errors[("DOP853", "1e-10")] < 1e-8
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, fragment", [
    (["--rtol", "1e-6", "--steps", "10"], "not both"),
    (["--method", "DOP853", "--steps", "10"], "--steps applies"),
    (["--compare-methods", "--torque", "1", "0", "0"], "drop --torque"),
    (["--duration", "-1"], "--duration"),
    (["--method", "Euler"], "Euler"),
    (["--steps", "0"], "--steps"),
    (["--samples", "1"], "--samples"),
])
def test_usage_errors_exit_2(runner, box, args, fragment):
    result = spin(runner, box, "--omega", 0, 0, 1, *(args if "--duration" in args else ["--duration", 1, *args]))
    assert result.exit_code == 2
    assert fragment in result.output


def test_missing_omega_is_a_usage_error(runner, box):
    result = spin(runner, box, "--duration", 1)
    assert result.exit_code == 2 and "--omega" in result.output


@pytest.mark.parametrize("args, fragment", [
    (["--duration", "1", "--rotate", "matrix:1,0,0,0,1,0,0,0,2"], "not orthonormal"),
    (["--duration", "1", "--density", "-3"], "must be positive"),
    (["--duration", "nan"], "not a finite number"),
])
def test_bad_option_values_are_usage_errors(runner, box, args, fragment):
    result = spin(runner, box, "--omega", 0, 0, 1, *args)
    assert result.exit_code == 2
    assert result.output.splitlines()[-1].startswith("Error: Invalid value") and fragment in result.output
    assert "Traceback" not in result.output


def test_bad_file_exits_1(runner, tmp_path):
    missing = tmp_path / "missing.stl"
    result = spin(runner, missing, "--omega", 0, 0, 1, "--duration", 1)
    assert result.exit_code == 1
    assert f"error: {missing}" in result.output


def test_unwritable_output_is_reported(runner, box, tmp_path):
    result = spin(runner, box, "--omega", 0, 0, 1, "--duration", 1, "--out", tmp_path / "no" / "such" / "t.csv")
    assert result.exit_code == 1
    assert "cannot write the file" in result.output
