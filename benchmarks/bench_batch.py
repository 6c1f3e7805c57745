"""`massprops batch` throughput on many small parts, against a Python loop over trimesh.

The corpus: 2,000 closed parts (quick: 200) of 1k–10k triangles, half binary
STL, half OBJ, written once under ``benchmarks/_data/batch/``.  Measured:

- files/s of ``run_batch`` (the code behind ``massprops batch``) with 1 and 2
  worker processes, pool start-up and report writing included;
- files/s of ``for f in files: trimesh.load(f).mass_properties``, and of
  the same loop spread over two worker processes;
- per-file overhead of the batch machinery: wall time of the one-worker run
  minus the summed per-file ``elapsed_s`` of its report, over the file count;
- the processor time of each run (its own and its worker processes'), which
  the other jobs on a shared machine change far less than the wall time: on
  free cores, two workers take about half of it.

Speed is measured, never asserted; the machine is shared, so take the ratios
as indicative.
"""

from __future__ import annotations

import csv
import os
import time

import numpy as np

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_data", "batch")


def _part(rng):
    """A closed mesh of 1k–10k triangles: a perturbed icosphere or a prism, off the axes."""
    from massprops.validation import solids
    from massprops.model.frames import Pose
    if rng.random() < 0.5:
        sphere = solids.icosphere(int(rng.integers(3, 5)), float(rng.uniform(0.5, 2.0)))
        # a radial bump per vertex keeps the surface closed and star-shaped but not a sphere
        bumped = sphere.vertices * rng.uniform(0.9, 1.1, size=(len(sphere.vertices), 1))
        mesh = type(sphere)(bumped, sphere.faces)
    else:
        mesh = solids.regular_prism(int(rng.integers(251, 2500)), float(rng.uniform(0.5, 2.0)),
                                    float(rng.uniform(0.2, 3.0)))
    pose = Pose.from_quat(rng.normal(size=4), translation=rng.uniform(-5, 5, size=3))
    return mesh.transformed(pose.rotation, pose.translation)


def _write_obj(path, mesh):
    with open(path, "w") as f:
        np.savetxt(f, mesh.vertices, fmt="v %.17g %.17g %.17g")
        np.savetxt(f, mesh.faces + 1, fmt="f %d %d %d")


def corpus(count):
    """Paths of ``count`` parts (made once, then reused), alternating binary STL and OBJ."""
    from massprops.io.stl import write_binary
    os.makedirs(DATA, exist_ok=True)
    paths = []
    for k in range(count):
        path = os.path.join(DATA, f"part{k:05d}.{'stl' if k % 2 == 0 else 'obj'}")
        if not os.path.exists(path):
            mesh = _part(np.random.default_rng(k))
            write_binary(path, mesh.triangles) if path.endswith(".stl") else _write_obj(path, mesh)
        paths.append(path)
    return paths


def _cpu():
    """Processor seconds (user and system) of this process and of its children that have ended."""
    import resource
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _trimesh_loop(paths):
    """Wall time of the loop, and seconds per file."""
    import trimesh
    per_file = {}
    start = time.perf_counter()
    for path in paths:
        t0 = time.perf_counter()
        trimesh.load(path).mass_properties
        per_file[path] = time.perf_counter() - t0
    return time.perf_counter() - start, per_file


def _trimesh_one(path):
    import trimesh
    trimesh.load(path).mass_properties
    return path


def _trimesh_pool(paths, workers):
    """Wall time of the same trimesh loop spread over ``workers`` processes (pool start-up included)."""
    from concurrent.futures import ProcessPoolExecutor
    start = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool:
        list(pool.map(_trimesh_one, paths, chunksize=16))
    return time.perf_counter() - start


def _ms_by_format(per_file):
    """Mean milliseconds per file for each extension."""
    by_ext = {}
    for path, seconds in per_file.items():
        by_ext.setdefault(os.path.splitext(path)[1], []).append(seconds)
    return {ext: 1e3 * sum(v) / len(v) for ext, v in sorted(by_ext.items())}


