"""`massprops regress`: deviations from an expected-values CSV fail the run, by file and quantity."""

from __future__ import annotations

import csv
import os
import shutil
from xml.etree import ElementTree

import numpy as np
import pytest
from click.testing import CliRunner

import massprops.cli
from massprops.validation import solids
from massprops.model.frames import Pose
from massprops.io.stl import write_binary
from massprops.validation.reference_set import reference_solids, write_reference_set


def run(*args):
    return CliRunner().invoke(massprops.cli.main, [str(a) for a in args])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """A small reference set: five solids, ten files."""
    directory = tmp_path_factory.mktemp("reference")
    chosen = {"box", "cylinder", "icosphere", "l_bracket_rotated", "cylinder_at_1e6"}
    write_reference_set(directory, [s for s in reference_solids() if s.name in chosen])
    return directory


def read(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return list(reader), reader.fieldnames


def edited_copy(reference, tmp_path, edit):
    """Copy the set, apply ``edit(rows_by_file)`` to expected.csv, return the new CSV's path."""
    copy = tmp_path / "copy"
    shutil.copytree(reference, copy)
    rows, columns = read(copy / "expected.csv")
    edit({r["file"]: r for r in rows})
    with open(copy / "expected.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return copy / "expected.csv"


def test_the_reference_set_passes(reference):
    result = run("regress", reference / "expected.csv")
    assert result.exit_code == 0, result.output
    assert "10 file(s)" in result.output and "all within tolerance" in result.output


def test_a_changed_value_fails_naming_file_and_quantity(reference, tmp_path):
    def edit(rows):
        rows["l_bracket_rotated.obj"]["Iyy"] = repr(float(rows["l_bracket_rotated.obj"]["Iyy"]) * (1 + 1e-6))
    expected = edited_copy(reference, tmp_path, edit)
    junit = tmp_path / "report.xml"
    result = run("regress", expected, "--junit", junit)
    assert result.exit_code == 1
    fails = [line for line in result.output.splitlines() if line.startswith("FAIL")]
    assert len(fails) == 1 and "l_bracket_rotated.obj" in fails[0] and "Iyy" in fails[0]
    suite = ElementTree.parse(junit).getroot().find("testsuite")
    assert suite.get("tests") == "10" and suite.get("failures") == "1" and suite.get("errors") == "0"
    failed = [case for case in suite.iter("testcase") if case.find("failure") is not None]
    assert [case.get("name") for case in failed] == ["l_bracket_rotated.obj"]
    assert "Iyy" in failed[0].find("failure").get("message")


def test_the_same_change_passes_within_a_looser_tolerance(reference, tmp_path):
    def edit(rows):
        rows["box.stl"]["volume"] = repr(6.0 * (1 + 1e-6))
    expected = edited_copy(reference, tmp_path, edit)
    assert run("regress", expected, "--rtol", "1e-5").exit_code == 0
    result = run("regress", expected)
    assert result.exit_code == 1 and "FAIL box.stl: volume" in result.output


def test_axes_are_compared_up_to_sign(reference, tmp_path):
    def edit(rows):
        for c in ("a1x", "a1y", "a1z", "a3x", "a3y", "a3z"):
            rows["l_bracket_rotated.stl"][c] = repr(-float(rows["l_bracket_rotated.stl"][c]))
    assert run("regress", edited_copy(reference, tmp_path, edit)).exit_code == 0


def test_a_turned_axis_fails(reference, tmp_path):
    def edit(rows):
        row = rows["l_bracket_rotated.obj"]
        axes = np.array([[float(row[f"a{k}{c}"]) for c in "xyz"] for k in (1, 2, 3)])
        turned = Pose.from_euler("z", [0.01], degrees=True).rotation @ axes.T
        row.update({f"a{k + 1}{c}": repr(float(turned[i, k])) for k in range(3) for i, c in enumerate("xyz")})
    result = run("regress", edited_copy(reference, tmp_path, edit))
    assert result.exit_code == 1
    assert "FAIL l_bracket_rotated.obj: a" in result.output


def test_equal_moments_compare_only_their_subspace(reference, tmp_path):
    """The cylinder's transverse axes are any pair in the xy plane; only leaving the plane is a deviation."""
    def turn_within(rows):
        row = rows["cylinder.obj"]
        assert row["degenerate"] == "[[1, 2]]"            # J_zz = V/2 < J_xx = J_yy = 7V/12
        c, s = float(np.cos(0.3)), float(np.sin(0.3))
        row.update(a2x=repr(c), a2y=repr(s), a2z="0.0", a3x=repr(-s), a3y=repr(c), a3z="0.0")
    assert run("regress", edited_copy(reference, tmp_path, turn_within)).exit_code == 0

    def tilt_out(rows):
        row = rows["cylinder.obj"]
        row.update(a2x=repr(float(np.cos(0.01))), a2y="0.0", a2z=repr(float(np.sin(0.01))))
    shutil.rmtree(tmp_path / "copy")
    result = run("regress", edited_copy(reference, tmp_path, tilt_out))
    assert result.exit_code == 1 and "cylinder.obj: a2,a3 subspace" in result.output


def test_record_writes_a_baseline_that_passes_and_catches_a_changed_part(tmp_path):
    part = tmp_path / "parts" / "bracket.stl"
    part.parent.mkdir()
    write_binary(part, solids.l_bracket(30.0, 10.0, 5.0).triangles)
    baseline = tmp_path / "baseline.csv"
    result = run("regress", "--record", baseline, part, "--density", "7850", "--unit", "mm")
    assert result.exit_code == 0, result.output
    rows, _ = read(baseline)
    assert [r["file"] for r in rows] == ["parts/bracket.stl"]
    assert rows[0]["unit"] == "mm" and float(rows[0]["density"]) == 7850.0
    # 30·10·5 + 10·20·5 mm³ of steel, exactly as the closed form says.
    assert float(rows[0]["mass"]) == pytest.approx(7850 * 2500e-9, rel=1e-14)
    assert run("regress", baseline).exit_code == 0

    write_binary(part, solids.l_bracket(30.0, 10.0, 5.01).triangles)        # a changed export
    result = run("regress", baseline)
    assert result.exit_code == 1
    assert "FAIL parts/bracket.stl: volume" in result.output and "FAIL parts/bracket.stl: mass" in result.output


def test_record_keeps_the_rows_of_other_files(tmp_path):
    first, second = tmp_path / "a.stl", tmp_path / "b.stl"
    write_binary(first, solids.box((1.0, 2.0, 3.0)).triangles)
    write_binary(second, solids.box((2.0, 2.0, 3.0)).triangles)
    baseline = tmp_path / "expected.csv"
    assert run("regress", "--record", baseline, first, second).exit_code == 0
    write_binary(second, solids.box((4.0, 2.0, 3.0)).triangles)
    assert run("regress", "--record", baseline, second).exit_code == 0
    rows, _ = read(baseline)
    assert {r["file"]: float(r["volume"]) for r in rows} == {"a.stl": 6.0, "b.stl": 24.0}


def test_a_missing_file_is_an_error_and_the_others_are_still_checked(reference, tmp_path):
    expected = edited_copy(reference, tmp_path, lambda rows: None)
    os.remove(expected.parent / "box.obj")
    junit = tmp_path / "report.xml"
    result = run("regress", expected, "--junit", junit)
    assert result.exit_code == 1
    assert "error: " in result.output and "box.obj: no such file" in result.output
    assert "1 file(s) not computed" in result.output and "Traceback" not in result.output
    suite = ElementTree.parse(junit).getroot().find("testsuite")
    assert suite.get("errors") == "1" and suite.get("failures") == "0"


@pytest.mark.parametrize("content, fragment", [
    ("name,volume\nx.stl,1\n", "no 'file' column"),
    ("file,volume\nx.stl,one\n", "column volume is 'one', not a number"),
    ("file,volume\nx.stl,\n", "no expected values"),
])
def test_a_bad_expected_file_is_one_error_line(tmp_path, content, fragment):
    expected = tmp_path / "expected.csv"
    expected.write_text(content)
    result = run("regress", expected)
    assert result.exit_code == 1
    assert fragment in result.output and "Traceback" not in result.output


def test_usage_errors(tmp_path):
    assert run("regress", tmp_path / "e.csv", tmp_path / "x.stl").exit_code == 2
    assert run("regress", "--record", tmp_path / "e.csv").exit_code == 2
    assert run("regress", tmp_path / "e.csv", "--density", "2").exit_code == 2
    result = run("regress", tmp_path / "missing.csv")
    assert result.exit_code == 1 and "no such file" in result.output
