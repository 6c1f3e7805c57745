"""The arrangement's cut stage in the compiled core agrees with the exact rational path (the reference).

Every soup is resolved twice by :func:`massprops.mesh.arrangement.arrange`:
with the compiled cut (which hands back to the exact path what its filter
cannot decide) and with the exact path alone.  They must keep the same
uncut faces and the same cut pieces (corner for corner, within the two
roundings' certified bounds), agree on negative windings, and the result
must match the exact oracle where there is one (signed unions of boxes).
"""

import contextlib

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops import mass_properties
from massprops.mesh import arrangement
from massprops.validation import solids
from oracle import within_bounds
from test_arrangement import _ROTATIONS, _box, _rotated, _turned_soup, grid_oracle, soup
from conftest import random_rotation


def _triangles(geometry, arranged):
    """Corners (k, 3, 3) of the kept pieces in the scaled frame, and a bound on each coordinate's rounding."""
    points = np.vstack([geometry.vertices, arranged.points])
    rounding = np.vstack([np.zeros_like(geometry.vertices), arranged.rounding])
    faces = np.vstack([arranged.faces, arranged.pieces])
    return points[faces], rounding[faces]


def _same_pieces(geometry, compiled, exact):
    """Every kept triangle of one run is a kept triangle of the other, corners within their rounding."""
    a, ea = _triangles(geometry, compiled)
    b, eb = _triangles(geometry, exact)
    assert a.shape == b.shape
    # |a - b| <= ea + eb on every coordinate of every corner, for a one-to-one matching
    gap = np.abs(a[:, None] - b[None, :]) - (ea[:, None] + eb[None, :])
    fits = np.all(gap <= 0.0, axis=(2, 3))
    free = np.ones(b.shape[0], dtype=bool)
    for k in range(a.shape[0]):
        candidates = np.flatnonzero(fits[k] & free)
        assert candidates.size, f"kept piece {k} of the compiled cut is not kept by the exact path"
        free[candidates[0]] = False


@contextlib.contextmanager
def handing_back(seed):
    """The compiled cut hands about half of the faces it cut, and of the rays it counted, back to the exact
    path (as it does with those whose signs it cannot settle): the two paths must fit together."""
    original = arrangement._Compiled.__init__

    def partly(self, geometry, faces, pairs, cut=None, available=None):
        original(self, geometry, faces, pairs, cut, available)
        cut = np.flatnonzero(self.status == 1)
        back = cut[np.random.default_rng(seed).random(cut.size) < 0.5]
        if back.size == 0:
            return
        status = self.status.copy()
        status[back] = 2
        keep = ~np.isin(self.face, back)
        count = np.diff(self.starts)
        corners = np.split(self.corners, self.starts[1:-1]) if self.face.size else []
        self.status = status
        self.face = self.face[keep]
        self.inside = self.inside[keep]
        self.corners = (np.concatenate([c for c, k in zip(corners, keep) if k]) if keep.any()
                        else np.zeros(0, dtype=np.int64))
        self.starts = np.concatenate([[0], np.cumsum(count[keep])]).astype(np.int64)

    counted = arrangement._Compiled.label

    def some(self, soup, pieces, first_patch, labels, done):
        # and about half of the rays it counted are counted again by the exact path
        before = np.flatnonzero(~done).tolist()
        counted(self, soup, pieces, first_patch, labels, done)
        for k in before:
            if np.random.default_rng([seed, k]).random() < 0.5:
                done[k] = False

    with pytest.MonkeyPatch.context() as patch:
        # (the one compiled call that does every step hands nothing back: the steps are taken one by one)
        patch.setattr(arrangement, "_all_at_once", lambda *args: None)
        patch.setattr(arrangement._Compiled, "__init__", partly)
        patch.setattr(arrangement._Compiled, "label", some)
        yield


@contextlib.contextmanager
def compared():
    """Every arrangement inside runs both ways and is compared; yields counts of faces the core cut
    itself and handed back."""
    original = arrangement.arrange
    tally = {"core": 0, "back": 0}

    def both(geometry, faces, weights, pairs):
        ours = original(geometry, faces, weights, pairs)
        reference = original(geometry, faces, weights, pairs, compiled=False)
        assert ours.negative == reference.negative
        assert sorted(map(tuple, ours.faces.tolist())) == sorted(map(tuple, reference.faces.tolist()))
        _same_pieces(geometry, ours, reference)
        status = arrangement._Compiled(geometry, faces, pairs).status
        tally["core"] += int(np.count_nonzero(status == 1))
        tally["back"] += int(np.count_nonzero(status == 2))
        return ours

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(arrangement, "arrange", both)
        yield tally


@settings(max_examples=25, deadline=None)
@given(st.lists(_box(), min_size=1, max_size=4), st.integers(0, 3), st.randoms(use_true_random=False),
       st.booleans(), st.sampled_from([None, 1, 2]))
