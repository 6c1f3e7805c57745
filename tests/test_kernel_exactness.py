"""The integration kernel's sums and bounds against exact rational arithmetic.

Every sum :func:`massprops.core.integrate.integrate` returns (Σ det, Σ det·s,
Σ det·(s sᵀ + a aᵀ + b bᵀ + c cᵀ)) is recomputed here with ``Fraction`` on the
same scaled coordinates, and the returned bound must cover the difference —
on meshes built to reach every path: slivers (cyclic rotation), needles and
plates seen edge-on (double-double), faces through the reference point
(exact), far offsets, partial chunks and weights.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import random_rotation
from massprops.validation import solids
from massprops.core.face_terms import _refine_hard_faces
from massprops.core.integrate import integrate
from massprops.core.integrate_dd import DET_ERROR, det_double_double


def _det3(a, b, c):
    """det[a b c] of three exact (Fraction) points."""
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


def _exact_det(a, b, c):
    return _det3(*([Fraction(float(x)) for x in p] for p in (a, b, c)))


def _exact_sums(moments, vertices, faces, weights=None):
    """Σ w·det, Σ w·det·s (3), Σ w·det·Q (3×3) in the moments' scaled coordinates, exactly."""
    scale = Fraction(2) ** -moments.scale_exp
    scaled = [[(Fraction(float(x)) - Fraction(float(r))) * scale for x, r in zip(v, moments.reference)]
              for v in vertices]
    det_sum, first, second = Fraction(0), [Fraction(0)] * 3, [[Fraction(0)] * 3 for _ in range(3)]
    for k, face in enumerate(faces):
        a, b, c = (scaled[int(i)] for i in face)
        det = _det3(a, b, c)
        if weights is not None:
            det *= Fraction(float(weights[k]))
        s = [a[i] + b[i] + c[i] for i in range(3)]
        det_sum += det
        first = [first[i] + det * s[i] for i in range(3)]
        second = [[second[i][j] + det * sum(p[i] * p[j] for p in (s, a, b, c)) for j in range(3)]
                  for i in range(3)]
    return det_sum, first, second


def assert_bounds_cover(vertices, faces, weights=None, chunk=1 << 14):
    moments = integrate(vertices, faces, chunk=chunk, weights=weights)
    det_sum, first, second = _exact_sums(moments, vertices, faces, weights)
    assert abs(Fraction(moments.det_sum) - det_sum) <= Fraction(moments.det_error)
    for i in range(3):
        assert abs(Fraction(float(moments.first[i])) - first[i]) <= Fraction(moments.first_error), i
        for j in range(3):
            assert abs(Fraction(float(moments.second[i, j])) - second[i][j]) <= Fraction(moments.second_error)
    return moments


def _posed(mesh, seed, offset, scale=1.0):
    vertices = mesh.vertices @ random_rotation(seed).T * scale + np.asarray(offset)
    return vertices, mesh.faces


offsets = st.sampled_from([0.0, 0.37, 3.0, 1e3, -2.5e6, 1e9])


@settings(max_examples=25, deadline=None)
@given(st.integers(3, 400), st.floats(1e-4, 1.0), st.integers(0, 2 ** 32 - 1), offsets, st.integers(5, 1 << 14))
def test_prism_slivers_within_bounds(sides, height, seed, offset, chunk):
    """Fan caps and long side rectangles: slivers at every angle, off the origin, any chunk."""
    mesh = solids.regular_prism(sides, 1.0, height)
    vertices, faces = _posed(mesh, seed, (offset, -0.5 * offset, 0.25 * offset + 0.1))
    assert_bounds_cover(vertices, faces, chunk=chunk)


@settings(max_examples=25, deadline=None)
@given(st.sampled_from([(1.0, 1.0, 1e-7), (1e-7, 1e-7, 1.0), (1.0, 1e-9, 1e-3), (3.0, 1.0, 0.5)]),
       st.integers(0, 2 ** 32 - 1), offsets, st.floats(-0.6, 0.6))
