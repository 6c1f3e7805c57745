"""What the solid's checks cost: the search for meeting faces on meshes where none meet, and the exact
arrangement on meshes where faces cross, against plain integration and the peers.

Measured:

- end to end, ``massprops props --format json`` in a fresh process, with
  ``--self-intersection`` and with ``--no-self-intersection``, on tori of
  10k to 300k triangles and on the 1.31M-triangle icosphere (runs
  interleaved, best of several): the check's share (it runs by default at
  every size);
- in process, on the icosphere, each step the solid adds to a one-shell mesh:
  the unused-vertex test, the between-shell decision (one shell: nothing to
  compare) and, for reference, the self-intersection search alone;
- in process, on two overlapping icospheres (one soup) and an icosphere with
  a dent pushed through its other side: ``mass_properties`` with the
  arrangement against the plain signed integral of the same faces, and
  against libigl's CGAL union and trueform's arrangement where installed
  (peers for the benchmark only, never dependencies).
"""

from __future__ import annotations

import sys
import time

from bench_props import icosphere_stl, measure, torus_stl

SIZES = (10_000, 30_000, 100_000, 200_000, 300_000, 1_200_000)


def _end_to_end(path, repeats):
    """Best wall seconds with the self-intersection check forced on and off, runs interleaved."""
    best = {"on": float("inf"), "off": float("inf")}
    for _ in range(repeats):
        for key, flag in (("on", "--self-intersection"), ("off", "--no-self-intersection")):
            wall, _ = measure([sys.executable, "-m", "massprops", "props", "--format", "json", flag, path])
            best[key] = min(best[key], wall)
    return best


def _in_process(path, repeats):
    import numpy as np
    from massprops.core.intersect import ExactGeometry
    from massprops.io import read
    from massprops.mesh.shells import resolve_shells
    from massprops.mesh.solid import without_unused_vertices
    mesh = read(path)
    labels = np.zeros(mesh.faces.shape[0], dtype=np.int64)
    steps = {
        "unused-vertex test": lambda: without_unused_vertices(mesh),
        "between shells (one shell)": lambda: resolve_shells(mesh, labels, 1, check_self=False),
        # closed: the file's surface is closed, as resolve_shells tells the search after its checks
        "self-intersection search": lambda: ExactGeometry(mesh.vertices).intersections(
            mesh.faces, labels, 1, within=True, between=False, closed=True),
    }
    best = {}
    for name, step in steps.items():
        best[name] = float("inf")
        for _ in range(repeats):
            begin = time.perf_counter()
            step()
            best[name] = min(best[name], time.perf_counter() - begin)
    return best


def _overlapping_icospheres(subdivisions, apart=False):
    import numpy as np
    from massprops.validation import solids
    a = solids.icosphere(subdivisions, 1.0)
    b = solids.icosphere(subdivisions, 1.0)
    b = type(b)(b.vertices + np.array([3.0 if apart else 0.9, 0.31, 0.17]), b.faces)
    return solids.combine(a, b)


def _dented(subdivisions):
    import numpy as np
    from massprops.validation import solids
    sphere = solids.icosphere(subdivisions, 1.0)
    vertices = sphere.vertices.copy()
    vertices[int(np.argmax(vertices[:, 2]))] = [0.0, 0.0, -1.5]
    return type(sphere)(vertices, sphere.faces)


def _best(step, budget=0.5):
    """Best of as many calls as ``budget`` seconds hold (at least three, at most 100): every tool the same."""
    best, spent, calls = float("inf"), 0.0, 0
    while calls < 3 or (spent < budget and calls < 100):
        begin = time.perf_counter()
        step()
        took = time.perf_counter() - begin
        best, spent, calls = min(best, took), spent + took, calls + 1
    return best


