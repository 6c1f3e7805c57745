"""What solid a mesh describes (SPEC): the points of positive winding number, each counted once.

Oracles are exact: :func:`exact_properties` of signed triangle sets (the sums
are linear in the triangles, so the union of A and B is A + B − A∩B given as
triangles of A, of B and the reversed triangles of A∩B), or exact rational
moments of polytopes whose corners are not floats.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops import mass_properties
from massprops.model.errors import MeshGeometryError, OpenMeshError
from massprops.io import obj as obj_io
from massprops.io.stl import write_binary
from massprops.mesh.surface import TriangleMesh
from massprops.validation import solids
from oracle import exact_properties, rational_moments, within_bounds


def box(low, high):
    low, high = np.asarray(low, float), np.asarray(high, float)
    return solids.box(tuple(high - low), tuple((high + low) / 2))


def union_oracle(*parts, minus=()):
    triangles = [p.triangles for p in parts] + [m.triangles[:, ::-1] for m in minus]
    return exact_properties(np.concatenate(triangles))


# --- overlapping, repeated and nested shells --------------------------------------------------

A = box((0.0, 0.0, 0.0), (2.0, 3.0, 1.0))
B = box((1.0, 2.0, 0.5), (4.0, 5.0, 2.0))
A_AND_B = box((1.0, 2.0, 0.5), (2.0, 3.0, 1.0))


def test_two_overlapping_boxes_are_their_union():
    result = mass_properties(solids.combine(A, B))
    within_bounds(result.properties, union_oracle(A, B, minus=[A_AND_B]))
    assert result.properties.volume == pytest.approx(6.0 + 13.5 - 0.5, rel=1e-15)
    assert result.checks["overlap"] == pytest.approx(0.5, rel=1e-12)
    assert any("overlap" in w and "union" in w for w in result.warnings)
    # Products of inertia are non-zero: a sign error would show.
    assert np.all(np.abs(result.properties.inertia_com[np.triu_indices(3, 1)]) > 0.1)


def test_boxes_sharing_a_face_add_up():
    right = box((2.0, 0.0, 0.0), (3.0, 3.0, 1.0))
    result = mass_properties(solids.combine(A, right))
    within_bounds(result.properties, union_oracle(A, right))
    assert result.checks["overlap"] == pytest.approx(0.0, abs=1e-12)


def test_union_vertices_off_the_float_grid_are_bounded():
    """A box and a tetrahedron whose face cuts the box's edges at 2/3 (not a float): the error bound
    covers the rounded intersection vertices; the exact union is A + T − (A ∩ T) in rationals."""
    cube = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    # Face on the plane 3x + 3y + 2z = 2 (cuts the x and y axes at 2/3), apex behind the corner.
    corners = np.array([[-2.0, -2.0, 7.0], [4.0, -2.0, -2.0], [-2.0, 4.0, -2.0], [-3.0, -3.0, -3.0]])
    tetra = TriangleMesh(corners, np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]]))
    if exact_properties(tetra.triangles)["volume"] < 0:
        tetra = tetra.flipped()
    third = Fraction(2, 3)
    cut = [(0, 0, 0), (third, 0, 0), (0, third, 0), (0, 0, 1)]       # cube ∩ tetra, a tetrahedron
    expected = _rational_union([cube.triangles.tolist(), tetra.triangles.tolist()],
                               [_tetra_triangles([[Fraction(c) for c in p] for p in cut])])
    result = mass_properties(solids.combine(cube, tetra))
    within_bounds(result.properties, expected)
    assert result.properties.error.volume < 1e-12


def _tetra_triangles(p):
    """Outward triangles of the tetrahedron with corners p[0..3] (any order)."""
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    triangles = [[p[i] for i in f] for f in faces]
    if rational_moments([(1, triangles)])[0] < 0:
        triangles = [t[::-1] for t in triangles]
    return triangles


def _rational_union(parts, minus):
    volume, center, inertia = rational_moments([(1, t) for t in parts] + [(-1, t) for t in minus])
    return {"volume": volume, "center_of_mass": center, "inertia_com": inertia}


def test_a_body_written_twice_counts_once(tmp_path):
    path = tmp_path / "twice.stl"
    write_binary(path, np.concatenate([A.triangles, A.triangles]))
    result = mass_properties(path)
    within_bounds(result.properties, exact_properties(A.triangles.astype(np.float32).astype(float)))
    assert result.checks["duplicate_shells"] == 1
    assert result.checks["overlap"] == pytest.approx(6.0)
    assert any("more than once" in w for w in result.warnings)


def test_nested_shells_of_one_orientation_count_once():
    inner = box((0.5, 0.5, 0.25), (1.5, 2.0, 0.75))
    result = mass_properties(solids.combine(inner, A))
    within_bounds(result.properties, exact_properties(A.triangles))
    assert result.checks["overlap"] == pytest.approx(0.75)
    assert result.checks["dropped_shells"] == 1


def test_a_cavity_stays_a_cavity_and_a_body_in_it_is_solid():
    cavity = box((0.5, 0.5, 0.25), (1.5, 2.5, 0.75)).flipped()
    core = box((0.75, 1.0, 0.4), (1.25, 2.0, 0.6))
    result = mass_properties(solids.combine(A, cavity, core))
    within_bounds(result.properties, union_oracle(A, core, cavity))
    assert result.checks["overlap"] == 0.0


def test_a_separate_body_inside_out_is_not_solid_until_repair_turns_it_outward():
    # Its winding number is -1: not part of {w > 0}, said in a warning; repair turns it outward.
    far = box((10.0, 0.0, 0.0), (11.0, 1.0, 1.0))
    mesh = solids.combine(A, far.flipped())
    alone = mass_properties(mesh)
    within_bounds(alone.properties, exact_properties(A.triangles))
    assert any("inside out" in w and "not part of the solid" in w for w in alone.warnings)
    result = mass_properties(mesh, repair=True)
    within_bounds(result.properties, union_oracle(A, far))
    assert any("inside-out shells outward" in w for w in result.warnings)


def test_every_shell_inward_is_flipped_with_a_warning():
    result = mass_properties(solids.combine(A, B).flipped())
    within_bounds(result.properties, union_oracle(A, B, minus=[A_AND_B]))
    assert result.checks["orientation"] == "inward, flipped"


# --- zero volume, unused vertices -------------------------------------------------------------

def test_a_two_sided_sheet_cancels_and_a_lone_one_has_zero_volume():
    sheet = np.array([[[5.0, 0, 0], [6.0, 0, 0], [5.0, 1, 0]]])
    result = mass_properties(TriangleMesh.from_triangles(np.concatenate([A.triangles, sheet, sheet[:, ::-1]])))
    within_bounds(result.properties, exact_properties(A.triangles))
    assert any("cancel" in w for w in result.warnings)
    with pytest.raises(MeshGeometryError, match="zero volume"):
        mass_properties(TriangleMesh.from_triangles(np.concatenate([sheet, sheet[:, ::-1]])))


def test_a_flat_closed_shell_is_dropped_whatever_its_rounded_sign():
    # Four coplanar points as a closed tetrahedron: volume exactly 0; its sign must not decide anything.
    flat = TriangleMesh(np.array([[7.0, 0, 0], [8.0, 0, 0], [7.0, 1, 0], [7.3, 0.3, 0]]),
                        np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))
    result = mass_properties(solids.combine(A, flat))
    within_bounds(result.properties, exact_properties(A.triangles))
    assert any("zero volume" in w for w in result.warnings)
    # folded onto itself, it is resolved exactly: nothing is added to the bound
    assert result.properties.error.volume < 1e-12


@pytest.mark.parametrize("stray", [[1e8, 0.0, 0.0], [1e10, -3e7, 1.0], [np.nan, 0.0, 0.0], [np.inf, 1.0, 2.0]])
def test_unused_vertices_take_no_part(stray, tmp_path):
    alone = mass_properties(A).properties
    mesh = TriangleMesh(np.vstack([A.vertices, [stray]]), A.faces)
    result = mass_properties(mesh)
    assert result.properties.volume == alone.volume
    np.testing.assert_array_equal(result.properties.inertia_com, alone.inertia_com)
    assert result.properties.error.volume == alone.error.volume
    path = tmp_path / "stray.obj"
    obj_io.write(path, np.vstack([A.vertices, [stray]]), A.faces)
    from_file = mass_properties(path)
    np.testing.assert_array_equal(from_file.properties.inertia_com, alone.inertia_com)
    assert any("NaN or infinite" in w for w in from_file.warnings) == (not np.isfinite(stray).all())


# --- welding: every format, and CAD noise -------------------------------------------------------

def _soup(mesh):
    """The mesh with every face's corners as their own vertices (per-face normals, UV seams)."""
    return mesh.triangles.reshape(-1, 3), np.arange(3 * mesh.faces.shape[0]).reshape(-1, 3)


