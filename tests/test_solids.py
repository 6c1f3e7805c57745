"""`massprops solids`: the reference solids, their exact and smooth values, and the sample set."""

from __future__ import annotations

import csv
import filecmp
import os

import numpy as np
import pytest
from click.testing import CliRunner

import massprops.cli
from massprops.validation import analytic, solids
from massprops import mass_properties
from massprops.validation.exact import exact_properties
from massprops.model.frames import Pose
from massprops.validation.reference_set import reference_solids
from oracle import rational_moments

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_meshes")


def run(*args):
    return CliRunner().invoke(massprops.cli.main, [str(a) for a in args])


def fraction_oracle(triangles):
    """Exact volume, center of mass and inertia about it, one triangle at a time (slow; small meshes)."""
    return rational_moments([(1, np.asarray(triangles, dtype=np.float64).tolist())])


def floats(values):
    volume, center, inertia = values
    return float(volume), np.array([float(x) for x in center]), np.array([[float(x) for x in r] for r in inertia])


def relative(ours, theirs, scale=None):
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    return float(np.abs(ours - theirs).max() / (scale or np.abs(theirs).max()))


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    directory = tmp_path_factory.mktemp("solids")
    result = run("solids", directory)
    assert result.exit_code == 0, result.output
    with open(directory / "expected.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return directory, rows, result.output


def test_exact_values_of_a_small_posed_solid_match_a_per_triangle_fraction_sum():
    pose = Pose.from_quat((0.8, 0.2, -0.4, 0.4), translation=(1e3, -2.5, 7.0))
    mesh = solids.posed(solids.l_bracket(), pose)
    for triangles in (mesh.triangles, mesh.triangles.astype(np.float32)):
        exact = exact_properties(triangles)
        volume, center, inertia = fraction_oracle(triangles)
        assert exact["volume"] == volume
        assert list(exact["center_of_mass"]) == center
        assert [list(r) for r in exact["inertia_com"]] == inertia


@pytest.mark.parametrize("solid", [s for s in reference_solids() if s.polyhedral is not None], ids=lambda s: s.name)
def test_closed_forms_of_the_tessellation_match_its_exact_values(solid):
    """k_n = n sin(2π/n)/(2π) and friends against rational arithmetic on the float64 corners."""
    volume, center, inertia = floats(exact_properties(solid.mesh.triangles).values())
    size = float(np.ptp(solid.mesh.vertices, axis=0).max())
    # Posed variants' corners were rounded after the rotation and move: allow that rounding, nothing more.
    tolerance = 1e-13 * (1 + float(np.abs(solid.mesh.vertices).max()) / size) ** 2
    assert abs(volume - solid.polyhedral.volume) <= tolerance * volume
    assert relative(center, solid.polyhedral.center_of_mass, size) <= tolerance
    assert relative(inertia, solid.polyhedral.inertia_com) <= tolerance


def test_section_factors_are_the_inscribed_polygon_area_and_polar_moment():
    for n in (3, 4, 6, 32):
        k, _ = analytic.section_factors(n)
        assert k * np.pi == pytest.approx(n / 2 * np.sin(2 * np.pi / n), rel=1e-15)
    # The square of circumradius 1 has side √2 and polar moment side⁴/6 = 2/3 = polar factor · π/2.
    assert analytic.section_factors(4)[1] * np.pi / 2 == pytest.approx(2 / 3, rel=1e-15)


def test_every_file_within_1e12_of_its_exact_polyhedral_values(written):
    directory, rows, _ = written
    assert len(rows) == 2 * len(reference_solids())
    result = run("regress", directory / "expected.csv", "--rtol", "1e-12")
    assert result.exit_code == 0, result.output
    assert "all within tolerance" in result.output


def test_exact_values_are_of_the_coordinates_as_stored(written):
    directory, rows, _ = written
    by_file = {r["file"]: r for r in rows}
    posed = {s.name: s for s in reference_solids()}["l_bracket_at_1e6"].mesh
    stl, obj = by_file["l_bracket_at_1e6.stl"], by_file["l_bracket_at_1e6.obj"]
    # float32 at 1e6 resolves only 1/16: the STL holds a visibly different solid, and its row says so.
    assert float(obj["volume"]) == pytest.approx(5.0, rel=1e-10)
    assert abs(float(stl["volume"]) - 5.0) > 1e-3
    assert float(stl["volume"]) == float(exact_properties(posed.triangles.astype(np.float32))["volume"])


@pytest.mark.parametrize("name", ["box", "cube", "tetrahedron", "octahedron", "l_bracket"])
def test_solids_with_exact_corners_have_no_tessellation_error(written, name):
    _, rows, _ = written
    for row in rows:
        if row["file"] in (f"{name}.stl", f"{name}.obj"):
            assert float(row["tess_rel_volume"]) == 0.0 and float(row["tess_rel_inertia"]) == 0.0
            assert float(row["volume"]) == float(row["smooth_volume"])


def test_every_solid_is_closed_and_wound_outward():
    for solid in reference_solids(n=8, m=4, subdivisions=1):
        result = mass_properties(solid.mesh)
        assert result.warnings == () and result.checks["closed"], solid.name


def _smooth_errors(build, smooth, sizes):
    errors = []
    for size in sizes:
        p = mass_properties(build(size)).properties
        errors.append((abs(p.volume - smooth.volume) / smooth.volume,
                       relative(p.inertia_com, smooth.inertia_com)))
    return np.array(errors)


@pytest.mark.parametrize("name, build, smooth", [
    ("cylinder", lambda n: solids.regular_prism(n, 1.0, 2.0), analytic.cylinder_values(1.0, 2.0)),
    ("cone", lambda n: solids.cone(n, 1.0, 2.0), analytic.cone_values(1.0, 2.0)),
    ("uv_sphere", lambda n: solids.uv_sphere(n, n // 2), analytic.sphere_values()),
    ("torus", lambda n: solids.torus(n, n // 2, 2.0, 0.5), analytic.torus_values(2.0, 0.5)),
    ("ellipsoid", lambda n: solids.ellipsoid((3.0, 2.0, 1.0), n, n // 2), analytic.ellipsoid_values((3.0, 2.0, 1.0))),
    ("icosphere", lambda s: solids.icosphere(s), analytic.sphere_values()),
])
def test_smooth_values_are_approached_at_second_order(name, build, smooth):
    sizes = (1, 2, 3, 4) if name == "icosphere" else (16, 32, 64, 128)
    errors = _smooth_errors(build, smooth, sizes)
    ratios = errors[:-1] / errors[1:]
    # Chords of length h miss the curve by O(h²): halving h divides the error by about 4.
    assert np.all(ratios[-1] > 3.5) and np.all(ratios[-1] < 4.5), ratios
    assert np.all(ratios > 3.0), ratios


def test_n_gon_volume_deficit_is_exactly_one_minus_k_n():
    for n in (5, 12, 100):
        volume = mass_properties(solids.regular_prism(n, 1.0, 2.0)).properties.volume
        k, _ = analytic.section_factors(n)
        assert volume / analytic.cylinder_values(1.0, 2.0).volume == pytest.approx(k, rel=1e-14)


def test_posed_smooth_values_are_the_rotated_and_moved_ones():
    by_name = {s.name: s for s in reference_solids()}
    base, moved = by_name["l_bracket"], by_name["l_bracket_at_1e3"]
    pose = Pose.from_quat((0.8, 0.2, -0.4, 0.4))
    rotation = pose.rotation
    np.testing.assert_allclose(moved.smooth.inertia_com, rotation @ base.smooth.inertia_com @ rotation.T,
                               rtol=0, atol=1e-13)
    assert np.linalg.norm(moved.smooth.center_of_mass - rotation @ base.smooth.center_of_mass) == pytest.approx(1e3)
    # A rotation with no symmetry: every product of inertia is non-zero.
    assert np.all(np.abs(moved.smooth.inertia_com[np.triu_indices(3, 1)]) > 0.05)


def test_output_is_deterministic_and_matches_sample_meshes(written, tmp_path):
    directory, rows, _ = written
    assert run("solids", tmp_path).exit_code == 0
    names = [r["file"] for r in rows] + ["expected.csv"]
    match, mismatch, errors = filecmp.cmpfiles(directory, tmp_path, names, shallow=False)
    assert mismatch == [] and errors == []
    match, mismatch, errors = filecmp.cmpfiles(directory, SAMPLES, names, shallow=False)
    assert mismatch == [] and errors == [], "regenerate with `massprops solids sample_meshes`"


def test_sample_set_is_small(written):
    directory, rows, _ = written
    assert sum(os.path.getsize(directory / r["file"]) for r in rows) < 3e6


def test_cli_prints_a_table_and_refuses_a_file_as_directory(written, tmp_path):
    _, _, output = written
    assert "torus.obj" in output and "wrote 38 files" in output
    target = tmp_path / "not_a_dir"
    target.write_text("x")
    result = run("solids", target)
    assert result.exit_code != 0
    assert "Traceback" not in result.output
