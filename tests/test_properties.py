"""Invariants: rotation and translation, additivity, frame transfers, and the Pose forms."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import random_rotation
from massprops.validation import solids
from massprops import mass_properties
from massprops.model.errors import OptionError
from massprops.model.frames import Pose, parallel_axis
from massprops.mesh.surface import TriangleMesh

BRACKET = solids.l_bracket(3.0, 1.0, 0.7)
BASE = mass_properties(BRACKET).properties

seeds = st.integers(0, 10 ** 6)
offsets = st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3)


@settings(max_examples=25, deadline=None)
@given(seeds, offsets)
def test_invariant_under_rotation_and_translation(seed, offset):
    rotation = random_rotation(seed)
    moved = mass_properties(TriangleMesh(BRACKET.vertices @ rotation.T + offset, BRACKET.faces)).properties
    assert moved.volume == pytest.approx(BASE.volume, rel=1e-13)
    np.testing.assert_allclose(moved.principal.moments, BASE.principal.moments, rtol=1e-12)
    np.testing.assert_allclose(moved.center_of_mass, rotation @ BASE.center_of_mass + offset, atol=1e-12 * 1e3)
    np.testing.assert_allclose(moved.inertia_com, rotation @ BASE.inertia_com @ rotation.T,
                               atol=1e-12 * np.abs(BASE.inertia_com).max())


@settings(max_examples=20, deadline=None)
@given(seeds, st.floats(4.5, 50.0))
def test_disjoint_parts_add(seed, gap):
    # The box reaches 1.15 and the bracket 3.24 from their origins: from a gap of 4.5 the parts are disjoint
    # (closer, they may overlap, and the solid is their union).
    first = solids.box((1.0, 2.0, 0.5))
    second = TriangleMesh(BRACKET.vertices @ random_rotation(seed).T + [gap, 0.0, 0.0], BRACKET.faces)
    a, b = mass_properties(first).properties, mass_properties(second).properties
    both = mass_properties(solids.combine(first, second)).properties
    mass = a.mass + b.mass
    com = (a.mass * a.center_of_mass + b.mass * b.center_of_mass) / mass
    inertia = (a.inertia_com + parallel_axis(a.mass, a.center_of_mass - com)
               + b.inertia_com + parallel_axis(b.mass, b.center_of_mass - com))
    assert both.mass == pytest.approx(mass, rel=1e-13)
    np.testing.assert_allclose(both.center_of_mass, com, atol=1e-12 * gap)
    np.testing.assert_allclose(both.inertia_com, inertia, atol=1e-12 * np.abs(inertia).max())


@settings(max_examples=25, deadline=None)
@given(offsets, seeds)
def test_about_point_and_back(point, seed):
    props = BASE.with_pose(Pose(random_rotation(seed), np.array([1.0, -2.0, 3.0])))
    about = props.about(point)
    back = about - parallel_axis(props.mass, props.center_of_mass_global - np.asarray(point))
    np.testing.assert_allclose(back, props.inertia_com_global, atol=1e-9 * np.abs(about).max())


@settings(max_examples=25, deadline=None)
@given(seeds)
def test_rotated_then_back(seed):
    rotation = random_rotation(seed)
    there_and_back = BASE.rotated(rotation).rotated(rotation.T)
    np.testing.assert_allclose(there_and_back.inertia_com, BASE.inertia_com, atol=1e-14)
    np.testing.assert_allclose(there_and_back.center_of_mass, BASE.center_of_mass, atol=1e-14)


def test_in_frame_matches_direct_integration():
    frame = Pose(random_rotation(31), np.array([4.0, 5.0, -6.0]))
    part = BASE.with_pose(Pose(random_rotation(32), np.array([-1.0, 2.0, 0.5])))
    # The mesh placed globally, then expressed in frame j's coordinates: x_j = A_jᵀ (x − r_j).
    global_vertices = part.pose.apply(BRACKET.vertices)
    in_j = TriangleMesh((global_vertices - frame.translation) @ frame.rotation, BRACKET.faces)
    direct = mass_properties(in_j).properties
    expected = direct.inertia_com + parallel_axis(direct.mass, direct.center_of_mass)
    np.testing.assert_allclose(part.in_frame(frame), expected, atol=1e-12 * np.abs(expected).max())


def test_pose_forms_agree():
    from scipy.spatial.transform import Rotation
    for seq, angles in (("xyz", [10, 20, 30]), ("ZYX", [-40, 15, 75]), ("zxz", [5, 60, -20])):
        reference = Rotation.from_euler(seq, angles, degrees=True)
        pose = Pose.from_euler(seq, angles)
        np.testing.assert_allclose(pose.rotation, reference.as_matrix(), atol=1e-15)
        q = np.roll(reference.as_quat(), 1)              # scipy gives x, y, z, w
        np.testing.assert_allclose(Pose.from_quat(q).rotation, pose.rotation, atol=1e-15)
        np.testing.assert_allclose(Pose.parse("quat:" + ",".join(map(repr, q.tolist()))).rotation, pose.rotation, atol=1e-15)
        text = "matrix:" + ",".join(map(repr, pose.rotation.ravel().tolist()))
        np.testing.assert_allclose(Pose.parse(text).rotation, pose.rotation, atol=0)
        np.testing.assert_allclose(Pose.from_quat(pose.as_quat()).rotation, pose.rotation, atol=1e-15)


@pytest.mark.parametrize("text,fragment", [
    ("matrix:1,0,0,0,1,0,0,0,2", "not orthonormal"),
    ("matrix:1,0,0,0,1,0,0,0,-1", "det −1"),
    ("quat:0,0,0,0", "zero length"),
    ("euler:xyq:1,2,3", "not valid"),
    ("nonsense", "cannot read rotation"),
])
def test_bad_rotations_are_refused(text, fragment):
    with pytest.raises(OptionError, match=fragment):
        Pose.parse(text)