def test_box_unions_agree_with_the_exact_path_and_the_oracle(boxes, rotation, random, repeat, back):
    # coplanar overlaps, repeated faces, boxes touching at faces, edges and vertices; some faces handed back
    if sum(sign for *_, sign in boxes) < 1:
        boxes = boxes + [((0, 0, 0), (65, 65, 65), 1)]
    with compared(), (handing_back(back) if back else contextlib.nullcontext()):
        if repeat:
            boxes = boxes + boxes[:1]
        exact = grid_oracle(boxes)
        if exact["volume"] == 0:
            return
        matrix = _ROTATIONS[rotation]
        result = mass_properties(soup(_turned_soup(boxes, matrix, random)))
        within_bounds(result.properties, _rotated(exact, matrix))


def _spheres(seeds, offsets, level=1):
    meshes = []
    for seed, offset in zip(seeds, offsets):
        sphere = solids.icosphere(level, 1.0)
        meshes.append(sphere.transformed(random_rotation(seed), offset))
    return solids.combine(*meshes)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.integers(0, 10 ** 6), min_size=2, max_size=3),
       st.lists(st.tuples(*[st.floats(-0.8, 0.8)] * 3), min_size=3, max_size=3), st.sampled_from([None, 3]))
def test_overlapping_spheres_agree_with_the_exact_path(seeds, offsets, back):
    with compared() as tally, (handing_back(back) if back else contextlib.nullcontext()):
        result = mass_properties(_spheres(seeds, offsets))
        assert result.properties.volume > 0
        assert tally["back"] == 0 or tally["core"] > 0


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10 ** 6), st.integers(6, 15), st.sampled_from(["box", "sphere"]),
       st.sampled_from([None, "reversed", "shifted"]))
def test_nearly_coplanar_copies_agree_with_the_exact_path(seed, digits, shape, variant):
    # a solid and a copy turned by 10**-digits about a random axis through a corner: faces that nearly
    # coincide, segments that nearly touch; a third copy reversed (cancelling) or shifted by a tiny step
    with compared():
        base = solids.box((1.0, 2.0, 3.0)) if shape == "box" else solids.icosphere(1, 1.0)
        axis = np.random.default_rng(seed).normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = 10.0 ** -digits
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        turn = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)
        pivot = base.vertices[0]
        copy = base.transformed(turn, pivot - turn @ pivot)
        parts = [base, copy]
        if variant == "reversed":
            parts.append(copy.flipped())
        elif variant == "shifted":
            parts.append(base.transformed(np.eye(3), np.full(3, 2.0 ** -40)))
        result = mass_properties(solids.combine(*parts))
        assert result.properties.volume > 0


def test_the_core_cuts_generic_crossings_itself():
    # Two spheres crossing in general position: no decision is left to the exact path.
    from massprops.core.intersect import ExactGeometry
    mesh = _spheres([1, 2], [(0, 0, 0), (0.5, 0.3, 0.2)], level=2)
    geometry = ExactGeometry(mesh.vertices)
    pairs, _ = geometry.crossing_pairs(mesh.faces)
    status = arrangement._Compiled(geometry, mesh.faces, pairs).status
    assert np.count_nonzero(status == 1) > 50 and np.count_nonzero(status == 2) == 0


@contextlib.contextmanager
def one_call_and_steps():
    """Every arrangement inside runs in the one compiled call (isect/resolve.c) and step by step (the call
    turned off): the faces, pieces, corners, roundings and negative windings must be the same bit for bit.
    Yields how many took the one call."""
    original, at_once = arrangement.arrange, arrangement._all_at_once
    tally = {"one call": 0}

    def both(geometry, faces, weights, pairs):
        ours = original(geometry, faces, weights, pairs)
        tally["one call"] += isinstance(at_once(geometry, np.ascontiguousarray(faces, dtype=np.int64),
                                                np.ascontiguousarray(weights, dtype=np.int64),
                                                np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2), 1),
                                        arrangement.Arrangement)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(arrangement, "_all_at_once", lambda *args: None)
            steps = original(geometry, faces, weights, pairs)
        assert ours.negative == steps.negative
        for name in ("faces", "pieces", "points", "rounding"):
            a, b = getattr(ours, name), getattr(steps, name)
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name
        return ours

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(arrangement, "arrange", both)
        yield tally


def _dented_sphere(level):
    sphere = solids.icosphere(level, 1.0)
    vertices = sphere.vertices.copy()
    vertices[int(np.argmax(vertices[:, 2]))] = [0.0, 0.0, -1.5]
    return type(sphere)(vertices, sphere.faces)


