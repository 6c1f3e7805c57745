"""Welding, edges, shells and duplicate faces of the compiled core, against plain-Python oracles.

- welding: a dictionary of coordinate values (``-0.0`` equal to ``+0.0``);
- edges: a ``Counter`` of directed edges (uses and balance per undirected edge);
- shells: a union-find over shared vertices;
- duplicate faces: a dictionary of sorted vertex triples with the orientation's parity;
- and through all of them ``check_mesh``'s outcome on closed, multi-shell,
  non-manifold, open, miswound, duplicated and inside-out meshes.
"""

from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.validation import solids
from massprops.core import edge_summary, face_groups, shells, weld_corners, weld_indexed
from massprops.core.topology import edge_shells
from massprops.model.errors import MassPropsError
from massprops.mesh import TriangleMesh, check_mesh


# --- welding ----------------------------------------------------------------------------------

def _weld_oracle(corners):
    """Labels by first appearance of each coordinate triple, compared as numbers (so -0.0 == 0.0)."""
    seen = {}
    return [seen.setdefault(tuple(float(x) + 0.0 for x in row), len(seen)) for row in corners.reshape(-1, 3).tolist()]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from(["grid", "ulps", "wide", "signs"]), st.integers(1, 4000),
       st.sampled_from([np.float32, np.float64]))
def test_weld_matches_coordinate_values(seed, kind, count, dtype):
    rng = np.random.default_rng(seed)
    pool = {"grid": np.arange(-20, 20),
            "ulps": 1.0 + np.arange(40) * float(np.finfo(dtype).eps),
            "wide": rng.standard_normal(30) * 1e6,
            "signs": np.array([0.0, -0.0, 1.0, -1.0, 1e-38, -1e-38, 3e38])}[kind].astype(dtype)
    corners = pool[rng.integers(0, pool.size, (count, 3, 3))]
    vertices, faces = weld_corners(corners)
    assert faces.ravel().tolist() == _weld_oracle(corners)
    assert vertices.dtype == np.float64 and np.array_equal(vertices[faces], corners.astype(np.float64))
    mesh = TriangleMesh.from_triangles(corners)
    assert mesh.source_dtype == np.dtype(dtype) and np.array_equal(mesh.faces, faces)


def test_weld_keeps_nan_bits_apart_from_numbers():
    corners = np.array([[[np.nan, 0, 0], [1, 0, 0], [np.nan, 0, 0]], [[1, 0, 0], [0, 0, 0], [-0.0, 0, 0]]])
    vertices, faces = weld_corners(corners)
    assert faces.tolist() == [[0, 1, 0], [1, 2, 2]]
    assert np.isnan(vertices[0, 0]) and vertices.shape == (3, 3)


def test_weld_indexed_merges_equal_points_and_drops_unused_ones():
    cube = solids.box((1.0, 2.0, 3.0))
    # Every corner repeated per face (as exporters with per-face normals write), plus unused vertices.
    soup = np.vstack([cube.vertices[cube.faces].reshape(-1, 3), [[1e8, 0, 0], [np.nan, 1, 2]]])
    faces = np.arange(3 * cube.faces.shape[0]).reshape(-1, 3)
    vertices, welded, ignored = weld_indexed(soup, faces)
    assert vertices.shape == (8, 3) and np.isfinite(vertices).all() and ignored == 1
    assert np.array_equal(vertices[welded], cube.vertices[cube.faces])
    with pytest.raises(IndexError, match="vertex"):
        weld_indexed(soup, faces + 100)


# --- meshes, good and bad, for the edge checks --------------------------------------------------

def _scrambled(mesh, rng):
    """The same surface with vertices renumbered, faces reordered, and corners rotated (winding kept)."""
    relabel = rng.permutation(mesh.vertices.shape[0])
    vertices = np.empty_like(mesh.vertices)
    vertices[relabel] = mesh.vertices
    faces = relabel[mesh.faces][rng.permutation(mesh.faces.shape[0])]
    turn = rng.integers(0, 3, faces.shape[0])
    faces = np.take_along_axis(faces, (np.arange(3) + turn[:, None]) % 3, axis=1)
    return TriangleMesh(vertices, faces)


