"""Principal moments and axes: order, signs, handedness, and the degenerate-axis rule."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import random_rotation
from massprops.validation import solids
from massprops import mass_properties
from massprops.mesh.surface import TriangleMesh
from massprops.model.principal import principal


def check_conventions(result, tensor):
    axes = result.axes
    assert np.all(np.diff(result.moments) >= 0)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.cross(axes[0], axes[1]), axes[2], atol=1e-12)
    for axis in axes[:2]:
        k = int(np.argmax(np.abs(axis)))
        assert axis[k] > 0
    np.testing.assert_allclose(axes.T @ np.diag(result.moments) @ axes, tensor, atol=1e-12 * np.abs(tensor).max())


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.1, 10.0), min_size=3, max_size=3), st.integers(0, 10 ** 6))
def test_random_tensors_follow_conventions(moments, seed):
    rotation = random_rotation(seed)
    tensor = rotation @ np.diag(moments) @ rotation.T
    check_conventions(principal(tensor), tensor)


def shuffled(mesh, seed, noise=0.0):
    rng = np.random.default_rng(seed)
    faces = np.roll(mesh.faces[rng.permutation(len(mesh.faces))], rng.integers(3), axis=1)
    vertices = mesh.vertices * (1 + noise * rng.uniform(-1, 1, mesh.vertices.shape))
    return TriangleMesh(vertices, faces)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cube_gives_identity(seed):
    result = mass_properties(shuffled(solids.box((2.0, 2.0, 2.0), (1.0, 2.0, 3.0)), seed)).properties.principal
    assert result.degenerate == ((0, 1, 2),)
    np.testing.assert_array_equal(result.axes, np.eye(3))


@pytest.mark.parametrize("seed,noise", [(0, 0.0), (1, 1e-13), (2, 1e-13)])
def test_tall_z_cylinder_has_z_as_odd_axis(seed, noise):
    result = mass_properties(shuffled(solids.regular_prism(64, 1.0, 5.0), seed, noise)).properties.principal
    assert result.degenerate == ((1, 2),)
    np.testing.assert_allclose(result.axes, [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-12)


def test_flat_z_cylinder_axial_moment_largest():
    result = mass_properties(solids.regular_prism(64, 3.0, 0.5)).properties.principal
    assert result.degenerate == ((0, 1),)
    np.testing.assert_allclose(result.axes, np.eye(3), atol=1e-12)


def test_x_cylinder_projects_local_axes_in_order():
    x_axis = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])   # maps z to x
    mesh = solids.regular_prism(64, 1.0, 5.0)
    result = mass_properties(TriangleMesh(mesh.vertices @ x_axis.T, mesh.faces)).properties.principal
    assert result.degenerate == ((1, 2),)
    np.testing.assert_allclose(result.axes, [[1, 0, 0], [0, 1, 0], [0, 0, 1]], atol=1e-12)


def test_distinct_moments_are_not_grouped():
    result = principal(np.diag([1.0, 1.0 + 1e-6, 2.0]))
    assert result.degenerate == ()
    result = principal(np.diag([1.0, 1.0 + 1e-12, 2.0]))
    assert result.degenerate == ((0, 1),)


def test_error_bound_widens_degeneracy():
    assert principal(np.diag([1.0, 1.0 + 1e-7, 2.0]), error=1e-6).degenerate == ((0, 1),)


def _rational_rotation(p, q, r):
    """The Cayley transform (I − S)⁻¹(I + S) of the skew matrix of (p, q, r): an exactly rational rotation."""
    p, q, r = (Fraction(x) for x in (p, q, r))
    d = 1 + p * p + q * q + r * r
    return [[(1 + p * p - q * q - r * r) / d, 2 * (p * q - r) / d, 2 * (p * r + q) / d],
            [2 * (p * q + r) / d, (1 - p * p + q * q - r * r) / d, 2 * (q * r - p) / d],
            [2 * (p * r - q) / d, 2 * (q * r + p) / d, (1 - p * p - q * q + r * r) / d]]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.integers(-50, 50), min_size=3, max_size=3), st.lists(st.integers(1, 10 ** 6), min_size=3,
       max_size=3), st.sampled_from(["distinct", "pair", "all"]), st.integers(-30, 30))
def test_moments_and_axes_are_within_their_bounds_of_the_exact_decomposition(params, numerators, kind, exponent):
    rotation = _rational_rotation(*(Fraction(x, 7) for x in params))
    moments = [Fraction(n, 1000) * Fraction(2) ** exponent for n in numerators]
    if kind == "pair":
        moments[1] = moments[0]
    elif kind == "all":
        moments = [moments[0]] * 3
    exact = [[sum(rotation[i][k] * moments[k] * rotation[j][k] for k in range(3)) for j in range(3)]
             for i in range(3)]
    tensor = np.array([[float(x) for x in row] for row in exact])
    # The rounded tensor's own eigenvalues are within ‖rounding‖₂ ≤ 3 · half an ulp of its largest element.
    rounding = 3 * max(abs(Fraction(float(x)) - x) for row in exact for x in row)
    result = principal(tensor)
    order = sorted(range(3), key=lambda k: moments[k])
    for got, k in zip(result.moments.tolist(), order):
        assert abs(Fraction(got) - moments[k]) <= Fraction(result.moments_error) + rounding
    axes = np.array([[float(rotation[i][k]) for i in range(3)] for k in order])      # exact axes as rows
    if kind == "distinct" and not result.degenerate:
        for k in range(3):
            cosine = abs(float(result.axes[k] @ axes[k]))
            assert np.arccos(min(1.0, cosine)) <= result.axes_error[k] + 1e-6
    for group in result.degenerate:                # the group's axes span the exact eigenspace
        exact_span = axes[list(group)]
        projected = result.axes[list(group)] @ exact_span.T @ exact_span
        np.testing.assert_allclose(projected, result.axes[list(group)], atol=1e-9)
    check_conventions(result, tensor)


def _davis_kahan(moments, norm_error, groups):
    """The axis bounds written out: each axis's gap to the moments outside its group, asin(E / (gap - E))."""
    import math
    bounds = []
    for k in range(3):
        inside = next((g for g in groups if k in g), (k,))
        gaps = [abs(moments[k] - moments[j]) for j in range(3) if j not in inside]
        if not gaps:
            bounds.append(0.0)
            continue
        gap = min(gaps) - norm_error
        ratio = norm_error / gap if gap > 0 else math.inf
        bounds.append(float(np.arcsin(ratio)) + 4 * 2.0 ** -53 if ratio < 1 else math.pi / 2)
    return tuple(bounds)


