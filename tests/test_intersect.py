"""The exact geometric decisions behind the solid: against independent rational oracles.

Triangles on a small integer grid meet in every degenerate way (shared
edges, touching corners, coplanar overlaps); the oracles are the separating
axis theorem and segment clipping in Python integers and Fractions.
"""

from fractions import Fraction

import numpy as np
import pytest
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


# ---- certificates: stars and shells that meet themselves only where they share -------------------

def _shared_points(t1, t2, f1, f2):
    return [t1[i] for i in range(3) if f1[i] in f2]


def _off_plane_on_one_side(t1, t2, shared):
    """t2's corners other than the shared ones lie strictly on one side of t1's plane: t2 meets
    that plane only in what they share, so the triangles meet nowhere else."""
    normal = _cross(_sub(t1[1], t1[0]), _sub(t1[2], t1[0]))
    sides = {(_dot(normal, _sub(x, t1[0])) > 0) - (_dot(normal, _sub(x, t1[0])) < 0) for x in t2 if x not in shared}
    return len(sides) == 1 and 0 not in sides


def crossing_pairs(points, faces):
    """Every pair of faces of one shell that meet other than along what they share, exactly."""
    triangles = [[points[i] for i in f] for f in faces]
    corners = np.array(triangles, dtype=object)
    low, high = corners.min(axis=1), corners.max(axis=1)            # exact: Python integers
    boxes_meet = np.all((low[:, None] <= high[None]) & (low[None] <= high[:, None]), axis=2)
    pairs = set()
    for a in range(len(faces)):
        for b in range(a + 1, len(faces)):
            if not boxes_meet[a, b]:
                continue
            shared = _shared_points(triangles[a], triangles[b], faces[a], faces[b])
            if shared and len(shared) < 3 and _off_plane_on_one_side(triangles[a], triangles[b], shared):
                continue
            if len(shared) == 3 or (shared and meet_beyond(triangles[a], triangles[b], shared)) or (
                    not shared and not separated(triangles[a], triangles[b])):
                pairs.add((a, b))
    return pairs


def search_pairs(vertices, faces):
    """Every crossing pair the search reports (examples uncapped), each once, and the geometry."""
    geometry = ExactGeometry(vertices)
    found = geometry.intersections(np.array(faces), np.zeros(len(faces), dtype=np.int64), 1, within=True,
                                   between=False, max_examples=10 ** 6)
    reported = [tuple(p) for p in found.examples.tolist()]
    assert len(reported) == len(set(reported)), "a pair reported twice"
    assert bool(found.self_found[0]) == bool(reported)
    return set(reported), geometry


