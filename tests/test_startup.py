"""Start-up stays light, and the fast paths stay exact.

1. ``massprops props`` on a small binary STL imports none of the heavy optional
   packages (checked in a fresh interpreter, through click's CliRunner).
2. The machinery that makes large meshes fast — hash-table grouping, the
   weld on float32 bit patterns, the edge and shell checks, the threaded,
   chunked integration kernel — gives exactly what the plain definitions give.
"""

import json
import os
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.core import grouping, integrate
from massprops.validation import solids
from massprops.io.stl import write_binary
from massprops.mesh.surface import TriangleMesh, check_mesh, group_ids
from massprops.core.topology import edge_balance, face_components

HEAVY = ("trimesh", "scipy", "meshio", "matplotlib", "dask")

PROBE = """
import json, sys
from click.testing import CliRunner
import massprops.cli
result = CliRunner().invoke(massprops.cli.main, ["props", "--format", "json", sys.argv[1]])
print(json.dumps({"exit": result.exit_code, "output": result.output,
                  "heavy": sorted(m for m in %r if m in sys.modules)}))
""" % (HEAVY,)


def _probe(path):
    done = subprocess.run([sys.executable, "-c", PROBE, str(path)], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def test_props_on_a_binary_stl_imports_no_heavy_package(tmp_path):
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0), (0.5, 0.5, 0.5)).triangles)
    probe = _probe(path)
    assert probe["exit"] == 0, probe["output"]
    assert json.loads(probe["output"])[0]["volume"] == 6.0
    assert probe["heavy"] == []


def test_a_bad_binary_stl_also_fails_without_heavy_imports(tmp_path):
    path = tmp_path / "open.stl"
    write_binary(path, solids.box((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)).triangles[:-1])
    probe = _probe(path)
    assert probe["exit"] == 1
    assert "open" in probe["output"]
    assert probe["heavy"] == []


# --- grouping: exact against a dictionary of tuples -------------------------------------------

def _oracle_groups(rows):
    labels, first, seen = [], [], {}
    for i, row in enumerate(map(tuple, rows)):
        if row not in seen:
            seen[row] = len(first)
            first.append(i)
        labels.append(seen[row])
    return labels, first


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.integers(0, 5), min_size=2, max_size=2), max_size=300))
def test_group_ids_matches_a_dictionary(rows):
    keys = np.array(rows, dtype=np.uint64).reshape(-1, 2)
    labels, first = group_ids(keys)
    assert (labels.tolist(), first.tolist()) == _oracle_groups(rows)


def test_group_ids_stays_exact_when_every_hash_collides(monkeypatch):
    rng = np.random.default_rng(7)
    keys = rng.integers(0, 4, size=(5000, 3)).astype(np.uint64)
    monkeypatch.setattr(grouping, "_hash_columns", lambda columns, salt=0: np.full(len(columns[0]), salt,
                                                                                  dtype=np.uint64))
    labels, first = group_ids(keys)
    assert (labels.tolist(), first.tolist()) == _oracle_groups(keys.tolist())


def test_group_ids_across_blocks():
    rng = np.random.default_rng(1)
    n = 3 * grouping._BLOCK + 123              # several first-pass blocks
    keys = rng.integers(0, 40_000, size=(n, 1)).astype(np.uint64)
    labels, first = group_ids(keys)
    assert (labels.tolist(), first.tolist()) == _oracle_groups(keys.tolist())


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_weld_merges_equal_coordinates_only(dtype):
    rng = np.random.default_rng(3)
    values = np.array([0.0, -0.0, 1.5, 1.5 + 2.0 ** -20, -3.0, 1e-30], dtype=dtype)
    triangles = values[rng.integers(0, values.size, size=(2000, 3, 3))]
    mesh = TriangleMesh.from_triangles(triangles)
    assert np.array_equal(mesh.vertices[mesh.faces], triangles.astype(np.float64))
    distinct = {tuple(p) for p in (triangles.reshape(-1, 3).astype(np.float64) + 0.0).tolist()}
    assert mesh.vertices.shape[0] == len(distinct)


# --- checks on a large mesh (the threaded, hashed paths) ---------------------------------------

def _two_spheres():
    a = solids.icosphere(6, 1.0)                      # 81,920 faces each
    b = solids.icosphere(6, 0.5)
    b = TriangleMesh(b.vertices + 5.0, b.faces)
    return solids.combine(a, b)


def test_large_mesh_checks_count_shells_and_find_a_flipped_face():
    mesh = _two_spheres()
    checks = check_mesh(mesh)
    assert checks.closed and checks.shells == 2
    labels, count = face_components(mesh.faces, mesh.vertices.shape[0])
    half = mesh.faces.shape[0] // 2
    assert count == 2 and len(set(labels[:half])) == 1 and set(labels[:half]).isdisjoint(labels[half:])
    faces = mesh.faces.copy()
    faces[12345] = faces[12345, ::-1]
    uses, balance = edge_balance(faces, mesh.vertices.shape[0])
    assert np.count_nonzero(balance) == 3 and np.all(uses % 2 == 0)


def test_integration_does_not_depend_on_threads(monkeypatch):
    mesh = _two_spheres()
    by_chunk = []
    for chunk in (1 << 13, 1000):
        results = []
        for threads in ("1", "2"):
            monkeypatch.setenv("MASSPROPS_THREADS", threads)
            results.append(integrate.integrate(mesh.vertices, mesh.faces, chunk=chunk))
        one, two = results
        assert (one.det_sum, one.det_error, one.area2) == (two.det_sum, two.det_error, two.area2)
        assert np.array_equal(one.first, two.first) and np.array_equal(one.second, two.second)
        by_chunk.append(one)
    # Other chunks round differently, but within the stated bounds of each other.
    big, small = by_chunk
    assert abs(big.det_sum - small.det_sum) <= big.det_error + small.det_error
    assert np.abs(big.second - small.second).max() <= big.second_error + small.second_error


def test_kernel_second_moment_within_its_bound_of_exact():
    mesh = solids.tetrahedron([(0.1, 0.2, 0.3), (1.7, 0.1, 0.2), (0.4, 1.3, 0.1), (0.3, 0.5, 2.1)])
    moments = integrate.integrate(mesh.vertices, mesh.faces)
    scale = Fraction(2) ** -moments.scale_exp
    points = [[(Fraction(float(x)) - Fraction(float(r))) * scale for x, r in zip(p, moments.reference)]
              for p in mesh.vertices]
    exact = [[Fraction(0)] * 3 for _ in range(3)]
    for face in mesh.faces:
        a, b, c = (points[k] for k in face)
        det = (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
               + a[2] * (b[0] * c[1] - b[1] * c[0]))
        s = [a[i] + b[i] + c[i] for i in range(3)]
        for i in range(3):
            for j in range(3):
                exact[i][j] += det * (s[i] * s[j] + a[i] * a[j] + b[i] * b[j] + c[i] * c[j])
    error = max(abs(Fraction(float(moments.second[i, j])) - exact[i][j]) for i in range(3) for j in range(3))
    assert error <= Fraction(moments.second_error)
    assert moments.second[0, 1] != 0.0             # asymmetric: products of inertia are exercised


def test_thread_count_follows_the_environment(monkeypatch):
    from massprops.core.parallel import thread_count
    monkeypatch.setenv("MASSPROPS_THREADS", "1")
    assert thread_count() == 1
    monkeypatch.delenv("MASSPROPS_THREADS")
    assert thread_count() >= 1
    assert os.environ.get("MASSPROPS_THREADS") is None
