"""The integration kernel's sums and bounds against exact rational arithmetic.

Every sum :func:`massprops.core.integrate` returns (Σ det, Σ det·s,
Σ det·(s sᵀ + a aᵀ + b bᵀ + c cᵀ), and Σ |n| for the area measure) is
recomputed here with ``Fraction`` on the same scaled coordinates, and the
returned bound must cover the difference — on meshes built to reach every
path: slivers and needles (rotated corners), plates seen edge-on
(double-double), faces through the reference point (exact), heavy
cancellation (the double-double pass), weights, float32 values, far offsets,
tiny and huge scales.  Nothing here looks inside the kernel.
"""

from decimal import Decimal, localcontext
from fractions import Fraction
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import random_rotation
from massprops.validation import solids
from massprops.core import integrate, reference_frame
from massprops.model.errors import MeshGeometryError


def _det3(a, b, c):
    """det[a b c] of three exact (Fraction) points."""
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


def _scaled(moments, vertices):
    """The vertices in the moments' frame, exactly: (x − reference) · 2**-scale_exp."""
    scale = Fraction(2) ** -moments.scale_exp
    return [[(Fraction(float(x)) - Fraction(float(r))) * scale for x, r in zip(v, moments.reference)]
            for v in np.asarray(vertices, dtype=np.float64)]


def _exact_sums(moments, vertices, faces, weights=None):
    """Σ w·det, Σ w·det·s (3), Σ w·det·Q (3×3) in the moments' scaled coordinates, exactly."""
    scaled = _scaled(moments, vertices)
    det_sum, first, second = Fraction(0), [Fraction(0)] * 3, [[Fraction(0)] * 3 for _ in range(3)]
    for k, face in enumerate(np.asarray(faces)):
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


def assert_bounds_cover(vertices, faces, weights=None, order=2):
    moments = integrate(vertices, faces, weights=weights, order=order)
    det_sum, first, second = _exact_sums(moments, vertices, faces, weights)
    assert abs(Fraction(moments.det_sum) - det_sum) <= Fraction(moments.det_error)
    if order >= 1:
        for i in range(3):
            assert abs(Fraction(float(moments.first[i])) - first[i]) <= Fraction(moments.first_error), i
    if order >= 2:
        for i in range(3):
            for j in range(3):
                assert abs(Fraction(float(moments.second[i, j])) - second[i][j]) <= Fraction(moments.second_error)
    return moments, det_sum


def _posed(mesh, seed, offset, scale=1.0):
    vertices = mesh.vertices @ random_rotation(seed).T * scale + np.asarray(offset)
    return vertices, mesh.faces


offsets = st.sampled_from([0.0, 0.37, 3.0, 1e3, -2.5e6, 1e9])


@settings(max_examples=25, deadline=None)
@given(st.integers(3, 400), st.floats(1e-4, 1.0), st.integers(0, 2 ** 32 - 1), offsets)
def test_prism_slivers_within_bounds(sides, height, seed, offset):
    """Fan caps and long side rectangles: slivers at every angle, off the origin."""
    mesh = solids.regular_prism(sides, 1.0, height)
    vertices, faces = _posed(mesh, seed, (offset, -0.5 * offset, 0.25 * offset + 0.1))
    assert_bounds_cover(vertices, faces)


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
    try:
        assert_bounds_cover(mesh.vertices, mesh.faces)
    except MeshGeometryError:
        # Refused only beyond double precision's range (docs/conventions.md): a box whose volume is below
        # about 2**-1000 mesh units³, or below about 2**-900 of its largest extent cubed (a coordinate
        # drawn near 1e-308 makes one), and never a tetrahedron the kernel can integrate.
        extents = np.ptp(mesh.vertices, axis=0)
        log_box = float(np.sum(np.log2(extents)))
        assert extents.min() > 0 and (log_box < -990 or log_box - 3 * math.log2(extents.max()) < -890)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(1e-9, 1e-2), st.floats(-1.0, 1.0))