def _peers(mesh):
    """Seconds of libigl's CGAL self-union and trueform's arrangement on the same soup, where installed."""
    import numpy as np
    out = {}
    try:
        import igl.copyleft.cgal as cgal
        v, f = np.ascontiguousarray(mesh.vertices), np.ascontiguousarray(mesh.faces, dtype=np.int64)
        empty_v, empty_f = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
        out["libigl CGAL union"] = _best(lambda: cgal.mesh_boolean(v, f, empty_v, empty_f, "union"))
    except Exception:                                            # noqa: BLE001 - a peer that is missing or fails
        pass
    try:
        import trueform as tf
        soup = tf.Mesh(np.ascontiguousarray(mesh.faces, dtype=np.int32), np.ascontiguousarray(mesh.vertices))
        # mesh_arrangements takes two meshes or more: the soup (cut against itself, within=True) and a
        # tetrahedron far away that meets nothing.  It splits faces; it does not label the solid.
        far = tf.Mesh(np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int32),
                      np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
                      + 10.0 * (1.0 + np.abs(mesh.vertices).max()))
        out["trueform arrangement"] = _best(lambda: tf.mesh_arrangements([soup, far], within=True))
    except Exception:                                            # noqa: BLE001
        pass
    return out


def arrangement_rows(quick=False):
    """Whole ``mass_properties`` on soups whose faces cross, against the same faces with nothing to resolve.

    "Plain" is ``mass_properties`` on the same number of faces where nothing
    crosses (every check still on): the two icospheres moved apart, and the
    dented icosphere with the self-intersection search off (its signed integral).
    """
    from massprops import mass_properties
    rows = ["| soup | triangles | plain `mass_properties` (s) | resolved (s) | resolved / plain | libigl CGAL union (s) "
            "| libigl / massprops | trueform arrangement (s) | massprops / trueform |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    levels = (3, 4) if quick else (3, 4, 5, 6)
    for name, build in (("two overlapping icospheres", _overlapping_icospheres), ("dented icosphere", _dented)):
        for level in levels:
            mesh = build(level)
            if name == "dented icosphere":
                plain = _best(lambda: mass_properties(mesh, self_intersection=False))
            else:
                apart = build(level, apart=True)
                plain = _best(lambda: mass_properties(apart))
            solved = _best(lambda: mass_properties(mesh))
            peers = _peers(mesh)
            igl, tf = peers.get("libigl CGAL union"), peers.get("trueform arrangement")
            rows.append(f"| {name} | {mesh.faces.shape[0]:,} | {plain:.4f} | {solved:.4f} | {solved / plain:.1f}x | "
                        + (f"{igl:.3f} | {igl / solved:.1f}x | " if igl else "not installed | | ")
                        + (f"{tf:.3f} | {solved / tf:.1f}x |" if tf else "not installed | |"))
    return "\n".join(rows)


def run(quick=False):
    repeats = 2 if quick else 4
    cases = [torus_stl(n) for n in (SIZES[:2] if quick else SIZES)]
    cases.append((icosphere_stl(), 1_310_720))
    rows = ["| mesh | triangles | end to end, check off (s) | check on (s) | check's share |",
            "|---|---:|---:|---:|---:|"]
    for path, triangles in cases:
        best = _end_to_end(path, repeats)
        share = (best["on"] - best["off"]) / best["on"]
        name = "icosphere(8)" if "icosphere" in path else "torus"
        rows.append(f"| {name} | {triangles:,} | {best['off']:.3f} | {best['on']:.3f} | {share:.0%} |")
    steps = _in_process(icosphere_stl(), repeats)
    off = _end_to_end(icosphere_stl(), repeats)["off"]
    rows += ["", "| on the 1.31M-triangle icosphere, in process | seconds | share of end to end (check off) |",
             "|---|---:|---:|"]
    rows += [f"| {name} | {seconds:.4f} | {seconds / off:.1%} |" for name, seconds in steps.items()]
    rows += ["", arrangement_rows(quick)]
    return "\n".join(rows)