@settings(max_examples=200, deadline=None)
@given(moments=st.lists(st.floats(0.0, 10.0), min_size=3, max_size=3),
       norm_error=st.floats(0.0, 1.0), tolerance=st.floats(0.0, 5.0))
def test_axis_bounds_are_the_davis_kahan_bounds_over_each_groups_gap(moments, norm_error, tolerance):
    from massprops.model.principal import axis_angle_bounds, degenerate_groups
    moments = sorted(moments)
    groups = degenerate_groups(moments, tolerance)
    found = axis_angle_bounds(np.array(moments), norm_error, groups)
    assert [b.hex() for b in found] == [b.hex() for b in _davis_kahan(moments, norm_error, groups)]
    for bound, k in zip(found, range(3)):
        assert 0.0 <= bound <= np.pi / 2
        if all(k in g for g in groups) and len(groups) == 1 and len(groups[0]) == 3:
            assert bound == 0.0                 # all three equal: the axes are fixed by convention


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1))
def test_principal_axes_keep_the_sign_convention(seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(3, 3))
    found = principal(a @ a.T + np.eye(3))
    for axis in found.axes[:2]:                        # the third is their cross product (right-handed)
        k = int(np.argmax(np.abs(axis)))              # the first of equal magnitudes
        assert axis[k] > 0
    assert np.allclose(found.axes[2], np.cross(found.axes[0], found.axes[1]), rtol=0, atol=1e-12)