def test_needles_and_obtuse_slivers_within_bounds(seed, width, lean):
    """A soup of needles (one short edge) and obtuse slivers (a corner almost on the long edge).

    The faces do not close, so each face's own determinant and bound are what the sums show.
    """
    rng = np.random.default_rng(seed)
    base = rng.uniform(-2, 2, size=(48, 3))
    along = rng.normal(size=(48, 3))
    across = rng.normal(size=(48, 3))
    c = base + (0.5 + 0.5 * lean) * along + width * across
    c[::3] = base[::3] + width * across[::3]
    triangles = np.stack([base, base + along, c], axis=1)
    vertices = triangles.reshape(-1, 3)
    faces = np.arange(vertices.shape[0]).reshape(-1, 3)
    for turn in range(3):                       # every corner first: the rotations must not matter
        assert_bounds_cover(vertices, np.roll(faces, turn, axis=1))


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_faces_through_the_reference_point_are_exact(seed):
    """Faces in the plane x + y + z = 0 through the reference: no float evaluation can certify
    the sign of det = 0, so the kernel must find it exactly, and the sums are exactly 0."""
    rng = np.random.default_rng(seed)
    t, u = rng.integers(-16, 17, size=(2, 30, 3)) / 16.0                   # dyadic: every coordinate exact
    points = np.stack([t, u, -t - u], axis=2).reshape(-1, 3)
    corners = np.array([[x, y, z] for x in (-2.0, 2.0) for y in (-2.0, 2.0) for z in (-2.0, 2.0)])
    vertices = np.vstack([points, corners])                               # the box is centred on the origin
    faces = np.arange(points.shape[0]).reshape(-1, 3)
    moments, exact = assert_bounds_cover(vertices, faces)
    assert moments.reference.tolist() == [0.0, 0.0, 0.0] and exact == 0
    assert moments.det_sum == 0.0 and not moments.first.any() and not moments.second.any()
    assert moments.det_error < 1e-290
    assert moments.exact_faces > 0                                         # the path this test is for


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(3, 60))
def test_weighted_sums_within_bounds(seed, sides):
    rng = np.random.default_rng(seed)
    vertices, faces = _posed(solids.regular_prism(sides, 1.0, 0.3), seed, rng.normal(size=3) * 10)
    weights = rng.uniform(0.1, 10.0, size=faces.shape[0])
    assert_bounds_cover(vertices, faces, weights=weights)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([1e-6, 1e-9, 1e-12]), st.sampled_from([0.0, 0.37, -0.8]))
def test_heavy_cancellation_stays_accurate(seed, thickness, shift):
    """A thin plate straddling the reference: the tetrahedra cancel to 1e-12 of their sum.

    The bound must still cover the error, and be small against the volume itself:
    the result stays accurate to ~1e-12, which no fast pass over such terms reaches.
    """
    mesh = solids.box((1.0, 1.0, thickness))
    vertices, faces = _posed(mesh, seed, (shift, -shift, 0.5 * shift))
    moments, exact = assert_bounds_cover(vertices, faces)
    assert moments.det_error <= 1e-12 * abs(exact)
    assert abs(Fraction(moments.det_sum) - exact) <= 1e-12 * abs(exact)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([1.0, 1e3, -7e5]), st.sampled_from([1.0, 1e-3, 1e4]))
def test_float32_values_within_bounds(seed, offset, scale):
    """Binary-STL values: float32 numbers held exactly in float64."""
    vertices, faces = _posed(solids.icosphere(1), seed, (offset, 2 * offset, -offset), scale)
    assert_bounds_cover(vertices.astype(np.float32).astype(np.float64), faces)