@pytest.mark.parametrize("ext", ["obj", "ply", "off", "glb", "3mf"])
def test_a_mesh_repeating_its_corners_per_face_is_closed(ext, tmp_path):
    import trimesh
    vertices, faces = _soup(A)
    path = tmp_path / f"soup.{ext}"
    if ext == "obj":
        obj_io.write(path, vertices, faces)
    else:
        trimesh.Trimesh(vertices, faces, process=False).export(path)
    result = mass_properties(path, unit=None if ext != "3mf" else "mm")
    expected = exact_properties(A.triangles)
    if ext == "3mf":
        expected = {"volume": expected["volume"] * Fraction(1, 1000) ** 3,
                    "center_of_mass": [c / 1000 for c in expected["center_of_mass"]],
                    "inertia_com": [[x * Fraction(1, 1000) ** 5 for x in row] for row in expected["inertia_com"]]}
    within_bounds(result.properties, expected)
    assert result.checks["closed"] and result.checks["shells"] == 1


def test_props_and_scene_agree_on_a_glb_soup(tmp_path, runner):
    import json

    import trimesh
    from massprops.cli import main
    vertices, faces = _soup(A)
    path = tmp_path / "soup.glb"
    trimesh.Trimesh(vertices, faces, process=False).export(path)
    props = json.loads(runner.invoke(main, ["props", "--format", "json", str(path)]).output)[0]
    scene = runner.invoke(main, ["scene", "--format", "json", str(path)])
    assert scene.exit_code == 0, scene.output
    assert json.loads(scene.output)["total"]["volume"] == pytest.approx(props["volume"], rel=1e-15)


