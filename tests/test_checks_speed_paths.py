"""The fast paths of the weld and the mesh checks give exactly what the general paths give.

- table rounds finished by a stable sort against the rounds alone, and
  against the first occurrence of each hash;
- the float32 point hash: welding by it against a dictionary of coordinate
  bits, and against the exact fallback that compares full keys;
- the edge grouping in one block, in many blocks with the hashes kept, and in
  many blocks with them recomputed: the same representatives;
- the shells (faces joined by shared vertices) against a union-find, with
  one block and with many;
- and through all of these paths
  ``check_mesh`` with the same outcome (message included) on closed,
  multi-shell, non-manifold closed, open, miswound, duplicated-face and
  inside-out meshes, each judged against a count of directed edges.
"""

from collections import Counter
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.compute import mass_properties
from massprops.core import grouping, topology
from massprops.validation import solids
from massprops.errors import MassPropsError, WindingError
from massprops.mesh.surface import TriangleMesh, check_mesh
from massprops.core.topology import _edge_representatives, face_components

# Every way the edge grouping and the shells can run (block sizes, kept-hash and sort limits).
_PATHS = {
    "default": {},
    "blocks, hashes kept": {"_FACE_BLOCK": 3},
    "blocks, hashes recomputed": {"_FACE_BLOCK": 3, "_KEEP_EDGE_HASHES_UP_TO": 0},
    "small hooking blocks": {"_SMALL_HOOK_BLOCK": 2},
    "table rounds only": {"_SORT_UP_TO": 0},
    "sort only": {"_SORT_UP_TO": 1 << 40},
}


@contextmanager
def _path(settings_):
    with pytest.MonkeyPatch.context() as patch:
        for name, value in settings_.items():
            patch.setattr(grouping if name == "_SORT_UP_TO" else topology, name, value)
        yield


# --- table rounds and their sort finish --------------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(1, 6000), st.integers(1, 4000))
def test_table_rounds_sort_finish_matches_rounds_and_first_occurrence(seed, rows, distinct):
    rng = np.random.default_rng(seed)
    values = rng.integers(0, distinct, rows).astype(np.uint64)
    h = grouping.mix(values.copy())         # a bijection: equal hashes exactly when equal values
    first = {}
    expected = np.array([first.setdefault(v, i) for i, v in enumerate(values.tolist())])
    for limit in (0, grouping._SORT_UP_TO, 1 << 40):
        with _path({"_SORT_UP_TO": limit}):
            assert np.array_equal(grouping.table_rounds(h.copy()), expected)
            offset_rows = np.arange(rows, dtype=np.intp) * 3 + 7
            assert np.array_equal(grouping.table_rounds(h.copy(), offset_rows), offset_rows[expected])


# --- the float32 weld ---------------------------------------------------------------------------

def _weld_oracle(corners):
    seen = {}
    return [seen.setdefault(row, len(seen)) for row in map(bytes, corners.view(np.uint8).reshape(len(corners), -1))]


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from(["grid", "ulps", "wide", "signs"]),
       st.integers(1, 40_000))