@pytest.mark.parametrize("exponent", [-1070, -1040, -1000, -300, 300, 1000])
def test_tiny_and_huge_scales_within_bounds(exponent):
    """Parts at 2**-1070 (subnormal coordinates) up to 2**1000: the frame's power-of-two scale stays exact."""
    mesh = solids.tetrahedron(((0.1, 0.2, 0.3), (1.7, 0.1, 0.2), (0.4, 1.3, 0.1), (0.3, 0.5, 2.1)))
    vertices = np.ldexp(mesh.vertices, exponent)
    moments, exact = assert_bounds_cover(vertices, mesh.faces)
    assert moments.det_sum != 0 and exact != 0


def _exact_lengths(moments, vertices, faces):
    """Σ |(b − a) × (c − a)| in the moments' frame, to 60 digits (square roots of exact rationals)."""
    scaled = _scaled(moments, vertices)
    total = Decimal(0)
    with localcontext() as context:
        context.prec = 60
        for face in np.asarray(faces):
            a, b, c = (scaled[int(i)] for i in face)
            e1 = [b[i] - a[i] for i in range(3)]
            e2 = [c[i] - a[i] for i in range(3)]
            n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
            square = sum(x * x for x in n)
            total += (Decimal(square.numerator) / Decimal(square.denominator)).sqrt()
    return total


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(3, 40), offsets)
def test_area_measure_within_bounds(seed, sides, offset):
    """The surface sums of thin shells: |n| per face in place of det, with its own bound."""
    vertices, faces = _posed(solids.regular_prism(sides, 1.0, 0.4), seed, (offset, 0.5, -offset))
    moments = integrate(vertices, faces, measure="area")
    exact = _exact_lengths(moments, vertices, faces)
    slack = Decimal(10) ** -40 * exact
    assert abs(Decimal(moments.det_sum) - exact) <= Decimal(moments.det_error) + slack
    assert moments.det_sum == moments.area2 or abs(moments.det_sum - moments.area2) <= moments.det_error


def test_orders_form_only_what_is_asked_and_agree():
    vertices, faces = _posed(solids.l_bracket(), 3, (0.5, -2.0, 1.0))
    full = integrate(vertices, faces)
    for order in (0, 1):
        part, _ = assert_bounds_cover(vertices, faces, order=order)
        assert (part.det_sum, part.det_error) == (full.det_sum, full.det_error)
        assert not part.second.any() and (order == 1 or not part.first.any())


def test_empty_input_and_bad_indices():
    mesh = solids.tetrahedron()
    empty = integrate(mesh.vertices, mesh.faces[:0])
    assert (empty.det_sum, empty.faces, empty.refined_faces) == (0.0, 0, 0)
    assert not empty.first.any() and not empty.second.any()
    for faces in (mesh.faces - 1, mesh.faces + 1, (mesh.faces - 1).astype(np.int32), mesh.faces.astype(np.uint32) + 1):
        with pytest.raises(IndexError, match="does not exist"):
            integrate(mesh.vertices, faces)
    assert integrate(mesh.vertices, mesh.faces.astype(np.int32)).det_sum == integrate(mesh.vertices, mesh.faces).det_sum


def test_results_do_not_depend_on_the_thread_count(monkeypatch):
    """Many blocks of faces, one or two threads: the same bits (and within bounds of exact on a sample)."""
    a, b = solids.icosphere(5, 1.0), solids.icosphere(4, 0.5)
    mesh = solids.combine(a, type(b)(b.vertices + 3.0, b.faces))
    vertices, faces = _posed(mesh, 4, (0.3, 0.2, -0.1))
    results = []
    for threads in ("1", "2", "3"):
        monkeypatch.setenv("MASSPROPS_THREADS", threads)
        for weights in (None, np.linspace(0.5, 2.0, faces.shape[0])):
            m = integrate(vertices, faces, weights=weights)
            results.append((threads, weights is None, m.det_sum, m.det_error, m.area2, m.first.tobytes(),
                            m.second.tobytes(), m.first_error, m.second_error))
    by_kind = {}
    for threads, plain, *values in results:
        by_kind.setdefault(plain, []).append(values)
    assert all(all(v == values[0] for v in values) for values in by_kind.values())