@pytest.mark.parametrize("make", [
    lambda: _dented_sphere(2),
    lambda: _spheres([1, 2], [(0, 0, 0), (0.5, 0.3, 0.2)], level=2),
    lambda: _spheres([3, 4, 5], [(0, 0, 0), (0.4, 0, 0), (0, 0.4, 0)], level=1),
    # coplanar overlaps (partners), a box written twice (weights), a negative box
    lambda: soup(_turned_soup([((0, 0, 0), (130, 65, 65), 1), ((65, 0, 0), (195, 130, 65), 1),
                               ((0, 0, 0), (130, 65, 65), 1), ((0, 0, 65), (65, 65, 130), 1)], _ROTATIONS[0])),
    lambda: soup(_turned_soup([((0, 0, 0), (195, 195, 195), 1), ((65, 65, 65), (130, 130, 260), -1),
                               ((65, 0, 0), (130, 65, 65), 1)], _ROTATIONS[1])),
])
def test_the_one_compiled_call_is_the_steps_bit_for_bit(make):
    with one_call_and_steps() as tally:
        result = mass_properties(make())
    assert result.properties.volume > 0 and tally["one call"] >= 1


def _swept_reference(geometry, vertices, arranged):
    """The rounded corners in mesh units and the bound on the volume their rounding may sweep, in numpy: the
    formulas of :func:`massprops.mesh.solid.swept_volume`, with the cones over the walls no reversed edge
    cancels (the reference the compiled pass, isect/swept.c, must match double for double)."""
    frame = geometry.frame
    power = 2.0 ** frame.scale_exp
    offset = arranged.points * power
    reference = np.asarray(frame.reference, dtype=np.float64)
    points = reference + offset
    back = points - reference
    added = np.abs((reference - (points - back)) + (offset - back))
    moved = np.linalg.norm(arranged.rounding * power + added, axis=1) * (1 + 1e-9)
    combined = np.vstack([vertices, points])
    delta = np.zeros(combined.shape[0])
    delta[vertices.shape[0]:] = moved
    faces = arranged.pieces[np.max(delta[arranged.pieces], axis=1) > 0]
    around = delta[faces]
    a, b, c = (combined[faces[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    perimeter = np.linalg.norm(b - a, axis=1) + np.linalg.norm(c - b, axis=1) + np.linalg.norm(a - c, axis=1)
    largest = float(moved.max())
    enlarged = (area + largest * perimeter + largest * largest) * (1 + 1e-9)
    total = float(np.sum(np.sum(around, axis=1) * enlarged)) / 3.0
    n = combined.shape[0]
    directed = {}
    for face in faces.tolist():
        for k in range(3):
            edge = (face[k], face[(k + 1) % 3])
            directed[edge] = directed.get(edge, 0) + 1
    def length(v):                     # as numpy's norm of rows (a 1-D norm is a dot product: other roundings)
        return np.linalg.norm(v[None], axis=1)[0]

    walls = []
    for (i, j), count in sorted(directed.items(), key=lambda item: item[0][0] * n + item[0][1]):
        surplus = count - directed.get((j, i), 0)
        if surplus > 0:
            pi, pj = combined[i], combined[j]
            wall = (length(pj - pi) + largest) * (delta[i] + delta[j])
            reach = max(length(pi - reference), length(pj - reference)) + largest
            walls.append(float(surplus) * wall * reach)
    total += float(np.sum(np.array(walls, dtype=np.float64))) / 3.0 * (1 + 1e-9)
    return combined, total * (1 + 1e-9)


@pytest.mark.parametrize("case", ["spheres", "dent", "boxes", "icospheres"])
def test_the_compiled_swept_volume_is_the_numpy_bound_double_for_double(case):
    from massprops.core.intersect import ExactGeometry
    from massprops.mesh.shells import _with_pieces
    if case == "spheres":
        mesh = _spheres([1, 2], [(0, 0, 0), (0.5, 0.3, 0.2)], level=2)
    elif case == "icospheres":                # two icospheres of 1,280 faces, hundreds of corners
        sphere = solids.icosphere(3, 1.0)
        mesh = solids.combine(sphere, sphere.transformed(np.eye(3), np.array([0.9, 0.31, 0.17])))
    elif case == "dent":
        mesh = solids.icosphere(2, 1.0)
        vertices = mesh.vertices.copy()
        vertices[int(np.argmax(vertices[:, 2]))] = [0.0, 0.0, -1.5]
        mesh = type(mesh)(vertices, mesh.faces)
    else:
        boxes = [((0, 0, 0), (4, 4, 4), 1), ((1, 2, 1), (6, 3, 5), 1), ((2, -1, 3), (3, 5, 7), 1)]
        mesh = soup(_turned_soup(boxes, _ROTATIONS[1], None))
    geometry = ExactGeometry(mesh.vertices)
    pairs, _ = geometry.crossing_pairs(mesh.faces)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    arranged = arrangement.arrange(geometry, faces, np.ones(faces.shape[0], dtype=np.int64), pairs)
    assert arranged.points.shape[0] > 0 and np.any(arranged.rounding > 0)
    combined, swept = _with_pieces(geometry, mesh.vertices, arranged)
    expected, bound = _swept_reference(geometry, mesh.vertices, arranged)
    assert np.array_equal(combined, expected)
    assert swept > 0 and swept == bound