def test_plates_and_needles_within_bounds(size, seed, offset, shift):
    """Thin boxes seen edge-on from the reference point (which may sit inside them)."""
    mesh = solids.box(size)
    vertices, faces = _posed(mesh, seed, (offset + shift, shift, -shift))
    assert_bounds_cover(vertices, faces)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-1.0, 1.0)] * 3), min_size=4, max_size=4),
       st.floats(1e-12, 1.0), st.integers(0, 3), offsets)
def test_flattened_tetrahedra_within_bounds(points, flatness, axis, offset):
    """Tetrahedra squeezed towards a plane or a line: every face a sliver or a needle."""
    p = np.array(points)
    p[:, axis % 3] *= flatness
    if axis == 3:
        p[:, 1] *= flatness
    mesh = solids.tetrahedron(p + offset)
    assert_bounds_cover(mesh.vertices, mesh.faces)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(3, 60))
def test_weighted_sums_within_bounds(seed, sides):
    rng = np.random.default_rng(seed)
    vertices, faces = _posed(solids.regular_prism(sides, 1.0, 0.3), seed, rng.normal(size=3) * 10)
    weights = rng.uniform(0.1, 10.0, size=faces.shape[0])
    assert_bounds_cover(vertices, faces, weights=weights)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([1e-3, 1e-8, 1e-14, 0.0]))
def test_double_double_determinant_within_its_bound(seed, flatness):
    """det_double_double: hi + lo within DET_ERROR · permanent of the exact determinant."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, 50, 3)) * 10.0 ** rng.integers(-3, 4, size=(2, 50, 1))
    c = rng.uniform(-1, 1, size=(50, 1)) * a + rng.uniform(-1, 1, size=(50, 1)) * b
    c += flatness * rng.normal(size=(50, 3))                      # nearly (or exactly) coplanar with the origin
    (hi, lo), permanent = det_double_double(a, b, c)
    for k in range(50):
        exact = _exact_det(a[k], b[k], c[k])
        assert abs(Fraction(float(hi[k])) + Fraction(float(lo[k])) - exact) <= Fraction(DET_ERROR * permanent[k])
        terms = [abs(Fraction(float(a[k, i])) * Fraction(float(b[k, j])) * Fraction(float(c[k, 3 - i - j])))
                 for i in range(3) for j in range(3) if i != j]
        assert permanent[k] <= 1.01 * float(sum(terms)) and float(sum(terms)) <= 1.01 * permanent[k]


def _corners(faces_points):
    """(face, corner, axis) points as the kernel's (corner, axis, face) block."""
    return np.ascontiguousarray(np.asarray(faces_points, dtype=float).transpose(1, 2, 0))