def _shape(kind, rng):
    shells_ = [solids.icosphere(int(rng.integers(0, 3)), 1.0)]
    if kind in ("two shells", "inside-out shell", "void"):
        inner = solids.box((0.5, 0.5, 0.5)) if kind == "void" else solids.cube(1.0, center=(5.0, 0.0, 0.0))
        shells_.append(inner.flipped() if kind != "two shells" else inner)
    if kind == "vertex-sharing tetrahedra":
        # Joined at one vertex only: one shell, as shells are counted by shared vertices.
        a = solids.tetrahedron()
        return TriangleMesh.from_triangles(np.concatenate([a.triangles, a.triangles + [1.0, 0.0, 0.0]]))
    if kind == "edge-sharing boxes":
        # Two boxes welded along one box edge: that edge is used four times, closed but not manifold.
        a, b = solids.box((1.0, 1.0, 1.0), (0.5, 0.5, 0.5)), solids.box((1.0, 1.0, 1.0), (1.5, 1.5, 0.5))
        return TriangleMesh.from_triangles(np.concatenate([a.triangles, b.triangles]))
    if kind == "written twice":
        # The same closed body twice: every edge balanced, every face duplicated.
        return TriangleMesh(shells_[0].vertices, np.concatenate([shells_[0].faces, shells_[0].faces]))
    return solids.combine(*shells_)


def _broken(mesh, flaw, rng):
    faces = mesh.faces
    k = int(rng.integers(0, faces.shape[0]))
    if flaw == "flipped face":
        faces = faces.copy()
        faces[k] = faces[k, ::-1]
    elif flaw == "missing face":
        faces = np.delete(faces, k, axis=0)
    elif flaw == "duplicated face":
        faces = np.concatenate([faces, faces[k:k + 1]])
    elif flaw == "reversed duplicate":
        faces = np.concatenate([faces, faces[k:k + 1, ::-1]])
    elif flaw == "collapsed edge":
        faces = np.concatenate([faces, [[faces[k, 0], faces[k, 0], faces[k, 1]]]])
    return TriangleMesh(mesh.vertices, faces)


def _edge_oracle(faces):
    """{(lower, higher): (uses, balance)} from a Counter of directed edges; collapsed edges apart."""
    directed = Counter(zip(faces.ravel().tolist(), np.roll(faces, -1, axis=1).ravel().tolist()))
    edges, collapsed = {}, 0
    for (tail, head), count in directed.items():
        if tail == head:
            collapsed += count
            continue
        uses, balance = edges.get((min(tail, head), max(tail, head)), (0, 0))
        edges[min(tail, head), max(tail, head)] = (uses + count, balance + (count if tail < head else -count))
    return edges, collapsed


def _components_oracle(faces, n_vertices):
    """Face labels (numbered by first face) and count, by union-find over shared vertices."""
    root = list(range(n_vertices))

    def find(v):
        while root[v] != v:
            root[v] = root[root[v]]
            v = root[v]
        return v

    for a, b, c in faces.tolist():
        for other in (b, c):
            root[find(other)] = find(a)
    numbers = {}
    labels = [numbers.setdefault(find(a), len(numbers)) for a in faces[:, 0].tolist()]
    return labels, len(numbers)


def _groups_oracle(faces):
    """Labels by first appearance of each vertex set, and duplicates of the same / the other winding."""
    first, labels, same, opposite = {}, [], 0, 0
    for face in faces.tolist():
        key = tuple(sorted(face))
        parity = sum(face[i] > face[j] for i in range(3) for j in range(i + 1, 3)) % 2
        if key in first:
            label, first_parity = first[key]
            degenerate = len(set(face)) < 3
            same += parity == first_parity or degenerate
            opposite += parity != first_parity and not degenerate
        else:
            first[key] = (len(first), parity)
        labels.append(first[key][0])
    return labels, same, opposite


KINDS = ["one shell", "two shells", "void", "inside-out shell", "edge-sharing boxes", "vertex-sharing tetrahedra",
         "written twice"]
