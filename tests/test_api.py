"""The Python API takes what trimesh, Open3D and meshio users hold; wrong input says what was expected."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import massprops
from massprops.model.errors import ArgumentTypeError, MassPropsError, OptionError
from massprops.validation import solids
from oracle import exact_properties


def _tilted_bracket():
    """A part with non-zero products of inertia (a sign error shows)."""
    from conftest import random_rotation
    return solids.l_bracket(3.0, 1.0, 0.5).transformed(random_rotation(7), np.array([0.5, -1.25, 2.0]))


@pytest.fixture(scope="module")
def bracket():
    mesh = _tilted_bracket()
    return mesh, exact_properties(mesh.triangles)


def _agrees(result, exact):
    p = result.properties
    assert abs(Fraction(p.volume) - exact["volume"]) <= Fraction(p.error.volume)
    for k in range(3):
        assert abs(Fraction(p.center_of_mass[k]) - exact["center_of_mass"][k]) <= Fraction(p.error.center_of_mass)


def _unwelded_trimesh(mesh):
    """A trimesh as its STL loader makes it: three vertices per face, none shared."""
    import trimesh
    corners = mesh.vertices[mesh.faces].reshape(-1, 3)
    return trimesh.Trimesh(corners, np.arange(len(corners)).reshape(-1, 3), process=False)


def test_a_trimesh_mesh_welded_or_not(bracket):
    import trimesh
    mesh, exact = bracket
    _agrees(massprops.mass_properties(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)), exact)
    _agrees(massprops.mass_properties(_unwelded_trimesh(mesh)), exact)      # welded by exact coordinates


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.uint32, np.int64, np.uint64])
def test_faces_of_any_integer_type(dtype):
    mesh = solids.box((1.0, 2.0, 3.0))
    result = massprops.mass_properties((mesh.vertices, mesh.faces.astype(dtype)))
    assert result.properties.volume == 6.0


def test_plain_lists_and_float32_vertices(bracket):
    mesh, exact = bracket
    _agrees(massprops.mass_properties((mesh.vertices.tolist(), mesh.faces.tolist())), exact)
    result = massprops.mass_properties([mesh.vertices.astype(np.float32), mesh.faces])
    assert result.source_dtype == "float32" and "input_resolution" in result.properties.error.as_dict()


def test_an_open3d_like_object_with_triangles(bracket):
    mesh, exact = bracket

    class Open3DLike:                      # o3d.geometry.TriangleMesh converted with np.asarray
        vertices = mesh.vertices
        triangles = mesh.faces.astype(np.int32)

    _agrees(massprops.mass_properties(Open3DLike()), exact)


def test_a_trimesh_scene_is_computed_as_an_assembly():
    import trimesh
    scene = trimesh.Scene()
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    scene.add_geometry(box, node_name="left", transform=trimesh.transformations.translation_matrix([-2, 0, 0]))
    scene.add_geometry(box, node_name="right", transform=trimesh.transformations.rotation_matrix(
        np.pi / 2, [0, 0, 1], point=[0, 0, 0]) @ trimesh.transformations.translation_matrix([2, 0, 0]))
    result = massprops.mass_properties(scene, density=2.0)
    total = result.properties
    assert total.volume == 12.0 and total.mass == 24.0
    np.testing.assert_allclose(total.center_of_mass, [-1.0, 1.0, 0.0], atol=1e-15)
    assert sorted(result.extra["parts"]) == ["left", "right"]
    right = result.extra["parts"]["right"]
    np.testing.assert_allclose(right.center_of_mass_global, [0.0, 2.0, 0.0], atol=1e-15)
    # the assembly's inertia about its COM: both boxes' own, rotated, plus the parallel-axis terms
    own = box.moment_inertia * 2.0
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1])[:3, :3]
    expected = own + turn @ own @ turn.T
    for r in ([-1.0, -1.0, 0.0], [1.0, 1.0, 0.0]):
        r = np.array(r)
        expected += 12.0 * (r @ r * np.eye(3) - np.outer(r, r))
    np.testing.assert_allclose(total.inertia_com, expected, atol=1e-12)
    with pytest.raises(OptionError, match="mass does not apply to a scene"):
        massprops.mass_properties(scene, mass=3.0)


def test_only_takes_one_name_a_comma_list_or_a_list():
    box = solids.box()
    assert massprops.mass_properties(box, only="volume").properties.center_of_mass is None
    assert massprops.mass_properties(box, only="volume,center_of_mass").properties.inertia_com is None
    assert massprops.mass_properties(box, only=["inertia"]).properties.inertia_com is not None
    with pytest.raises(OptionError, match="unknown quantity 'colour'"):
        massprops.mass_properties(box, only="colour")


@pytest.mark.parametrize("source, error, fragment", [
    (["a.stl", "b.stl"], ArgumentTypeError, "a list of paths"),
    (("a.stl",), ArgumentTypeError, "a list of paths"),
    (42, ArgumentTypeError, "expected a path, a TriangleMesh"),
    ({"vertices": [], "faces": []}, ArgumentTypeError, "got dict"),
    ((np.zeros((4, 2)), [[0, 1, 2]]), OptionError, "vertices must have shape (n, 3), got (4, 2)"),
    ((np.zeros((4, 3)), [[0, 1, 2, 3]]), OptionError, "faces must have shape (m, 3), triangles, got (1, 4)"),
    ((np.zeros((4, 3)), np.array([[0.0, 1.0, 2.0]])), ArgumentTypeError, "faces must be integer vertex indices"),
    ((np.zeros((4, 3)), [[0, 1, 4]]), OptionError, "faces refer to vertex 4"),
    ((np.zeros((4, 3)), [[0, -1, 2]]), OptionError, "faces refer to vertex -1"),
    ((np.zeros((4, 3)), np.zeros((0, 3), int)), OptionError, "there are no faces"),
    (([[0, 0, 0], [1, 0]], [[0, 1, 2]]), ArgumentTypeError, "vertices must be an array of numbers"),
    ((np.array([["a", "b", "c"]]), [[0, 0, 0]]), ArgumentTypeError, "vertices must be real numbers"),
])
def test_wrong_sources_say_what_was_expected(source, error, fragment):
    with pytest.raises(error) as raised:
        massprops.mass_properties(source)
    assert fragment in str(raised.value) and str(raised.value).startswith("source:")
    assert isinstance(raised.value, MassPropsError)
    assert isinstance(raised.value, TypeError if error is ArgumentTypeError else ValueError)


def test_a_pose_must_be_a_pose():
    with pytest.raises(TypeError, match="pose: expected a massprops.Pose, got ndarray"):
        massprops.mass_properties(solids.box(), pose=np.eye(4))


def test_returned_arrays_are_read_only_and_caches_cannot_go_stale():
    pose = massprops.Pose.from_quat([0.9, 0.1, 0.3, -0.2], translation=[1.0, 2.0, 3.0])
    result = massprops.mass_properties(_tilted_bracket(), pose=pose)
    p = result.properties
    arrays = [p.center_of_mass, p.inertia_com, p.center_of_mass_global, p.inertia_com_global,
              p.principal.moments, p.principal.axes, p.pose.rotation, p.pose.translation]
    for array in arrays:
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0.0
    moments = p.principal.moments.copy()
    with pytest.raises(ValueError):
        p.inertia_com[0, 0] += 1.0
    np.testing.assert_array_equal(p.principal.moments, moments)
    rotation = np.eye(3)
    posed = massprops.Pose(rotation)                   # the pose keeps its own copy
    rotation[0, 0] = 5.0
    assert posed.rotation[0, 0] == 1.0


def test_pose_refuses_what_is_not_a_rotation_and_translation():
    with pytest.raises(OptionError, match="translation must have shape"):
        massprops.Pose(translation=[1.0, 2.0])
    with pytest.raises(OptionError, match="finite"):
        massprops.Pose(translation=[np.nan, 0.0, 0.0])
    with pytest.raises(OptionError, match="Euler angles must be finite"):
        massprops.Pose.from_euler("xyz", [np.inf, 0.0, 0.0])


def _json_bounds(path):
    import json
    from click.testing import CliRunner
    from massprops.cli import main
    result = CliRunner().invoke(main, ["props", str(path), "--format", "json"])
    assert result.exit_code == 0, result.output
    obj = json.loads(result.output)
    return (obj[0] if isinstance(obj, list) else obj)["error"]


@pytest.mark.parametrize("name", ["l_bracket_rotated.stl", "hollow_sphere.obj", "cube.stl", "torus.obj",
                                  "cylinder_at_1e6.stl", "examples/overlapping_boxes.stl"])
def test_every_bound_the_api_returns_is_the_one_json_prints(name):
    """API and JSON give the same bound for every quantity, the principal ones included, each one computed."""
    from pathlib import Path
    path = Path(__file__).resolve().parent.parent / "sample_meshes" / name
    error = massprops.mass_properties(path).properties.error
    printed = _json_bounds(path)
    for key in ("volume", "mass", "center_of_mass", "inertia_com", "principal_moments"):
        assert getattr(error, key) == printed[key] and getattr(error, key) > 0, key
    # An axis in a degenerate group is fixed by convention within its subspace (bound 0 there, docs/conventions.md).
    assert list(error.principal_axes_rad) == printed["principal_axes_rad"]


def test_a_quantity_not_computed_has_no_bound():
    """With only the volume, the other bounds are None (not a zero that claims exactness)."""
    error = massprops.mass_properties(solids.l_bracket(3.0, 1.0, 0.5), only="volume").properties.error
    assert error.volume > 0
    assert error.center_of_mass is None and error.inertia_com is None
    assert error.principal_moments is None and error.principal_axes_rad is None
