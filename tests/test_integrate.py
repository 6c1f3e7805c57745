"""massprops against the exact rational oracle, on ordinary and extreme meshes."""

import numpy as np
import pytest

from conftest import random_rotation
from massprops.validation import solids
from massprops import mass_properties
from massprops.io.stl import write_binary
from massprops.mesh.surface import TriangleMesh
from oracle import errors_against, exact_properties


def posed(mesh, *, rotation_seed=None, offset=(0.0, 0.0, 0.0), scale=1.0):
    rotation = np.eye(3) if rotation_seed is None else random_rotation(rotation_seed)
    return TriangleMesh(mesh.vertices @ rotation.T * scale + np.asarray(offset), mesh.faces)


def assert_matches_oracle(mesh, size, rtol=1e-13):
    props = mass_properties(mesh).properties
    exact = exact_properties(mesh.triangles)
    err = errors_against(props, exact, size)
    assert err["rel_volume"] <= rtol, err
    assert err["rel_center_of_mass"] <= rtol, err
    assert err["rel_inertia_com"] <= rtol, err
    # The reported bounds cover the true error.
    assert err["volume"] <= props.error.volume
    assert err["center_of_mass"] <= props.error.center_of_mass
    assert err["inertia_com"] <= props.error.inertia_com
    return props, err


ORDINARY = {
    "box": (solids.box((1.0, 2.0, 3.0)), 3.0),
    "l_bracket": (solids.l_bracket(3.0, 1.0, 0.7), 3.0),
    "tetrahedron": (solids.tetrahedron(((0.1, 0.2, 0.3), (1.3, 0.1, 0.2), (0.4, 1.7, 0.1), (0.2, 0.5, 1.9))), 2.0),
    "prism": (solids.regular_prism(7, 1.0, 2.5), 2.5),
    "two_bodies": (solids.combine(solids.box((1.0, 1.0, 1.0)), solids.box((0.5, 2.0, 1.0), (3.0, 0.0, 0.0))), 4.0),
    "cavity": (solids.hollow_sphere(1.0, 0.6, 1), 2.0),
}


@pytest.mark.parametrize("name", sorted(ORDINARY))
@pytest.mark.parametrize("seed", [None, 1, 2])
def test_rotated_translated_against_oracle(name, seed):
    mesh, size = ORDINARY[name]
    assert_matches_oracle(posed(mesh, rotation_seed=seed, offset=(0.3, -1.7, 2.9)), size)


@pytest.mark.parametrize("offset", [1e3, 1e8])
def test_far_from_origin(offset):
    mesh, size = ORDINARY["l_bracket"]
    assert_matches_oracle(posed(mesh, rotation_seed=3, offset=(offset, -0.5 * offset, 0.25 * offset)), size,
                          rtol=1e-12)


@pytest.mark.parametrize("scale", [1e-9, 1e9])
def test_extreme_scales(scale):
    mesh, size = ORDINARY["l_bracket"]
    assert_matches_oracle(posed(mesh, rotation_seed=4, scale=scale, offset=(3 * scale, scale, 0.0)),
                          size * scale, rtol=1e-12)


THIN = {
    "plate": (solids.box((1.0, 1.0, 1e-6)), 1.0),
    "needle": (solids.box((1e-6, 1e-6, 1.0)), 1.0),
}


@pytest.mark.parametrize("name", sorted(THIN))
@pytest.mark.parametrize("seed", [5, 6])
def test_thin_parts_against_oracle(name, seed):
    mesh, size = THIN[name]
    props, _ = assert_matches_oracle(posed(mesh, rotation_seed=seed, offset=(0.5, 0.25, 100.0)), size,
                                     rtol=1e-12)
    i1, i2, i3 = props.principal.moments
    # Physical validity: the triangle inequality holds within the bound.
    assert i1 + i2 >= i3 - 2 * props.principal.moments_error
    assert i1 > 0


def test_hard_faces_are_refined_and_easy_ones_are_not():
    easy = mass_properties(solids.icosphere(3)).checks
    assert easy["refined_faces"] == 0
    hard = mass_properties(posed(THIN["needle"][0], rotation_seed=7)).checks
    assert hard["refined_faces"] > 0


def test_float32_stl_is_integrated_as_stored(tmp_path):
    mesh = posed(ORDINARY["l_bracket"][0], rotation_seed=8, offset=(1e3, 2e3, -3e3))
    path = tmp_path / "part.stl"
    write_binary(path, mesh.triangles)
    stored = mesh.triangles.astype(np.float32).astype(np.float64)
    result = mass_properties(path)
    assert result.source_dtype == "float32"
    err = errors_against(result.properties, exact_properties(stored), 3.0)
    assert err["rel_volume"] <= 1e-13 and err["rel_inertia_com"] <= 1e-13
    assert err["inertia_com"] <= result.properties.error.inertia_com


def test_ascii_stl_and_obj_against_oracle(tmp_path):
    mesh = posed(ORDINARY["tetrahedron"][0], rotation_seed=9, offset=(10.0, 20.0, 30.0))
    ascii_path = tmp_path / "part.stl"
    with open(ascii_path, "w") as f:
        f.write("solid part\n")
        for tri in mesh.triangles:
            f.write(" facet normal 0 0 0\n  outer loop\n")
            for v in tri:
                f.write("   vertex %r %r %r\n" % tuple(float(x) for x in v))
            f.write("  endloop\n endfacet\n")
        f.write("endsolid part\n")
    obj_path = tmp_path / "part.obj"
    with open(obj_path, "w") as f:
        for v in mesh.vertices:
            f.write("v %r %r %r\n" % tuple(float(x) for x in v))
        for face in mesh.faces:
            f.write("f %d %d %d\n" % tuple(int(i) + 1 for i in face))
    exact = exact_properties(mesh.triangles)
    for path in (ascii_path, obj_path):
        err = errors_against(mass_properties(path).properties, exact, 2.0)
        assert max(err["rel_volume"], err["rel_center_of_mass"], err["rel_inertia_com"]) <= 1e-13


def test_bounds_are_not_vacuous():
    """On an ordinary mesh the bound is within ~1e4 of the true error, or at rounding level."""
    mesh = posed(solids.icosphere(3), rotation_seed=10, offset=(2.0, 3.0, 4.0))
    props = mass_properties(mesh).properties
    exact = exact_properties(mesh.triangles)
    err = errors_against(props, exact, 2.0)
    jmax = float(np.abs(props.inertia_com).max())
    assert props.error.inertia_com <= max(1e4 * err["inertia_com"], 1e-13 * jmax)
    assert props.error.volume <= max(1e4 * err["volume"], 1e-13 * props.volume)