def _umbrella(k, kind, turns, swap, radii, heights, angles):
    """A closed fan of k faces (v, a_i, a_{i+1}) about v = 0 on integer coordinates."""
    import math
    order = sorted(angles)
    if turns == 2:            # the link winds twice about v: half the angles a turn later
        order = sorted(order[::2]) + sorted(a + 360.0 for a in order[1::2])
    if swap is not None:      # two link vertices out of order: the fan folds (or not, if they are close)
        i, j = swap % k, (swap // k) % k
        order[i], order[j] = order[j], order[i]
    link = []
    for angle, radius, height in zip(order, radii, heights):
        x, y = round(radius * math.cos(math.radians(angle))), round(radius * math.sin(math.radians(angle)))
        z = {"planar": 0, "cone": heights[0], "rough": height}[kind]
        link.append([x, y, z])
    points = [[0, 0, 0]] + link
    faces = [[0, 1 + i, 1 + (i + 1) % k] for i in range(k)]
    return points, faces


def _monotone_once(points, k):
    """The link turns strictly counter-clockwise about the z axis, once (exact integers)."""
    import math
    link = [p[:2] for p in points[1:]]
    total = 0.0
    for i in range(k):
        (ax, ay), (bx, by) = link[i], link[(i + 1) % k]
        if ax * by - ay * bx <= 0:
            return False
        total += math.atan2(ax * by - ay * bx, ax * bx + ay * by)
    return round(total / (2 * math.pi)) == 1


def _integer_map(points, matrix, shift):
    return [[sum(matrix[r][c] * p[c] for c in range(3)) + shift[r] for r in range(3)] for p in points]


_matrices = st.lists(st.integers(-2, 2), min_size=9, max_size=9).map(lambda x: [x[0:3], x[3:6], x[6:9]]).filter(
    lambda m: round(np.linalg.det(np.array(m, dtype=float))) != 0)


@settings(max_examples=150, deadline=None)
@given(st.integers(3, 28), st.sampled_from(["planar", "cone", "rough"]), st.sampled_from([1, 1, 1, 2]),
       st.one_of(st.none(), st.integers(0, 28 * 28)),
       st.lists(st.integers(50, 1000), min_size=28, max_size=28),
       st.lists(st.integers(-1000, 1000), min_size=28, max_size=28),
       st.lists(st.integers(0, 3599).map(lambda a: a / 10), min_size=28, max_size=28, unique=True),
       st.one_of(st.none(), _matrices), st.sampled_from([-300, 0, 300]),
       st.sampled_from(["alone", "triangle", "fan"]))
def test_a_fan_about_one_vertex_meets_itself_exactly_where_pairs_of_its_faces_do(
        k, kind, turns, swap, radii, heights, angles, matrix, scale, company):
    """Fans (planar, on a cone, rough; wound once or twice; folded or not; any linear map; tiny or
    huge coordinates), alone, crossed by a triangle, or by a second fan of the same shell: the
    pairs the search reports are exactly those the oracle finds.  A star certificate that accepted
    a folded fan, or a hub group that swallowed a face too many, would lose some."""
    points, faces = _umbrella(k, kind, turns, swap, radii[:k], heights[:k], angles[:k])
    reach = max(radii[:k])
    if company == "triangle":   # a separate triangle of the same shell, through the fan's middle
        points = points + [[-reach, 1, -3], [reach, 2, -2], [3, -1, 5 + reach // 3]]
        faces = faces + [[k + 1, k + 2, k + 3]]
    elif company == "fan":      # the same fan turned on its side and moved: two hubs in one shell
        other = [[p[2] + 7, p[0] + reach // 4, p[1] - 5] for p in points]
        faces = faces + [[f[0] + k + 1, f[1] + k + 1, f[2] + k + 1] for f in faces]
        points = points + other
    if matrix is not None:
        points = _integer_map(points, matrix, [7, -3, 11])
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    expected = crossing_pairs(points, faces)
    reported, geometry = search_pairs(np.array(points, dtype=float) * 2.0 ** scale, faces)
    assert reported == expected
    stars, _ = geometry.certificates(np.array(faces))
    fan_pairs = {(a, b) for a, b in expected if b < k}
    assert not (stars[0] and fan_pairs), "a star certified embedded folds over itself"
    # Complete where it is promised: a flat or level-linked fan turning once about v is certified.
    level = kind == "planar" or (kind == "cone" and matrix is None)
    if level and swap is None and turns == 1 and _monotone_once(points[:k + 1] if matrix is None else
                                                                _umbrella(k, kind, 1, None, radii[:k], heights[:k],
                                                                          angles[:k])[0], k):
        assert stars[0]


def test_convex_solids_are_certified_whole_and_found_clean():
    from massprops.validation import solids
    for mesh in (solids.icosphere(2), solids.regular_prism(40, 2.0, 0.3), solids.box((1.0, 2.0, 3.0)),
                 solids.tetrahedron()):
        geometry = ExactGeometry(mesh.vertices)
        _, whole = geometry.certificates(mesh.faces)
        found = geometry.intersections(mesh.faces, np.zeros(len(mesh.faces), dtype=np.int64), 1, within=True,
                                       between=False)
        assert whole.tolist() == [True] and not found.self_found[0] and found.tests == 0


def _double_cover():
    """A closed surface whose every face faces the origin, wrapping twice around the z axis.

    Two poles and eight vertices around them at azimuths 0, 90, ..., 630 degrees, alternately at
    radius 4 and 6: each face is seen from inside, each edge has two faces, V - F/2 = 2, but the
    poles' links wind twice -- condition (b) of the shell certificate is all that refuses it.
    """
    ring = []
    for i in range(8):
        r = 4 if i < 4 else 6
        x, y = [(1, 0), (0, 1), (-1, 0), (0, -1)][i % 4]
        ring.append([r * x, r * y, 0])
    points = [[0, 0, 5], [0, 0, -5]] + ring
    faces = [[0, 2 + i, 2 + (i + 1) % 8] for i in range(8)] + [[1, 2 + (i + 1) % 8, 2 + i] for i in range(8)]
    return points, faces


def test_a_surface_wrapping_twice_around_its_centre_is_not_certified_and_is_found():
    points, faces = _double_cover()
    expected = crossing_pairs(points, faces)
    reported, geometry = search_pairs(np.array(points, dtype=float), faces)
    _, whole = geometry.certificates(np.array(faces))
    assert expected and reported == expected and whole.tolist() == [False]


def test_two_crossing_spheres_under_one_label_are_not_certified_and_are_found():
    """Each sphere is star-shaped about their common centre; only V - F/2 = 4 (two components) tells."""
    from massprops.validation import solids
    a = solids.icosphere(1, 8.0)
    both = solids.combine(a, type(a)(a.vertices + [1.0, 0.5, 0.25], a.faces))
    geometry = ExactGeometry(both.vertices)
    _, whole = geometry.certificates(both.faces)
    found = geometry.intersections(both.faces, np.zeros(len(both.faces), dtype=np.int64), 1, within=True,
                                   between=False)
    assert whole.tolist() == [False] and found.self_found[0]
    # Labelled as the two shells they are, each is certified and neither crosses itself.
    labels = np.repeat([0, 1], len(a.faces))
    _, whole = geometry.certificates(both.faces, labels, 2)
    found = geometry.intersections(both.faces, labels, 2, within=True, between=True)
    assert whole.tolist() == [True, True] and not found.self_found.any() and found.shell_pairs.tolist() == [[0, 1]]


def _integer_sphere(seed, moves):
    """icosphere(1) on integer coordinates (radius 100) with `moves` vertices moved at random."""
    from massprops.validation import solids
    rng = np.random.default_rng(seed)
    sphere = solids.icosphere(1, 100.0)
    points = np.rint(sphere.vertices).astype(np.int64)
    for v in rng.choice(len(points), size=moves, replace=False):
        points[v] += rng.integers(-150, 151, size=3)
    return points.tolist(), sphere.faces.tolist()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2 ** 31), st.integers(0, 6), st.sampled_from([-200, 0, 250]))
def test_a_closed_shell_meets_itself_exactly_where_pairs_of_its_faces_do(seed, moves, scale):
    """Spheres with vertices pushed about (star-shaped or not, folded or not): the shell
    certificate, the star certificates, the separation filter and the exact tests together
    against every pair of faces tested exactly."""
    points, faces = _integer_sphere(seed, moves)
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    reported, _ = search_pairs(np.array(points, dtype=float) * 2.0 ** scale, faces)
    assert reported == crossing_pairs(points, faces)


def _meeting_shell_pairs(points, faces, labels):
    """Every pair of shells with two faces that share a point (touching counts), exactly."""
    triangles = [[points[i] for i in f] for f in faces]
    return {(min(labels[a], labels[b]), max(labels[a], labels[b]))
            for a in range(len(faces)) for b in range(a + 1, len(faces))
            if labels[a] != labels[b] and not separated(triangles[a], triangles[b])}


_corner = st.lists(st.integers(-3, 3), min_size=3, max_size=3)


@settings(max_examples=120, deadline=None)
@given(st.lists(st.tuples(st.lists(st.integers(-12, 12), min_size=3, max_size=3), _corner, _corner, _corner),
                min_size=2, max_size=45),
       st.lists(st.integers(0, 3), min_size=45, max_size=45), st.sampled_from([1, 3, 8]),
       st.sampled_from([1.0, 2.0 ** -30, 2.0 ** 40]))
def test_a_soup_of_small_triangles_meets_exactly_where_pairs_of_its_faces_do(placed, labels, spread, scale):
    """Loose triangles over many grid cells (or crowded into a few, spread 1), touching, crossing and
    coplanar on a small integer grid: within one shell and between shells, the sweep, the
    separating planes and the exact tests together against every pair tested exactly."""
    points, faces = [], []
    for base, *corners in placed:
        triangle = [[spread * base[k] + c[k] for k in range(3)] for c in corners]
        if _area_zero(triangle):
            continue
        faces.append([len(points), len(points) + 1, len(points) + 2])
        points.extend(triangle)
    if len(faces) < 2:
        return
    reported, geometry = search_pairs(np.array(points, dtype=float) * scale, faces)
    assert reported == crossing_pairs(points, faces)
    labels = labels[:len(faces)]
    found = geometry.intersections(np.array(faces), np.array(labels), 4, within=False, between=True)
    assert {tuple(p) for p in found.shell_pairs.tolist()} == _meeting_shell_pairs(points, faces, labels)


def test_what_the_search_reports_does_not_depend_on_the_thread_count():
    """Many shells crossing each other and themselves: the same shells, pairs and examples."""
    from massprops.validation import solids
    rng = np.random.default_rng(5)
    pieces = []
    for k in range(40):
        piece = solids.torus(12, 6, 2.0, 0.6) if k % 2 else solids.icosphere(1, 1.5)
        vertices = piece.vertices + rng.uniform(-4, 4, size=3)
        if k % 5 == 0:
            vertices[0] = -vertices[0]           # pushed through: crosses itself
        pieces.append(type(piece)(vertices, piece.faces))
    mesh = solids.combine(*pieces)
    labels = np.concatenate([np.full(len(p.faces), k) for k, p in enumerate(pieces)])
    geometry = ExactGeometry(mesh.vertices)
    results = []
    for threads in (1, 2, 3):
        found = geometry.intersections(mesh.faces, labels, len(pieces), within=True, between=True,
                                       threads=threads)
        results.append((found.self_found.tolist(), found.examples.tolist(), found.shell_pairs.tolist(),
                        found.face_pairs.tolist()))
    assert results[0] == results[1] == results[2]
    assert any(results[0][0]) and len(results[0][2]) > 10


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(-2 ** 38, 2 ** 38).map(lambda x: 4 * x), min_size=9, max_size=9),
       st.lists(st.integers(-2 ** 20, 2 ** 20), min_size=6, max_size=6), st.integers(0, 2))
def test_a_triangle_touching_another_inside_is_found_however_the_float_filter_rounds(abc, offsets, which):
    """p lies exactly inside triangle abc; a second triangle from p leans off to one side.  With
    coordinates near 2**40 the float plane tests round, so only a certified bound keeps the
    separation filter from calling them apart."""
    a, b, c = (abc[3 * k:3 * k + 3] for k in range(3))
    if _area_zero([a, b, c]):
        return
    weights = [(1, 2, 1), (2, 1, 1), (1, 1, 2)][which]       # quarters: exact on multiples of 4
    p = [(weights[0] * a[k] + weights[1] * b[k] + weights[2] * c[k]) // 4 for k in range(3)]
    q = [p[k] + offsets[k] for k in range(3)]
    r = [p[k] + offsets[3 + k] for k in range(3)]
    if _area_zero([p, q, r]):
        return
    found = ExactGeometry(np.array([a, b, c, p, q, r], dtype=float)).intersections(
        np.array([[0, 1, 2], [3, 4, 5]]), np.array([0, 1]), 2, within=False, between=True)
    assert found.shell_pairs.tolist() == [[0, 1]]


@settings(max_examples=40, deadline=None)
@given(st.integers(16, 40), st.integers(16, 40), st.lists(st.integers(0, 9), min_size=80, max_size=80),
       st.lists(st.integers(300, 1000), min_size=80, max_size=80), st.integers(-400, 400), st.integers(-300, 300),
       st.one_of(st.none(), _matrices))
def test_two_flat_fans_crossing_in_one_shell_are_found_pair_by_pair(k1, k2, jitter, radii, shift, height, matrix):
    """Two embedded fans (each star certified, its faces grouped under its hub), one in z = 0 and one
    upright, crossing along a segment: every crossing pair between them is found, none twice."""
    import math

    def fan(k, jitter, radii, place):
        link = []
        for i in range(k):
            angle = 2 * math.pi * (i + jitter[i] / 20.0) / k
            link.append(place(round(radii[i] * math.cos(angle)), round(radii[i] * math.sin(angle))))
        return [place(0, 0)] + link, [[0, 1 + i, 1 + (i + 1) % k] for i in range(k)]

    points, faces = fan(k1, jitter, radii, lambda x, y: [x, y, 0])
    upright, other = fan(k2, jitter[40:], radii[40:], lambda x, y: [shift + y // 3, x, y + height])
    faces = faces + [[i + len(points) for i in f] for f in other]
    points = points + upright
    if matrix is not None:
        points = _integer_map(points, matrix, [5, 0, -9])
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    expected = crossing_pairs(points, faces)
    reported, geometry = search_pairs(np.array(points, dtype=float), faces)
    assert reported == expected
    stars, _ = geometry.certificates(np.array(faces))
    assert stars[0] and stars[k1 + 1]


def _finely_cut_box(n, rng, spike, depth=None):
    """A closed box [0, 4n]^2 x [0, 4 depth] (depth n unless given) whose sides are grids of squares
    of side 4 cut in two (integer coordinates), each side's inner grid points moved out by 0 or 1,
    and the middle of the bottom pushed up to height `spike`: not star-shaped about its centre, so
    the search certifies it patch by patch (cells of a coarse grid whose faces are one disk that
    projects one-to-one)."""
    index, points, faces = {}, [], []
    count = (n, n, n if depth is None else depth)
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for high in (0, 1):
            grid = []
            for i in range(count[u] + 1):
                row = []
                for j in range(count[v] + 1):
                    p = [0, 0, 0]
                    p[axis], p[u], p[v] = high * 4 * count[axis], 4 * i, 4 * j
                    row.append(index.setdefault(tuple(p), len(index)))
                    if row[-1] == len(points):
                        points.append(p)
                grid.append(row)
            for i in range(count[u]):
                for j in range(count[v]):
                    a, b, c, d = grid[i][j], grid[i + 1][j], grid[i + 1][j + 1], grid[i][j + 1]
                    for f in ([[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]):
                        faces.append(f if high else f[::-1])
    for p in points:
        inner = [a for a in range(3) if 0 < p[a] < 4 * count[a]]
        if len(inner) == 2:
            axis = 3 - sum(inner)
            p[axis] += (1 if p[axis] == 4 * count[axis] else -1) * int(rng.integers(0, 2))
    middle = next(p for p in points if p[0] == p[1] == 4 * (n // 2) and p[2] <= 0)
    middle[2] = spike
    return points, faces


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([12, 30]), st.integers(0, 3), st.sampled_from([0, -40, 60]))
def test_a_shell_certified_patch_by_patch_meets_itself_exactly_where_pairs_of_its_faces_do(seed, spike, folds,
                                                                                           scale):
    """A finely cut box, its spike short of the top or through it, with up to three points of its
    top slid across their neighbours (the top folds over itself, or its faces cross): patches of
    faces proved embedded skip their pairs, and the pairs found are exactly those of every pair of
    faces tested exactly."""
    rng = np.random.default_rng(seed)
    points, faces = _finely_cut_box(5, rng, spike)
    top = [p for p in points if p[2] >= 20 and 0 < p[0] < 20 and 0 < p[1] < 20]
    for k in rng.choice(len(top), size=folds, replace=False):
        top[k][0] += int(rng.integers(-9, 10))
        top[k][1] += int(rng.integers(-9, 10))
        top[k][2] += int(rng.integers(-6, 3))
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    reported, _ = search_pairs(np.array(points, dtype=float) * 2.0 ** scale, faces)
    assert reported == crossing_pairs(points, faces)


def _pairs_near(points, faces, moved):
    """Every crossing pair of faces when only the faces `moved` were moved off a closed shell that
    did not meet itself: each such pair holds one of them, and the other face's box meets its box
    (tested exactly pair by pair)."""
    corners = np.array(points, dtype=np.int64)[np.array(faces)]
    low, high = corners.min(axis=1), corners.max(axis=1)
    near = np.zeros(len(faces), dtype=bool)
    for t in moved:
        near |= np.all((low <= high[t]) & (low[t] <= high), axis=1)
    subset = np.flatnonzero(near)
    return {(int(subset[a]), int(subset[b])) for a, b in crossing_pairs(points, [faces[t] for t in subset])}


@settings(max_examples=6, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([12, 19]), st.sampled_from([0, 30]))
def test_a_thin_slab_meets_itself_exactly_where_its_pushed_vertex_makes_faces_cross(seed, spike, scale):
    """A finely cut slab four squares thick and twenty-four wide, 3,072 faces (the coarse grid's
    cells are then bounded by its thickness, not by its number of faces), the middle of its bottom
    pushed up short of the top (12) or through it (19): the pairs found are exactly those of the
    pushed vertex's faces, on one thread or two."""
    rng = np.random.default_rng(seed)
    points, faces = _finely_cut_box(24, rng, spike, depth=4)
    pushed = next(i for i, p in enumerate(points) if p[0] == p[1] == 48 and p[2] == spike)
    expected = _pairs_near(points, faces, [t for t, f in enumerate(faces) if pushed in f])
    assert bool(expected) == (spike == 19)
    geometry = ExactGeometry(np.array(points, dtype=float) * 2.0 ** scale)
    for threads in (1, 2):
        reported, pinched = geometry.crossing_pairs(np.array(faces), threads=threads)
        assert {tuple(p) for p in reported.tolist()} == expected and pinched == 0


def test_a_shell_certified_patch_by_patch_is_found_the_same_on_any_thread_count():
    rng = np.random.default_rng(3)
    points, faces = _finely_cut_box(8, rng, 40)
    geometry = ExactGeometry(np.array(points, dtype=float))
    labels = np.zeros(len(faces), dtype=np.int64)
    results = []
    for threads in (1, 2, 3):
        found = geometry.intersections(np.array(faces), labels, 1, within=True, between=False, threads=threads,
                                       max_examples=10 ** 6)
        results.append((found.self_found.tolist(), found.examples.tolist()))
    assert results[0] == results[1] == results[2] and results[0][0] == [True]


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2 ** 31), st.lists(st.integers(-8, 8), min_size=3, max_size=3),
       st.lists(st.integers(-8, 8), min_size=3, max_size=3))
def test_crossing_pairs_of_several_shells_are_every_pair_that_meets(seed, second, third):
    """Three finely cut boxes, the second and third moved so they cross the first, each other, or
    nothing: with their shell labels, the pairs listed are every pair of faces that meet (within a
    shell or between two), exactly those of every pair tested exactly."""
    rng = np.random.default_rng(seed)
    points, faces = [], []
    for shift in ([0, 0, 0], second, third):
        p, f = _finely_cut_box(3, rng, 4)
        faces += [[i + len(points) for i in face] for face in f]
        points += [[x + s for x, s in zip(q, shift)] for q in p]
    labels = np.repeat(np.arange(3), len(faces) // 3)
    geometry = ExactGeometry(np.array(points, dtype=float))
    reported, _ = geometry.crossing_pairs(np.array(faces), labels, 3)
    assert {tuple(p) for p in reported.tolist()} == crossing_pairs(points, faces)


@settings(max_examples=6, deadline=None)
@given(st.integers(0, 2 ** 31), st.sampled_from([2, 20]), st.sampled_from([10 ** 3, 10 ** 6]))
def test_parts_far_apart_under_one_label_meet_themselves_exactly_where_pairs_of_their_faces_do(seed, spike, apart):
    """Three finely cut boxes far apart under one label (not star-shaped: certified patch by patch,
    in a coarse grid whose cells, at 10**6 apart, far outnumber the faces), the middle of each
    bottom pushed up short of the top or through it: the pairs found are exactly those of every
    pair of faces tested exactly."""
    rng = np.random.default_rng(seed)
    points, faces = [], []
    for shift in ([0, 0, 0], [apart, 0, 0], [0, apart, apart]):
        p, f = _finely_cut_box(3, rng, spike)
        faces += [[i + len(points) for i in face] for face in f]
        points += [[x + s for x, s in zip(q, shift)] for q in p]
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    reported, _ = search_pairs(np.array(points, dtype=float), faces)
    assert reported == crossing_pairs(points, faces)
    assert bool(reported) == (spike == 20)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(*[st.sampled_from([0.0, 1e-70, -3e-65, 0.1, 0.3, -1.7, 2.5, 1e3, 7.25e-3])] * 3),
                min_size=3, max_size=12),
       st.sampled_from([1.0, 2.0 ** -1000, 3.0e200, 1e-300]), st.randoms(use_true_random=False))
def test_moments_from_the_checks_scaled_vertices_are_those_of_the_vertices(points, scale, rng):
    # The exact checks hand their scaled vertices to the integration (when nothing was snapped):
    # every sum must be bit for bit the one the integration finds by scaling the vertices itself.
    from massprops.core import integrate

    vertices = np.array(points, dtype=np.float64) * scale
    n = vertices.shape[0]
    faces = np.array([[rng.randrange(n) for _ in range(3)] for _ in range(2 * n)], dtype=np.int64)
    geometry = ExactGeometry(vertices)
    given_scaled = integrate(vertices, faces, frame=geometry.frame, scaled=geometry.unsnapped)
    own = integrate(vertices, faces, frame=geometry.frame)
    for name in ("det_sum", "det_error", "first", "first_error", "second", "second_error", "area2"):
        assert np.array_equal(getattr(given_scaled, name), getattr(own, name)), name


@pytest.mark.parametrize("spike", [100, 186])
def test_a_large_shell_meets_itself_exactly_where_its_pushed_vertex_makes_faces_cross(spike):
    """A finely cut box of 23,232 faces (large enough that the search matches each vertex's faces
    from the faces themselves), the middle of its bottom pushed up short of the top (100) or through
    it (186).  Only the faces of the pushed vertex moved, so every crossing pair holds one of them,
    and the other face's box meets its box: the pairs are those of that handful of faces, tested
    exactly pair by pair, on one thread or two."""
    rng = np.random.default_rng(7)
    points, faces = _finely_cut_box(44, rng, spike)
    assert len(faces) == 23232
    pushed = next(i for i, p in enumerate(points) if p[0] == p[1] == 88 and p[2] == spike)
    corners = np.array(points, dtype=np.int64)[np.array(faces)]
    low, high = corners.min(axis=1), corners.max(axis=1)
    moved = [t for t, f in enumerate(faces) if pushed in f]
    near = np.zeros(len(faces), dtype=bool)
    for t in moved:
        near |= np.all((low <= high[t]) & (low[t] <= high), axis=1)
    subset = np.flatnonzero(near)
    expected = {(int(subset[a]), int(subset[b])) for a, b in crossing_pairs(points, [faces[t] for t in subset])}
    assert bool(expected) == (spike == 186)
    geometry = ExactGeometry(np.array(points, dtype=float))
    for threads in (1, 2):
        reported, pinched = geometry.crossing_pairs(np.array(faces), threads=threads)
        assert {tuple(p) for p in reported.tolist()} == expected and pinched == 0


@pytest.mark.parametrize("spike", [300, 660])
def test_a_large_shell_in_any_face_order_meets_itself_exactly_where_its_pushed_vertex_makes_faces_cross(spike):
    """A finely cut box of 307,200 faces in a random order (the coarse grid's filing then cannot
    reuse what counting found for most faces, which are filed from their corners again), the middle
    of its bottom pushed up short of the top (300) or through it (660): the pairs are those of the
    pushed vertex's faces tested exactly pair by pair, on one thread or two."""
    rng = np.random.default_rng(11)
    points, faces = _finely_cut_box(160, rng, spike)
    faces = [faces[t] for t in rng.permutation(len(faces))]
    assert len(faces) == 307200
    pushed = next(i for i, p in enumerate(points) if p[0] == p[1] == 320 and p[2] == spike)
    expected = _pairs_near(points, faces, [t for t, f in enumerate(faces) if pushed in f])
    assert bool(expected) == (spike == 660)
    geometry = ExactGeometry(np.array(points, dtype=float))
    for threads in (1, 2):
        reported, pinched = geometry.crossing_pairs(np.array(faces), threads=threads)
        assert {tuple(p) for p in reported.tolist()} == expected and pinched == 0
