"""The exact geometric decisions behind the solid: against independent rational oracles.

Triangles on a small integer grid meet in every degenerate way (shared
edges, touching corners, coplanar overlaps); the oracles are the separating
axis theorem and segment clipping in Python integers and Fractions.
"""

from fractions import Fraction

import numpy as np
from hypothesis import given, settings, strategies as st

from massprops.core.intersect import ExactGeometry, orient3d_signs


def _sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def _area_zero(t):
    return _cross(_sub(t[1], t[0]), _sub(t[2], t[0])) == [0, 0, 0]


def separated(t1, t2):
    """Separating axis theorem for two closed triangles (integer coordinates, exact)."""
    e1 = [_sub(t1[(i + 1) % 3], t1[i]) for i in range(3)]
    e2 = [_sub(t2[(i + 1) % 3], t2[i]) for i in range(3)]
    n1, n2 = _cross(e1[0], e1[1]), _cross(e2[0], e2[1])
    axes = [n1, n2] + [_cross(a, b) for a in e1 for b in e2] + [_cross(n, e) for n in (n1, n2) for e in e1 + e2]
    for axis in axes:
        p1, p2 = [_dot(axis, v) for v in t1], [_dot(axis, v) for v in t2]
        if axis != [0, 0, 0] and (max(p1) < min(p2) or max(p2) < min(p1)):
            return True
    return False


def _segment_in_triangle(a, b, t):
    """Points where the closed segment ab meets the closed triangle t (its end points), exactly."""
    p, q, r = t
    n = _cross(_sub(q, p), _sub(r, p))
    d = _sub(b, a)
    da, db = _dot(n, _sub(a, p)), _dot(n, _sub(b, p))
    sides = [(t[i], t[(i + 1) % 3]) for i in range(3)]
    if da == 0 and db == 0:
        low, high = Fraction(0), Fraction(1)
        for u, v in sides:
            f0, f1 = _dot(_cross(_sub(v, u), _sub(a, u)), n), _dot(_cross(_sub(v, u), d), n)
            if f1 == 0 and f0 < 0:
                return []
            if f1 > 0:
                low = max(low, Fraction(-f0, f1))
            elif f1 < 0:
                high = min(high, Fraction(-f0, f1))
        return [] if low > high else [[a[k] + d[k] * s for k in range(3)] for s in (low, high)]
    if (da > 0 and db > 0) or (da < 0 and db < 0):
        return []
    s = Fraction(da, da - db)
    x = [a[k] + d[k] * s for k in range(3)]
    return [x] if all(_dot(_cross(_sub(v, u), _sub(x, u)), n) >= 0 for u, v in sides) else []


def meet_beyond(t1, t2, shared):
    """Whether triangles sharing the points ``shared`` (1 or 2) have another common point."""
    points = [x for s, o in ((t1, t2), (t2, t1)) for i in range(3)
              for x in _segment_in_triangle(s[i], s[(i + 1) % 3], o)]
    for x in points:
        if len(shared) == 1 and x != shared[0]:
            return True
        if len(shared) == 2:
            a, b = shared
            if _cross(_sub(b, a), _sub(x, a)) != [0, 0, 0]:
                return True
            s = Fraction(_dot(_sub(x, a), _sub(b, a)), _dot(_sub(b, a), _sub(b, a)))
            if s < 0 or s > 1:
                return True
    return False


grid = st.lists(st.integers(-2, 2), min_size=3, max_size=3)


@settings(max_examples=200, deadline=None)
@given(st.lists(grid, min_size=6, max_size=6), st.integers(-3, 3), st.sampled_from([1.0, 2.0 ** -10, 2.0 ** 20]))
def test_triangles_of_two_shells_meet_exactly_when_they_share_a_point(points, shift, scale):
    t1, t2 = points[:3], points[3:]
    if _area_zero(t1) or _area_zero(t2):
        return
    # Power-of-two shifts and scales keep the integer geometry exact in floats.
    vertices = np.array(points, dtype=float) * scale + 2.0 ** shift
    found = ExactGeometry(vertices).intersections(np.array([[0, 1, 2], [3, 4, 5]]), np.array([0, 1]), 2,
                                                 within=False, between=True)
    assert (found.shell_pairs.shape[0] == 1) == (not separated(t1, t2))


@settings(max_examples=200, deadline=None)
@given(st.lists(grid, min_size=5, max_size=5, unique_by=tuple), st.integers(1, 2), st.permutations([0, 1, 2]),
       st.permutations([0, 1, 2]))
def test_neighbours_in_a_shell_meet_only_where_they_fold(points, shared, order1, order2):
    first = [0, 1, 2]
    second = [0, 1, 3] if shared == 2 else [0, 3, 4]
    first, second = [first[i] for i in order1], [second[i] for i in order2]
    t1, t2 = [points[i] for i in first], [points[i] for i in second]
    if _area_zero(t1) or _area_zero(t2):
        return
    found = ExactGeometry(np.array(points, dtype=float)).intersections(
        np.array([first, second]), np.array([0, 0]), 1, within=True, between=False)
    assert bool(found.self_found[0]) == meet_beyond(t1, t2, points[:shared])


# The predicates' contract: coordinates of about unit size, none non-zero below 2**-200.
unit_floats = st.floats(-1.0, 1.0).map(lambda x: x if abs(x) >= 2.0 ** -200 else 0.0)


@settings(max_examples=200, deadline=None)
@given(st.lists(unit_floats, min_size=9, max_size=9), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
       st.integers(-4, 4))
def test_orient3d_signs_are_exact_on_nearly_coplanar_points(abc, u, v, ulps):
    """d on the plane of a, b, c up to rounding, then moved by a few units in the last place of its size."""
    a, b, c = (np.array(abc[3 * k:3 * k + 3]) for k in range(3))
    d = a + u * (b - a) + v * (c - a)
    d[2] = d[2] + ulps * np.spacing(max(np.abs(d).max(), 2.0 ** -100))
    d[np.abs(d) < 2.0 ** -200] = 0.0
    got = int(orient3d_signs(np.array([a, b, c, d]))[0])
    fa, fb, fc, fd = ([Fraction(float(x)) for x in p] for p in (a, b, c, d))
    rows = [_sub(fa, fd), _sub(fb, fd), _sub(fc, fd)]
    det = _dot(rows[0], _cross(rows[1], rows[2]))
    assert got == (det > 0) - (det < 0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-6, 6), min_size=3, max_size=3), st.integers(0, 2 ** 31))
def test_winding_numbers_of_nested_boxes(point, seed):
    """Points on a grid, boxes (outward, inward) with faces on odd coordinates: no point on a surface."""
    from massprops.validation import solids
    outer = solids.box((10.0, 10.0, 10.0))
    inner = solids.box((6.0, 6.0, 6.0), (1.0, 0.0, 0.0)).flipped()
    both = solids.combine(outer, inner)
    vertices = np.vstack([both.vertices, [np.array(point, float) + 0.5]])
    x = np.array(point) + 0.5
    expected = int(np.all(np.abs(x) < 5)) - int(np.all(np.abs(x - [1, 0, 0]) < 3))
    got = ExactGeometry(vertices).winding(both.faces, [len(vertices) - 1])
    assert got.tolist() == [expected]
