"""Every surface format reads the coordinates as stored; shells and overflow are handled."""

import numpy as np
import pytest
import trimesh

from conftest import random_rotation
from massprops.validation import solids
from massprops.cli import main
from massprops import mass_properties
from massprops.model.errors import MeshGeometryError
from massprops.mesh.surface import TriangleMesh
from oracle import errors_against, exact_properties


@pytest.mark.parametrize("ext", ["ply", "off", "glb", "obj", "stl"])
def test_formats_through_trimesh_export(tmp_path, ext):
    mesh = solids.l_bracket(3.0, 1.0, 0.7)
    vertices = mesh.vertices @ random_rotation(51).T + [1.0, 2.0, 3.0]
    path = tmp_path / f"part.{ext}"
    trimesh.Trimesh(vertices, mesh.faces, process=False).export(path)
    # Exporters may round (float32, limited digits): the oracle takes the values as stored.
    stored = np.asarray(trimesh.load(path, process=False, force="mesh").vertices, dtype=np.float64)
    if ext == "stl":
        stored = vertices.astype(np.float32).astype(np.float64)
    assert np.abs(stored - vertices).max() < 1e-5
    result = mass_properties(path)
    err = errors_against(result.properties, exact_properties(stored[mesh.faces]), 3.0)
    assert max(err["rel_volume"], err["rel_center_of_mass"], err["rel_inertia_com"]) <= 1e-13, err


def test_separate_body_inside_out_is_not_solid():
    mesh = solids.combine(solids.box((1.0, 1.0, 1.0)), solids.box((1.0, 1.0, 1.0), (5.0, 0.0, 0.0)).flipped())
    result = mass_properties(mesh)
    assert result.properties.volume == 1.0
    assert any("inside out" in w for w in result.warnings)


def test_cavity_is_accepted_and_subtracted():
    outer, inner = solids.box((4.0, 4.0, 4.0)), solids.box((2.0, 2.0, 2.0), (0.5, 0.0, 0.0))
    result = mass_properties(solids.combine(outer, inner.flipped()))
    assert result.checks["shells"] == 2
    assert result.properties.volume == 56.0
    np.testing.assert_allclose(result.properties.center_of_mass, [-0.5 * 8 / 56, 0, 0], atol=1e-15)


def test_closed_non_manifold_mesh_passes():
    # Two cubes sharing one edge: closed (every directed edge matched), not manifold.
    mesh = solids.combine(solids.box((1.0, 1.0, 1.0), (0.5, 0.5, 0.5)), solids.box((1.0, 1.0, 1.0), (-0.5, -0.5, 0.5)))
    welded = TriangleMesh.from_triangles(mesh.triangles)
    assert welded.vertices.shape[0] == 14
    assert mass_properties(welded).properties.volume == 2.0


def test_overflow_is_refused():
    with pytest.raises(MeshGeometryError, match="overflow"):
        mass_properties(TriangleMesh(solids.box().vertices * 1e70, solids.box().faces))


def test_underflow_is_refused():
    with pytest.raises(MeshGeometryError, match="underflow"):
        mass_properties(TriangleMesh(solids.box().vertices * 2.0 ** -500, solids.box().faces))


def test_tiny_scale_is_exact():
    props = mass_properties(TriangleMesh(solids.box((1.0, 2.0, 3.0)).vertices * 1e-30, solids.box().faces)).properties
    assert props.volume == pytest.approx(6e-90, rel=1e-15)


def test_glb_cli(runner, tmp_path):
    path = tmp_path / "part.glb"
    trimesh.Trimesh(solids.box((1.0, 2.0, 3.0)).vertices, solids.box().faces, process=False).export(path)
    result = runner.invoke(main, ["props", str(path), "--only", "volume", "--format", "json"])
    assert result.exit_code == 0 and '"volume": 6.0' in result.stdout