FLAWS = ["none", "flipped face", "missing face", "duplicated face", "reversed duplicate", "collapsed edge"]


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from(KINDS), st.sampled_from(FLAWS))
def test_edges_shells_and_duplicates_match_their_oracles(seed, kind, flaw):
    rng = np.random.default_rng(seed)
    mesh = _scrambled(_broken(_shape(kind, rng), flaw, rng), rng)
    n, faces = mesh.vertices.shape[0], mesh.faces
    edges, collapsed = _edge_oracle(faces)
    found = edge_summary(faces, n, arrays=True)
    assert {tuple(e): (u, b) for e, u, b in zip(found.edge_vertices.tolist(), found.uses.tolist(),
                                                 found.balance.tolist())} == edges
    values = list(edges.values())
    assert (found.edges, found.boundary, found.odd, found.unbalanced, found.nonmanifold, found.collapsed) == (
        len(edges), sum(u == 1 for u, _ in values), sum(u % 2 for u, _ in values), sum(b != 0 for _, b in values),
        sum(u > 2 for u, _ in values), collapsed)
    assert found.max_uses == max(u for u, _ in values)
    unbalanced = sorted(e for e, (_, b) in edges.items() if b)
    assert found.first_unbalanced == (unbalanced[0] if unbalanced else None)
    assert edge_summary(faces, n) == type(found)(**{**found.__dict__, "edge_vertices": None, "uses": None,
                                                    "balance": None})
    labels, count = shells(faces, n)
    assert (labels.tolist(), count) == _components_oracle(faces, n)
    _assert_edge_shells(faces, n)
    groups = face_groups(faces)
    expected_labels, same, opposite = _groups_oracle(faces)
    assert groups.labels.tolist() == expected_labels
    assert (groups.same_orientation, groups.opposite_orientation) == (same, opposite)
    assert groups.first.tolist() == [expected_labels.index(k) for k in range(max(expected_labels) + 1)]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(12, 400), st.sampled_from(FLAWS))
def test_fan_centres_edges_match_the_oracle(seed, sides, flaw):
    """A prism's caps fanned from one corner: that vertex has an edge to every other of its cap (many edges
    of one vertex are grouped otherwise than a few); the flaw on a face at a fan's centre."""
    rng = np.random.default_rng(seed)
    prism = solids.regular_prism(sides, 1.0, 0.5)
    at_centre = np.flatnonzero((prism.faces == 0).any(axis=1))
    faces = prism.faces[np.roll(np.arange(prism.faces.shape[0]), -int(rng.choice(at_centre)))]

    class First:                                  # _broken's choice of face: the first, at a fan's centre
        @staticmethod
        def integers(low, high):
            return 0

    mesh = _scrambled(_broken(TriangleMesh(prism.vertices, faces), flaw, First), rng)
    n, faces = mesh.vertices.shape[0], mesh.faces
    edges, collapsed = _edge_oracle(faces)
    values = list(edges.values())
    found = edge_summary(faces, n)
    assert (found.edges, found.boundary, found.odd, found.unbalanced, found.nonmanifold, found.collapsed,
            found.max_uses) == (len(edges), sum(u == 1 for u, _ in values), sum(u % 2 for u, _ in values),
                                sum(b != 0 for _, b in values), sum(u > 2 for u, _ in values), collapsed,
                                max(u for u, _ in values))
    unbalanced = sorted(e for e, (_, b) in edges.items() if b)
    boundary = sorted(e for e, (u, _) in edges.items() if u == 1)
    assert found.first_unbalanced == (unbalanced[0] if unbalanced else None)
    assert found.first_boundary == (boundary[0] if boundary else None)
    _assert_edge_shells(faces, n)


def _assert_edge_shells(faces, n):
    """edge_shells gives edge_summary's counts and the oracle's shells (labels only when more than one)."""
    summary, labels, count = edge_shells(faces, n)
    expected_labels, expected_count = _components_oracle(faces, n)
    assert summary == edge_summary(faces, n)
    assert count == expected_count
    assert (labels.tolist() if labels is not None else None) == (expected_labels if expected_count > 1 else None)


@pytest.mark.parametrize("extra", [[[8, 8, 8]], [[8, 8, 8], [9, 9, 9]], [[0, 0, 0]], [[8, 8, 9]], [[8, 9, 9], [9, 9, 8]]])
def test_edge_shells_counts_shells_of_collapsed_faces(extra):
    """A face (a, a, a) has no edge: a shell of its own vertex is still one shell (and (a, a, b) one with an edge)."""
    cube = solids.box((1.0, 1.0, 1.0))
    _assert_edge_shells(np.concatenate([cube.faces, extra]), 11)


@pytest.mark.parametrize("dtype", [np.int32, np.int64])
@pytest.mark.parametrize("bad", [8, -1, 1000])
def test_edge_shells_refuses_the_first_face_outside_the_vertices(dtype, bad):
    cube = solids.box((1.0, 1.0, 1.0))
    faces = cube.faces.astype(dtype)
    faces[7, 2], faces[9, 0] = bad, 8
    with pytest.raises(IndexError, match=rf"^face 7 refers to vertex {bad}, but there are 8 vertices$"):
        edge_shells(faces, 8)
    with pytest.raises(MassPropsError, match="a face refers to a vertex that does not exist"):
        check_mesh(TriangleMesh(cube.vertices, faces))