def _float_determinants(corners):
    """The kernel's plain-float det and bound of faces given as (axis, corner, face)."""
    import massprops.core.face_terms as kernel
    h = corners.shape[2]
    w = kernel.workspace(np.empty(kernel.WORKSPACE_ROWS * h), h)
    w["points"][:] = corners
    det, _, bound, area = w["summed"][:4]
    kernel._cross_product(w, area)
    kernel._determinant(w, det, bound)
    return det.copy(), bound.copy()


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(1e-9, 1e-2), st.floats(-1.0, 1.0))
def test_refined_faces_within_bound(seed, width, lean):
    """Each refined determinant (rotation, double-double or exact) is within its own bound."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(-2, 2, size=(64, 3))
    along = rng.normal(size=(64, 3))
    across = rng.normal(size=(64, 3))
    # Needles (one short edge) and obtuse slivers (the third corner almost on the long edge).
    a = base
    b = base + along
    c = base + (0.5 + 0.5 * lean) * along + width * across
    c[::3] = base[::3] + width * across[::3]
    corners = _corners(np.stack([a, b, c], axis=1))
    det, bound = _float_determinants(corners)
    absolute = np.empty(64)
    refined, exact_count = _refine_hard_faces(corners, det, bound, absolute, np.empty(64))
    assert np.array_equal(absolute, np.abs(det))
    assert 0 <= exact_count <= refined <= 64
    for k in range(64):
        assert abs(Fraction(float(det[k])) - _exact_det(a[k], b[k], c[k])) <= Fraction(float(bound[k]))
        assert bound[k] <= 64 * 2.0 ** -53 * abs(det[k]) or det[k] == 0


def test_rotation_spares_most_slivers_the_double_double(monkeypatch):
    """A fine prism's slivers are mostly certified in plain float by a cyclic rotation."""
    import massprops.core.face_terms as kernel
    vertices, faces = _posed(solids.regular_prism(2000, 1.0, 3.0), 11, (2.0, -1.0, 0.5))
    rotated = assert_bounds_cover(vertices, faces)
    monkeypatch.setattr(kernel, "_best_rotation", lambda corners, det, bound: (det, bound))
    unrotated = integrate(vertices, faces)
    assert 0 < rotated.refined_faces < unrotated.refined_faces / 2
    assert abs(rotated.det_sum - unrotated.det_sum) <= rotated.det_error + unrotated.det_error


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([0, 1, 2]))
def test_rotation_starts_each_needle_at_its_shortest_edge(seed, turn):
    """A needle keeps the better of its own bound and the one from its shortest edge's first corner."""
    from massprops.core.face_terms import _best_rotation
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, size=(48, 3))
    long_edge = rng.normal(size=(48, 3))
    b = a + long_edge * rng.uniform(1e-4, 1e-1, size=(48, 1))     # a short edge a→b
    c = a + long_edge + 1e-3 * rng.normal(size=(48, 3))
    c[::4] = a[::4] + rng.normal(size=(12, 3))                      # and some ordinary faces
    points = np.roll(np.stack([a, b, c], axis=1), turn, axis=1)      # the short edge starts at corner `turn`
    det, bound = _float_determinants(_corners(points))
    expected_det, expected_bound = det.copy(), bound.copy()
    for k in range(48):
        lengths = [np.sum((points[k, (i + 1) % 3] - points[k, i]) ** 2) for i in range(3)]
        start = int(np.argmin(lengths))
        if start and max(lengths) > 4 * min(lengths):
            d, e = _float_determinants(_corners(np.roll(points[k:k + 1], -start, axis=1)))
            if e[0] < bound[k]:
                expected_det[k], expected_bound[k] = d[0], e[0]
    found_det, found_bound = _best_rotation(_corners(points), det, bound)
    assert np.array_equal(found_det, expected_det) and np.array_equal(found_bound, expected_bound)


def test_partial_chunks_and_empty_input():
    mesh = solids.icosphere(2)
    vertices, faces = _posed(mesh, 12, (0.2, 0.3, 0.4))
    whole = integrate(vertices, faces)
    for chunk in (1, 7, 100, faces.shape[0] - 1):
        part = assert_bounds_cover(vertices, faces, chunk=chunk)
        assert abs(part.det_sum - whole.det_sum) <= part.det_error + whole.det_error
    empty = integrate(vertices, faces[:0])
    assert (empty.det_sum, empty.faces, empty.refined_faces) == (0.0, 0, 0)
    assert not empty.first.any() and not empty.second.any()


def test_face_indices_outside_the_vertices_are_refused():
    import pytest
    mesh = solids.tetrahedron()
    for faces in (mesh.faces - 1, mesh.faces + 1, (mesh.faces - 1).astype(np.int32), mesh.faces.astype(np.uint32) + 1):
        with pytest.raises(IndexError, match="does not exist"):
            integrate(mesh.vertices, faces)
    assert integrate(mesh.vertices, mesh.faces.astype(np.int32)).det_sum == integrate(mesh.vertices, mesh.faces).det_sum


