"""The shell certificate by degree (isect/stars.c): a closed shell seen from its centroid.

When the caller guarantees a closed surface (every edge used as often each
way), a one-shell search certifies the shell from its faces alone: one sign
of every face seen from the centroid, one face crossed by a ray from it, and
V - F/2 = 2.  Shells that pass the sign test and the Euler count but wrap
twice around the centroid, or touch themselves at vertices, must still be
found crossing or pinched; the oracle is every pair of faces tested exactly
in Python integers (tests/test_intersect.py).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.core.intersect import ExactGeometry
from test_intersect import _area_zero, _double_cover, _integer_sphere, crossing_pairs


def _closed_search(points, faces, threads=1, scale=0):
    """Pairs and pinched vertices of the search told the surface is closed, and its record."""
    geometry = ExactGeometry(np.array(points, dtype=float) * 2.0 ** scale)
    faces = np.array(faces, dtype=np.int64)
    pairs, pinched = geometry.crossing_pairs(faces, closed=True, threads=threads)
    found = geometry.intersections(faces, np.zeros(len(faces), dtype=np.int64), 1, within=True, between=False,
                                   max_examples=10 ** 6, closed=True, threads=threads)
    assert {tuple(p) for p in found.examples.tolist()} == {tuple(p) for p in pairs.tolist()}
    assert found.pinched == pinched
    return {tuple(p) for p in pairs.tolist()}, pinched, found


def _bipyramid(k, turns, radii, heights, offset):
    """Two poles and a ring of k vertices whose azimuths step by turns/k of a turn (integer points).

    Every face is seen from the z axis with one sign and every edge has two faces, wound
    oppositely; V - F/2 = 2.  The ring winds `turns` times around the axis: one turn is a
    star-shaped bipyramid, more a surface folded through itself `turns` times.
    """
    ring = []
    for i in range(k):
        angle = 2.0 * math.pi * turns * i / k
        ring.append([round(radii[i] * math.cos(angle)), round(radii[i] * math.sin(angle)), 0])
    points = [[0, 0, heights[0]], [0, 0, -heights[1]]] + ring
    points = [[p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]] for p in points]
    faces = [[0, 2 + i, 2 + (i + 1) % k] for i in range(k)] + [[1, 2 + (i + 1) % k, 2 + i] for i in range(k)]
    return points, faces


def _octahedron(radius, centre=(0, 0, 0)):
    x, y, z = centre
    points = [[x + radius, y, z], [x - radius, y, z], [x, y + radius, z], [x, y - radius, z],
              [x, y, z + radius], [x, y, z - radius]]
    faces = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    return points, faces


def _nested_octahedra(shared):
    """An octahedron and a smaller one inside it, both wound outward, sharing `shared` of the outer's
    poles (by index): each face is seen from the centre with one sign, every edge has two faces."""
    outer, faces = _octahedron(12)
    inner, inner_faces = _octahedron(6)
    points = list(outer)
    index = {}
    for i, p in enumerate(inner):
        if i in (4, 5)[:shared]:
            index[i] = i                                      # the pole the two share
            continue
        index[i] = len(points)
        points.append(p)
    faces = faces + [[index[v] for v in f] for f in inner_faces]
    return points, faces


def test_star_shaped_shells_are_certified_whole_and_found_clean():
    from massprops.validation import solids
    for mesh in (solids.icosphere(3), solids.regular_prism(40, 2.0, 0.3), solids.box((1.0, 2.0, 3.0)),
                 solids.tetrahedron()):
        for threads in (1, 2):
            pairs, pinched, found = _closed_search(mesh.vertices, mesh.faces, threads)
            assert not pairs and pinched == 0 and found.certified_shells == 1 and found.tests == 0


@pytest.mark.parametrize("turns", [1, 2, 3])
def test_a_bipyramid_turning_more_than_once_is_found_crossing(turns):
    points, faces = _bipyramid(7, turns, [50] * 7, [40, 40], [3, -2, 1])
    expected = crossing_pairs(points, faces)
    assert bool(expected) == (turns > 1)
    for threads in (1, 2):
        pairs, pinched, found = _closed_search(points, faces, threads)
        assert pairs == expected and pinched == 0
        assert found.certified_shells == (turns == 1)


def test_a_surface_wrapping_twice_around_its_centre_is_found_with_the_surface_closed():
    points, faces = _double_cover()
    expected = crossing_pairs(points, faces)
    pairs, pinched, found = _closed_search(points, faces)
    assert expected and pairs == expected and found.certified_shells == 0


@pytest.mark.parametrize("shared", [1, 2])
def test_spheres_pinched_together_are_found_pinched(shared):
    """One pole shared: V - F/2 = 3; both: V - F/2 = 2 and the ray from the centre crosses two faces."""
    points, faces = _nested_octahedra(shared)
    assert 2 * len({v for f in faces for v in f}) - len(faces) == 4 + 2 * (2 - shared)
    expected = crossing_pairs(points, faces)
    pairs, pinched, found = _closed_search(points, faces)
    assert pairs == expected and pinched == shared and found.certified_shells == 0


def test_spheres_sharing_an_edge_are_found_pinched():
    """An octahedron inside another, both wound outward, sharing two adjacent corners and the edge between
    them: that edge is used four times, twice each way (closed), the ray from the centre crosses two faces."""
    points, faces = _octahedron(12)
    inner, inner_faces = _octahedron(6)
    index = {0: 0, 2: 2}                                      # the outer's +x and +y corners
    for i, p in enumerate(inner):
        if i not in index:
            index[i] = len(points)
            points.append(p)
    faces = faces + [[index[v] for v in f] for f in inner_faces]
    edges = [(f[i], f[(i + 1) % 3]) for f in faces for i in range(3)]
    assert edges.count((0, 2)) == 2 and edges.count((2, 0)) == 2
    expected = crossing_pairs(points, faces)
    pairs, pinched, found = _closed_search(points, faces)
    assert pairs == expected and pinched == 2 and found.certified_shells == 0


@settings(max_examples=30, deadline=None)
@given(st.sampled_from([5, 7, 9, 11]), st.integers(1, 4), st.lists(st.integers(20, 90), min_size=11, max_size=11),
       st.lists(st.integers(5, 80), min_size=2, max_size=2), st.lists(st.integers(-9, 9), min_size=3, max_size=3),
       st.sampled_from([-200, 0, 250]))
def test_a_folded_bipyramid_meets_itself_exactly_where_its_faces_do(k, turns, radii, heights, offset, scale):
    """Rings winding 1-4 times with radii at random: folded or not, the search told the surface is
    closed reports exactly the pairs every pair of faces tested exactly gives, and certifies the shell
    as a whole only when there are none."""
    if math.gcd(k, turns) != 1 or 2 * turns >= k:
        return
    points, faces = _bipyramid(k, turns, radii[:k], heights, offset)
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    expected = crossing_pairs(points, faces)
    pairs, pinched, found = _closed_search(points, faces, scale=scale)
    assert pairs == expected and pinched == 0
    assert not (found.certified_shells and expected)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 31), st.integers(0, 6))
def test_a_pushed_sphere_told_closed_meets_itself_exactly_where_pairs_of_its_faces_do(seed, moves):
    points, faces = _integer_sphere(seed, moves)
    if any(_area_zero([points[i] for i in f]) for f in faces):
        return
    pairs, pinched, _ = _closed_search(points, faces, threads=2)
    assert pairs == crossing_pairs(points, faces) and pinched == 0