def _outcome(mesh):
    try:
        return "passed", check_mesh(mesh).as_dict()
    except MassPropsError as error:
        return type(error).__name__, str(error)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from(KINDS[:-1]), st.sampled_from(FLAWS))
def test_check_mesh_outcomes(seed, kind, flaw):
    rng = np.random.default_rng(seed)
    mesh = _scrambled(_broken(_shape(kind, rng), flaw, rng), rng)
    status, found = _outcome(mesh)
    edges, _ = _edge_oracle(mesh.faces)
    if any(balance for _, balance in edges.values()):
        assert status in ("OpenMeshError", "WindingError") and "shells" not in found
        if flaw == "duplicated face":
            assert "duplicated" in found
    else:        # balanced: closed (what the shells' orientations mean is the solid's business, mesh.solid)
        assert status == "passed" and found["shells"] == _components_oracle(mesh.faces, mesh.vertices.shape[0])[1]


def test_a_body_written_twice_is_seen_as_duplicated_faces_though_its_edges_balance():
    cube = solids.box((1.0, 1.0, 1.0))
    twice = np.concatenate([cube.faces, cube.faces])
    assert edge_summary(twice, 8).balanced
    groups = face_groups(twice)
    assert (groups.same_orientation, groups.opposite_orientation, groups.first.size) == (12, 0, 12)


def _two_spheres():
    a = solids.icosphere(6, 1.0)                      # 81,920 faces each: many blocks and threads
    b = solids.icosphere(6, 0.5)
    return solids.combine(a, TriangleMesh(b.vertices + 5.0, b.faces))


def test_large_mesh_checks_and_thread_count(monkeypatch):
    mesh = _two_spheres()
    n, half = mesh.vertices.shape[0], mesh.faces.shape[0] // 2
    found = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("MASSPROPS_THREADS", threads)
        faces = mesh.faces.copy()
        faces[12345] = faces[12345, ::-1]
        found[threads] = (check_mesh(mesh).as_dict(), edge_summary(faces, n), shells(mesh.faces, n)[1])
        _assert_edge_shells(faces, n)
    assert found["1"] == found["2"]
    checks, flipped, count = found["1"]
    assert checks["shells"] == count == 2 and flipped.unbalanced == 3 and flipped.odd == 0
    labels, _ = shells(mesh.faces, n)
    assert set(labels[:half].tolist()) == {0} and set(labels[half:].tolist()) == {1}


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_welding_on_several_threads_numbers_vertices_as_one_thread_does(monkeypatch, tmp_path, dtype):
    """Large enough to be split among threads: the same vertices, numbered by first appearance."""
    from massprops.io import read
    from massprops.io.stl import write_binary
    rng = np.random.default_rng(11)
    pool = rng.normal(size=(30_000, 3)).astype(dtype)
    corners = pool[rng.integers(0, pool.shape[0], size=(110_000, 3))]       # 330,000 points: split among threads
    expected = _weld_oracle(corners)
    path = tmp_path / "soup.stl"
    write_binary(path, corners)
    for threads in ("1", "2", "3"):
        monkeypatch.setenv("MASSPROPS_THREADS", threads)
        vertices, faces = weld_corners(corners)
        assert faces.ravel().tolist() == expected, threads
        assert np.array_equal(vertices[faces], corners.astype(np.float64))
        if dtype == np.float32:
            mesh = read(path)
            assert mesh.faces.ravel().tolist() == expected and np.array_equal(mesh.vertices, vertices)


def test_welding_a_mesh_whose_faces_fill_32_mib_numbers_vertices_by_first_appearance(monkeypatch):
    """From 32 MiB of faces (1.4M triangles) a second thread faults the weld's arrays in meanwhile."""
    rng = np.random.default_rng(24)
    pool = np.unique(rng.normal(size=(400_000, 3)).astype(np.float32), axis=0)
    chosen = rng.integers(0, pool.shape[0], size=3 * 1_400_000)
    _, first = np.unique(chosen, return_index=True)              # each pool point's first corner
    label = np.empty(pool.shape[0], dtype=np.int64)
    label[chosen[np.sort(first)]] = np.arange(first.size)        # numbered in order of first appearance
    corners = pool[chosen]
    for threads in ("1", "2"):
        monkeypatch.setenv("MASSPROPS_THREADS", threads)
        vertices, faces = weld_corners(corners)
        assert np.array_equal(faces.ravel(), label[chosen]), threads
        assert np.array_equal(vertices, pool[chosen[np.sort(first)]].astype(np.float64)), threads