def test_float32_weld_matches_coordinate_bits(seed, kind, count):
    rng = np.random.default_rng(seed)
    pool = {"grid": np.arange(-20, 20, dtype=np.float32),
            "ulps": np.float32(1.0) + np.arange(40, dtype=np.float32) * np.finfo(np.float32).eps,
            "wide": rng.standard_normal(30).astype(np.float32) * np.float32(1e6),
            "signs": np.array([0.0, -0.0, 1.0, -1.0, 1e-38, -1e-38, 3e38], dtype=np.float32)}[kind]
    corners = np.add(pool[rng.integers(0, pool.size, (3 * count, 3))], np.float32(0.0))
    expected = _weld_oracle(corners)
    welded = TriangleMesh.from_corners(corners.copy())
    assert welded.faces.ravel().tolist() == expected
    assert np.array_equal(welded.vertices[welded.faces].reshape(-1, 3), corners.astype(np.float64))
    with pytest.MonkeyPatch.context() as patch:
        # Every point one hash: the table rounds see a collision and the full-key fallback decides.
        patch.setattr(grouping, "_hash_float32_points", lambda bits: np.zeros(bits.shape[0], dtype=np.uint64))
        assert TriangleMesh.from_corners(corners.copy()).faces.ravel().tolist() == expected


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
    shells = [solids.icosphere(int(rng.integers(0, 3)), 1.0)]
    if kind in ("two shells", "inside-out shell", "void"):
        inner = solids.box((0.5, 0.5, 0.5)) if kind == "void" else solids.cube(1.0, center=(5.0, 0.0, 0.0))
        shells.append(inner.flipped() if kind != "two shells" else inner)
    if kind == "vertex-sharing tetrahedra":
        # Joined at one vertex only: one shell, as shells are counted by shared vertices.
        a = solids.tetrahedron()
        return TriangleMesh.from_triangles(np.concatenate([a.triangles, a.triangles + [1.0, 0.0, 0.0]]))
    if kind == "edge-sharing boxes":
        # Two boxes welded along one box edge: that edge is used four times, closed but not manifold.
        a, b = solids.box((1.0, 1.0, 1.0), (0.5, 0.5, 0.5)), solids.box((1.0, 1.0, 1.0), (1.5, 1.5, 0.5))
        return TriangleMesh.from_triangles(np.concatenate([a.triangles, b.triangles]))
    return solids.combine(*shells)


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
    elif flaw == "collapsed edge":
        faces = np.concatenate([faces, [[faces[k, 0], faces[k, 0], faces[k, 1]]]])
    return TriangleMesh(mesh.vertices, faces)


def _balanced(faces):
    """Every directed edge matched by a reverse edge, with multiplicity (the oracle)."""
    directed = Counter(zip(faces.ravel().tolist(), np.roll(faces, -1, axis=1).ravel().tolist()))
    return all(directed[(b, a)] == uses for (a, b), uses in directed.items())


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


def _outcome(mesh):
    try:
        return "passed", check_mesh(mesh).as_dict()
    except MassPropsError as error:
        return type(error).__name__, str(error)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1),
       st.sampled_from(["one shell", "two shells", "void", "inside-out shell", "edge-sharing boxes",
                        "vertex-sharing tetrahedra"]),
       st.sampled_from(["none", "flipped face", "missing face", "duplicated face", "collapsed edge"]))
def test_every_edge_path_gives_the_same_checks(seed, kind, flaw):
    rng = np.random.default_rng(seed)
    mesh = _scrambled(_broken(_shape(kind, rng), flaw, rng), rng)
    n = mesh.vertices.shape[0]
    results = {}
    for name, settings_ in _PATHS.items():
        with _path(settings_):
            representative, direction = _edge_representatives(mesh.faces, n)
            labels, count = face_components(mesh.faces, n)
            results[name] = (representative.tolist(), direction.tolist(), _outcome(mesh))
        assert (labels.tolist(), count) == _components_oracle(mesh.faces, n), name
    assert all(result == results["default"] for result in results.values()), kind
    status, found = results["default"][2]
    if not _balanced(mesh.faces):
        assert status in ("OpenMeshError", "WindingError") and "shells" not in found
    elif kind == "inside-out shell":
        # Closed and consistently wound: the refusal is the solid's (which shells bound {w > 0}).
        assert status == "passed" and found["shells"] == 2
        with pytest.raises(WindingError, match="shells are wound inward"):
            mass_properties(mesh)
    else:
        assert status == "passed" and found["shells"] == _components_oracle(mesh.faces, n)[1]
        assert found["shells"] == (2 if kind in ("two shells", "void") else 1)
    if flaw == "duplicated face":
        assert "duplicated" in found


def test_representatives_are_first_edges_of_each_undirected_edge():
    rng = np.random.default_rng(5)
    mesh = _scrambled(solids.combine(solids.icosphere(3, 1.0), solids.cube(1.0, center=(4.0, 0.0, 0.0))), rng)
    tails, heads = mesh.faces.ravel(), np.roll(mesh.faces, -1, axis=1).ravel()
    first = {}
    expected = [first.setdefault(frozenset((t, h)), i) for i, (t, h) in enumerate(zip(tails.tolist(), heads.tolist()))]
    for settings_ in _PATHS.values():
        with _path(settings_):
            representative, direction = _edge_representatives(mesh.faces, mesh.vertices.shape[0])
        assert representative.tolist() == expected
        assert direction.tolist() == np.sign(heads - tails).tolist()
