"""What the solid's checks cost (issue 14): the check between shells on a one-shell mesh, and the
self-intersection check within a shell, against the end-to-end time of ``massprops props``.

Measured:

- end to end, ``massprops props --format json`` in a fresh process, with
  ``--self-intersection`` and with ``--no-self-intersection``, on tori of
  10k to 300k triangles and on the 1.31M-triangle icosphere (runs
  interleaved, best of several): the self-intersection check's share, which
  sets the face count up to which it runs by default
  (:data:`massprops.mesh.solid.SELF_INTERSECTION_UP_TO`);
- in process, on the icosphere, each step the solid adds to a one-shell mesh:
  the unused-vertex test, the between-shell decision (one shell: nothing to
  compare) and, for reference, the self-intersection search alone.
"""

from __future__ import annotations

import sys
import time

from bench_props import icosphere_stl, measure, torus_stl

SIZES = (10_000, 30_000, 100_000, 200_000, 300_000)


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
        "self-intersection search": lambda: ExactGeometry(mesh.vertices).intersections(
            mesh.faces, labels, 1, within=True, between=False),
    }
    best = {}
    for name, step in steps.items():
        best[name] = float("inf")
        for _ in range(repeats):
            begin = time.perf_counter()
            step()
            best[name] = min(best[name], time.perf_counter() - begin)
    return best


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
    return "\n".join(rows)