coordinates = st.one_of(
    st.floats(-1e3, 1e3, allow_nan=False, width=32).map(float),      # binary STL values
    st.floats(-1e3, 1e3, allow_nan=False),
    st.floats(-1e-300, 1e-300, allow_nan=False),                     # tiny values beside large ones
    st.floats(1e8, 1e8 + 4, allow_nan=False))


@settings(max_examples=200, deadline=None)
@given(st.lists(coordinates, min_size=2, max_size=40))
def test_the_frame_shift_is_exact_for_every_coordinate(values):
    """Whatever reference the frame takes (the box's centre or the safe fallback), x − reference is exact."""
    vertices = np.array([values, values[::-1], values[1:] + values[:1]], dtype=np.float64).T
    reference, _ = reference_frame(vertices)
    for row, r in zip(vertices.T, reference.tolist()):
        for x in row.tolist():
            assert Fraction(x - r) == Fraction(x) - Fraction(r)


def test_a_float32_part_near_the_origin_is_shifted_to_its_centre():
    """Its coordinates are coarse enough that the centre subtracts exactly; a finer double keeps the safe reference."""
    vertices = np.array([[-1.0, 3.0, 0.1], [-2.0, 2.0, 1.5], [0.25, 0.5, 0.75]], dtype=np.float32).astype(np.float64).T
    reference, _ = reference_frame(np.ascontiguousarray(vertices))
    assert reference.tolist() == [1.0, 0.0, 0.5]
    vertices[2, 0] = 1e-300                                   # a double far finer than the box: the centre is inexact
    reference, _ = reference_frame(np.ascontiguousarray(vertices))
    assert reference[0] == 0.0


def test_slivers_around_the_centre_need_no_refinement():
    """A fine float32 prism beside the origin: with the box's centre as reference, no face is hard."""
    mesh = solids.regular_prism(500, 1.0, 2.0)
    for offset in ([1.6, 0.0, 0.0], [2.5, -1.8, 1.2]):
        vertices = (mesh.vertices + offset).astype(np.float32).astype(np.float64)
        moments, _ = assert_bounds_cover(vertices, mesh.faces)
        assert moments.refined_faces == 0 and moments.reference[0] != 0.0


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), offsets, st.floats(1e-9, 1.0))
def test_shell_and_tetrahedron_determinants_within_bounds(seed, offset, flatness):
    """The signed volumes the checks decide signs with: each within its bound of exact, in the frame's units."""
    from massprops.core import reference_frame, shell_determinants, shells, tetra_determinants
    rng = np.random.default_rng(seed)
    a = solids.regular_prism(int(rng.integers(3, 30)), 1.0, flatness)
    b = solids.icosphere(1, 0.5)
    mesh = solids.combine(a, type(b)(b.vertices + [3.0, 0.0, 0.0], b.faces).flipped())
    vertices, faces = _posed(mesh, seed, (offset, 0.5, -offset))
    labels, count = shells(faces, vertices.shape[0])
    det_sum, det_error = shell_determinants(vertices, faces, labels, count)
    reference, scale_exp = reference_frame(vertices)
    frame = type("Frame", (), {"reference": reference, "scale_exp": scale_exp})
    scaled = _scaled(frame, vertices)
    for shell in range(count):
        exact = sum(_det3(*(scaled[int(i)] for i in face)) for face in faces[labels == shell])
        assert abs(Fraction(det_sum[shell]) - exact) <= Fraction(det_error[shell])
    tets = rng.integers(0, vertices.shape[0], size=(40, 4))
    det, bound = tetra_determinants(vertices, tets)
    for k, (p0, p1, p2, p3) in enumerate(tets.tolist()):
        e = [[scaled[p][i] - scaled[p0][i] for i in range(3)] for p in (p1, p2, p3)]
        assert abs(Fraction(det[k]) - _det3(*e)) <= Fraction(bound[k])