def _noisy_cube(offset):
    """A unit cube whose corner (0, 0, 0) is written as (offset, 0, 0) in the faces of its side x = 0."""
    cube = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    corner, twin = int(np.flatnonzero((cube.vertices == 0).all(axis=1))[0]), cube.vertices.shape[0]
    faces = cube.faces.copy()
    side = np.all(cube.vertices[faces][:, :, 0] == 0.0, axis=1)
    faces[side] = np.where(faces[side] == corner, twin, faces[side])
    return cube, TriangleMesh(np.vstack([cube.vertices, [[offset, 0.0, 0.0]]]), faces)


def test_a_gap_of_cad_noise_at_a_zero_coordinate_is_welded_within_the_bound():
    cube, noisy = _noisy_cube(1e-18)
    result = mass_properties(noisy)
    within_bounds(result.properties, exact_properties(cube.triangles))
    assert result.checks["welded_vertices"] == 1
    assert any("CAD noise" in w for w in result.warnings)


def test_a_real_gap_is_refused_with_its_size():
    _, gapped = _noisy_cube(1e-9)
    with pytest.raises(OpenMeshError, match=r"boundary edges along gaps at most 1e-09 wide") as caught:
        mass_properties(gapped)
    assert "weld vertices closer than 1e-09" in str(caught.value)


# --- self-intersection ------------------------------------------------------------------------------

# --- repair ---------------------------------------------------------------------------------------

def test_after_repair_no_message_advises_repair():
    # Two open sheets far apart with a duplicated face: repair closes nothing it should not.
    sheet = np.array([[[0.0, 0, 0], [1.0, 0, 0], [0.0, 1, 0]], [[0.0, 0, 1], [1.0, 0, 1], [0.0, 1, 2]]])
    mesh = TriangleMesh.from_triangles(np.concatenate([sheet, sheet[:1]]))
    with pytest.raises(MeshGeometryError) as caught:
        mass_properties(mesh, repair=True)
    for line in (caught.value.render("cli"), caught.value.render("python")):
        assert "pass --repair" not in line and "pass repair=True" not in line and "(--repair" not in line, line


def test_repair_closes_a_hole_and_counts_each_point_once():
    open_box = TriangleMesh(A.vertices, A.faces[1:])
    result = mass_properties(solids.combine(open_box, B), repair=True)
    within_bounds(result.properties, union_oracle(A, B, minus=[A_AND_B]))
    assert any("closed holes" in w for w in result.warnings)


# --- the property: a solid split into overlapping pieces ----------------------------------------

dyadic = st.integers(1, 64).map(lambda k: k / 16.0)


@settings(max_examples=25, deadline=None)
@given(st.tuples(dyadic, dyadic, dyadic), st.integers(0, 2), st.floats(0.1, 0.9), st.floats(0.05, 0.5),
       st.booleans())
def test_a_solid_split_into_overlapping_pieces_is_the_solid(size, axis, cut, overlap, third):
    whole = box((0.0, 0.0, 0.0), size)
    low_high = np.array(size, float)
    at = np.ldexp(np.round(np.ldexp(cut * low_high[axis], 10)), -10)
    width = np.ldexp(np.round(np.ldexp(overlap * low_high[axis], 10)), -10)
    first_high, second_low = low_high.copy(), np.zeros(3)
    first_high[axis] = min(low_high[axis], at + width)
    second_low[axis] = max(0.0, at - width)
    pieces = [box((0.0, 0.0, 0.0), first_high), box(second_low, low_high)]
    if third:                                                    # a piece inside both
        middle = (first_high + second_low) / 2
        pieces.append(box(np.maximum(middle - low_high / 8, 0.0), np.minimum(middle + low_high / 8, low_high)))
    result = mass_properties(solids.combine(*pieces))
    within_bounds(result.properties, exact_properties(whole.triangles))
