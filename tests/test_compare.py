"""`massprops compare`: trimesh raw and fair on the same triangles, and why they differ."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import massprops.cli
from massprops.validation import solids
from massprops.model.frames import Pose
from massprops.io import obj

QUANTITIES = ("volume", "center_of_mass", "inertia_com", "principal_moments")


def run(*args):
    return CliRunner().invoke(massprops.cli.main, [str(a) for a in args])


def write_part(path, offset):
    """The L-bracket, rotated (so every product of inertia is non-zero) and moved ``offset`` away."""
    pose = Pose.from_quat((0.8, 0.2, -0.4, 0.4), translation=(0.6 * offset, -0.8 * offset, 0.0))
    mesh = solids.posed(solids.l_bracket(), pose)
    obj.write(path, mesh.vertices, mesh.faces)
    return path


def test_far_part_raw_difference_large_fair_tiny_and_explained(tmp_path):
    part = write_part(tmp_path / "far.obj", 1e6)
    result = run("compare", part, "--format", "json")
    assert result.exit_code == 0, result.output
    (found,) = json.loads(result.output)
    # The inertia about the COM: ~(offset/size)³ · 2⁻⁵³ ≈ 1 relative for trimesh about the origin.
    assert found["relative_difference_raw"]["inertia_com"] > 1e-3
    assert all(found["relative_difference"][q] <= 1e-12 for q in QUANTITIES)
    assert found["within_tolerance"] and found["digits_lost_raw"] > 10
    assert "integrates about the origin" in found["explanation"]

    text = run("compare", part)
    assert text.exit_code == 0
    assert "why raw differs: trimesh integrates about the origin" in text.output
    assert "digits" in text.output and "ok: fair difference" in text.output


def test_a_part_at_the_origin_has_nothing_to_explain(tmp_path):
    part = write_part(tmp_path / "near.obj", 0.0)
    result = run("compare", part, "--format", "json")
    assert result.exit_code == 0, result.output
    (found,) = json.loads(result.output)
    assert found["explanation"] is None
    assert all(found["relative_difference_raw"][q] <= 1e-12 for q in QUANTITIES)


def test_digits_lost_grow_with_the_offset(tmp_path):
    lost = []
    for offset in (1e2, 1e4):
        (found,) = json.loads(run("compare", write_part(tmp_path / f"p{offset:g}.obj", offset), "--format",
                                  "json").output)
        lost.append(found["relative_difference_raw"]["inertia_com"])
    # Three powers of the offset: 100× farther costs about 10⁶ in accuracy (within rounding luck).
    assert lost[1] > 1e3 * lost[0]


def test_fair_difference_beyond_tolerance_fails(tmp_path):
    part = tmp_path / "torus.obj"
    mesh = solids.torus(24, 12)
    obj.write(part, mesh.vertices, mesh.faces)
    (found,) = json.loads(run("compare", part, "--format", "json").output)
    fair = max(found["relative_difference"].values())
    assert 0 < fair <= 1e-12
    result = run("compare", part, "--rtol", f"{fair / 2!r}")
    assert result.exit_code == 1 and "FAIL: fair difference" in result.output


def test_bad_file_is_one_error_line_and_good_ones_still_checked(tmp_path):
    good = write_part(tmp_path / "good.obj", 10.0)
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    result = run("compare", bad, good)
    assert result.exit_code == 1
    assert f"error: {bad}" in result.output and "good.obj" in result.output
    assert "Traceback" not in result.output


def test_props_check_trimesh_still_reports_fair_differences(tmp_path):
    part = write_part(tmp_path / "far.obj", 1e6)
    result = run("props", part, "--check-trimesh", "--format", "json")
    assert result.exit_code == 0, result.output
    (found,) = json.loads(result.output)
    assert found["trimesh"]["relative_difference"]["inertia_com"] <= 1e-12
    assert found["trimesh"]["relative_difference_raw"]["inertia_com"] > 1e-3


@pytest.mark.parametrize("options", [["--unit", "mm", "--density", "7850"], ["--mass", "3"]])
def test_props_check_trimesh_compares_at_density_one_whatever_the_material(tmp_path, options):
    part = write_part(tmp_path / "part.obj", 0.0)
    (found,) = json.loads(run("props", part, "--check-trimesh", "--format", "json", *options).output)
    assert max(found["trimesh"]["relative_difference"].values()) <= 1e-12


def test_check_is_the_hidden_deprecated_name_of_compare(tmp_path):
    part = write_part(tmp_path / "p.obj", 0.0)
    old, new = run("check", part, "--format", "json"), run("compare", part, "--format", "json")
    assert old.exit_code == new.exit_code == 0
    drop = ("elapsed_s",)
    strip = [[{k: v for k, v in o.items() if k not in drop} for o in json.loads(r.stdout)] for r in (old, new)]
    assert strip[0] == strip[1]
    assert "massprops compare" in old.stderr and new.stderr == ""
    listing = run("--help").output
    assert " compare " in listing and " check " not in listing
    assert "Deprecated" in run("check", "--help").output