def test_radius_and_frame_match_the_scaled_coordinates():
    """The bounds' radius (from the bounding box) is the largest scaled coordinate, exactly."""
    from massprops.core.integrate import _frame
    rng = np.random.default_rng(5)
    for offset in (0.0, 0.3, 7.0, -1e6, 3e12):
        vertices = rng.normal(size=(200, 3)) * rng.uniform(1e-3, 1e3, size=3) + offset
        axes = np.ascontiguousarray(vertices.T)
        reference, scale_exp, radius = _frame(axes)
        scaled = [(Fraction(float(x)) - Fraction(float(r))) / Fraction(2) ** scale_exp
                  for row, r in zip(axes, reference) for x in row]
        assert Fraction(radius) == max(abs(y) for y in scaled)


@pytest.mark.parametrize("exponent", [-1000, -1040, -1070])
def test_parts_below_2_to_the_minus_1000_scale_exactly(exponent):
    """The power-of-two scale factor itself would overflow: the scaling must still be exact."""
    mesh = solids.tetrahedron()
    vertices = np.ldexp(mesh.vertices, exponent)
    moments = assert_bounds_cover(vertices, mesh.faces)
    assert moments.scale_exp < -990 and moments.det_sum != 0


coordinates = st.one_of(
    st.floats(-1e3, 1e3, allow_nan=False, width=32).map(float),      # binary STL values
    st.floats(-1e3, 1e3, allow_nan=False),
    st.floats(-1e-300, 1e-300, allow_nan=False),                     # tiny values beside large ones
    st.floats(1e8, 1e8 + 4, allow_nan=False))


@settings(max_examples=200, deadline=None)
@given(st.lists(coordinates, min_size=2, max_size=40), st.sampled_from([1, 3, 1 << 16]))
def test_the_frame_shift_is_exact_for_every_coordinate(values, block):
    """Whatever reference the frame takes (the box's centre or the safe fallback), x − reference is exact."""
    import massprops.core.integrate as kernel
    from massprops.core.integrate import _frame
    original = kernel._EXACT_CHECK_BLOCK
    kernel._EXACT_CHECK_BLOCK = block
    try:
        axes = np.array([values, values[::-1], values[1:] + values[:1]], dtype=np.float64)
        reference, _, _ = _frame(axes)
    finally:
        kernel._EXACT_CHECK_BLOCK = original
    for row, r in zip(axes, reference.tolist()):
        for x in row.tolist():
            assert Fraction(x - r) == Fraction(x) - Fraction(r)


def test_a_float32_part_near_the_origin_is_shifted_to_its_centre():
    """Its coordinates are coarse enough that the centre subtracts exactly: fewer hard faces than at the origin."""
    from massprops.core.integrate import _frame
    axes = np.array([[-1.0, 3.0, 0.1], [-2.0, 2.0, 1.5], [0.25, 0.5, 0.75]], dtype=np.float32).astype(np.float64)
    reference, _, _ = _frame(axes)
    assert reference.tolist() == [1.0, 0.0, 0.5]
    axes[0, 2] = 1e-300                                       # a double far finer than the box: the centre is inexact
    reference, _, _ = _frame(axes)
    assert reference[0] == 0.0


def test_slivers_around_the_centre_need_no_double_double():
    """A fine float32 prism beside the origin (outside it): none of its faces' planes pass near the box's centre.

    With the origin as reference, the faces seen edge-on from it (tens of them) needed double-double.
    """
    mesh = solids.regular_prism(500, 1.0, 2.0)
    for offset in ([1.6, 0.0, 0.0], [2.5, -1.8, 1.2]):
        vertices = (mesh.vertices + offset).astype(np.float32).astype(np.float64)
        moments = assert_bounds_cover(vertices, mesh.faces)
        assert moments.refined_faces == 0 and moments.reference[0] != 0.0