def _batch(paths, jobs, output):
    from massprops.batch.run import run_batch
    start = time.perf_counter()
    summary = run_batch(paths, output=output, jobs=jobs)
    wall = time.perf_counter() - start
    with open(output, newline="") as f:
        rows = list(csv.DictReader(f))
    per_file = {r["file"]: float(r["elapsed_s"]) for r in rows if r["status"] == "ok"}
    triangles = {r["file"]: int(r["triangles"]) for r in rows if r["status"] == "ok"}
    return wall, per_file, summary, triangles


def _fixed_ms(per_file, triangles):
    """Fixed cost per file (ms) and cost per triangle (ns): a least-squares line through each file's elapsed_s."""
    files = sorted(per_file)
    slope, intercept = np.polyfit([triangles[f] for f in files], [per_file[f] for f in files], 1)
    return 1e3 * intercept, 1e9 * slope


def run(quick: bool = False) -> str:
    count = 200 if quick else 2000
    paths = corpus(count)
    report = os.path.join(DATA, "report.csv")
    import trimesh  # noqa: F401  (imported before the clocks start: the loop's time is its files')
    cpu = [_cpu()]
    trimesh_s, trimesh_files = _trimesh_loop(paths)
    cpu.append(_cpu())
    trimesh2_s = _trimesh_pool(paths, 2)
    cpu.append(_cpu())
    wall1, batch_files, summary1, triangles = _batch(paths, 1, report)
    cpu.append(_cpu())
    compute1 = sum(batch_files.values())
    wall2, _, summary2, _ = _batch(paths, 2, report)
    cpu.append(_cpu())
    if summary1.failed or summary2.failed:
        return f"batch failed on {summary1.failed} files — check {report}"
    runs = {"trimesh loop": trimesh_s, "trimesh, 2 worker processes": trimesh2_s, "massprops batch, 1 worker": wall1,
            "massprops batch, 2 workers": wall2}
    used = dict(zip(runs, (b - a for a, b in zip(cpu, cpu[1:]))))         # processor seconds of each run
    lines = [f"**batch** — {count} parts, 1k–10k triangles, binary STL + OBJ ({os.cpu_count()} cores, load "
             f"average {os.getloadavg()[0]:.1f} at the end)", "",
             "| run | time (s) | files/s | vs trimesh loop | vs trimesh, 2 workers | processor s | vs trimesh loop |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name, seconds in runs.items():
        lines.append(f"| {name} | {seconds:.2f} | {count / seconds:.0f} | {trimesh_s / seconds:.2f}× "
                     f"| {trimesh2_s / seconds:.2f}× | {used[name]:.2f} | {used['trimesh loop'] / used[name]:.2f}× |")
    lines += ["", f"Per-file batch overhead (1 worker, wall − Σ elapsed_s): "
                  f"{1e3 * (wall1 - compute1) / count:.2f} ms; per-file compute {1e3 * compute1 / count:.2f} ms; "
                  f"speedup 1 → 2 workers: {wall1 / wall2:.2f}×", "",
              "Fixed cost per file (1 worker): {:.2f} ms computing (the intercept of elapsed_s against the file's "
              "triangles, {:.0f} ns per triangle) + {:.2f} ms of batch machinery = {:.2f} ms.".format(
                  *_fixed_ms(batch_files, triangles), 1e3 * (wall1 - compute1) / count,
                  _fixed_ms(batch_files, triangles)[0] + 1e3 * (wall1 - compute1) / count), "",
              "| format | massprops ms/file (elapsed_s) | trimesh.load + mass_properties ms/file |",
              "| --- | ---: | ---: |"]
    ours, theirs = _ms_by_format(batch_files), _ms_by_format(trimesh_files)
    lines += [f"| {ext} | {ours[ext]:.2f} | {theirs[ext]:.2f} |" for ext in ours]
    return "\n".join(lines)


if __name__ == "__main__":
    import sys
    print(run(quick="--quick" in sys.argv))
