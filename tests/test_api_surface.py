"""The Python result (issue 25): every source shape against the exact oracle, flat names, repr, to_dict."""

from __future__ import annotations

import json
from fractions import Fraction
from types import SimpleNamespace

import numpy as np
import pytest

import massprops
from massprops.model.errors import ArgumentTypeError
from massprops.io.stl import write_binary
from massprops.validation import solids
from oracle import exact_properties, within_bounds


@pytest.fixture(scope="module")
def part():
    from conftest import random_rotation
    tilted = solids.l_bracket(3.0, 1.0, 0.5).transformed(random_rotation(11), np.array([0.25, -1.5, 2.0]))
    # coordinates a binary STL (float32) holds exactly, so every source carries the same numbers
    mesh = massprops.TriangleMesh(tilted.vertices.astype(np.float32).astype(np.float64), tilted.faces)
    return mesh, exact_properties(mesh.triangles)


def _sources(mesh, tmp_path):
    import trimesh
    path = tmp_path / "part.stl"
    write_binary(path, mesh.triangles)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False), node_name="only")
    return {
        "path": ((str(path),), {}),
        "pathlib": ((path,), {}),
        "trimesh": ((trimesh.Trimesh(mesh.vertices, mesh.faces, process=False),), {}),
        "(V, F)": (((mesh.vertices, mesh.faces),), {}),
        "V, F": ((mesh.vertices, mesh.faces), {}),
        "V, F as lists": ((mesh.vertices.tolist(), mesh.faces.tolist()), {}),
        "(m, 3, 3)": ((mesh.triangles,), {}),
        "numpy-stl mesh": ((SimpleNamespace(vectors=mesh.triangles.astype(np.float64)),), {}),
        "TriangleMesh": ((mesh,), {}),
        "Scene": ((scene,), {}),
    }


SHAPES = ["path", "pathlib", "trimesh", "(V, F)", "V, F", "V, F as lists", "(m, 3, 3)", "numpy-stl mesh",
          "TriangleMesh", "Scene"]


@pytest.mark.parametrize("shape", SHAPES)
def test_every_source_shape_is_within_its_bounds_of_the_exact_values(part, tmp_path, shape):
    mesh, exact = part
    args, kwargs = _sources(mesh, tmp_path)[shape]
    result = massprops.mass_properties(*args, **kwargs)
    within_bounds(result.properties, exact)
    # the flat names are the same numbers
    assert result.volume == result.properties.volume and result.mass == result.properties.mass
    assert abs(Fraction(result.mass) - exact["volume"]) <= Fraction(result.error.mass)


def test_faces_with_a_path_is_refused(part, tmp_path):
    mesh, _ = part
    with pytest.raises(ArgumentTypeError, match="faces"):
        massprops.mass_properties(str(tmp_path / "x.stl"), mesh.faces)


def test_a_triangle_array_of_the_wrong_shape_says_so():
    with pytest.raises(ValueError, match=r"\(m, 3, 3\)"):
        massprops.mass_properties(np.zeros((4, 3, 2)))


def test_flat_properties_and_trimesh_aliases(part):
    import trimesh
    mesh, exact = part
    result = massprops.mass_properties(mesh, density=2.5)
    p = result.properties
    assert result.mass == p.mass == pytest.approx(2.5 * float(exact["volume"]), rel=1e-14)
    assert result.center_of_mass is p.center_of_mass and result.center_mass is p.center_of_mass
    assert result.inertia is p.inertia_com and result.moment_inertia is p.inertia_com
    np.testing.assert_array_equal(result.inertia_origin, p.inertia_origin)
    np.testing.assert_array_equal(result.principal_moments, p.principal.moments)
    np.testing.assert_array_equal(result.principal_inertia_components, p.principal.moments)
    np.testing.assert_array_equal(result.principal_axes, p.principal.axes)
    np.testing.assert_array_equal(result.principal_inertia_vectors, p.principal.axes)
    assert result.error is p.error
    with pytest.raises(AttributeError):
        result.mass = 3.0
    with pytest.raises(ValueError):
        result.inertia[0, 0] = 1.0                        # read-only arrays
    # trimesh's names mean what trimesh means by them (its own, less exact, integration)
    theirs = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    theirs.density = 2.5
    np.testing.assert_allclose(result.center_mass, theirs.center_mass, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.moment_inertia, theirs.moment_inertia, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.principal_inertia_components, theirs.principal_inertia_components,
                               rtol=1e-9)


def test_quantities_not_computed_are_none():
    result = massprops.mass_properties(solids.box((1.0, 2.0, 3.0)), only="volume")
    assert result.volume == 6.0
    assert result.center_of_mass is None and result.inertia is None and result.principal_moments is None
    assert result.inertia_origin is None and result.principal_axes is None


def test_repr_is_one_line_with_file_mass_com_moments_and_the_largest_relative_bound(tmp_path):
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0), (0.5, 1.0, 1.5)).triangles)
    result = massprops.mass_properties(path)
    text = repr(result)
    assert "\n" not in text and len(text) < 200
    assert str(path) in text and "mass=6," in text
    assert "center_of_mass=[0.5, 1, 1.5]" in text
    # a 1 × 2 × 3 box: (m/12)(b² + c²) ... ascending
    assert "principal_moments=[2.5, 5, 6.5]" in text
    e = result.error
    expected = max(e.volume / 6, e.mass / 6, e.inertia_com / 6.5, e.principal_moments / 6.5,
                   e.center_of_mass / 1.5)
    assert f"relative_bound={expected:.1e}" in text
    html = result._repr_html_()
    assert html.startswith("<table>") and "principal moments" in html and str(path) in html


def test_to_dict_is_the_json_props_prints(tmp_path, runner):
    from massprops.cli import main
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0)).triangles)
    ours = massprops.mass_properties(str(path)).to_dict()
    out = runner.invoke(main, ["props", str(path), "--format", "json"])
    (printed,) = json.loads(out.stdout)
    assert json.loads(json.dumps(ours)) == {**printed, "elapsed_s": ours["elapsed_s"]}
