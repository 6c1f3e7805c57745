"""`massprops props` against trimesh on large meshes: wall time, peak memory, kernel, startup, scaling.

Meshes (binary STL, written once under ``benchmarks/_data/props/``):

- ``icosphere8.stl``: ``trimesh.creation.icosphere(subdivisions=8)``
  (1,310,720 triangles), translated to (100, -50, 25), away from the origin;
- tori of 10k ... 10M triangles for the scaling table (quick: up to 1.3M).

Measured, each the best of a few runs (the machine is shared):

- end to end: ``massprops props --format json F`` against
  ``python -c "import trimesh; trimesh.load(F).mass_properties"``, each a fresh
  process; wall time and peak RSS (``wait4``'s ``ru_maxrss``);
- peers (:mod:`peers`): MuJoCo (MjSpec compile, exact mesh inertia),
  pymeshlab, numpy-stl and meshlib (volume only), each a fresh process on
  the same file, "not installed" where their package is missing;
- kernel: ``massprops.core.integrate`` against
  ``trimesh.triangles.mass_properties`` on the same triangles, ns/triangle,
  next to the memory-read floor (one pass summing the float64 triangles)
  and meshlib's volume-only time on the same mesh;
- threads: the same with ``MASSPROPS_THREADS=1`` and with every core;
- read and weld: ``massprops.core.read_stl`` on the binary STLs and ``read_obj`` on the 1M torus
  written as OBJ, 1 and 2 threads, in process;
- startup: ``massprops props`` on a 12-triangle box against ``python -c "import numpy"`` (and the same
  with one BLAS thread, which the ``massprops`` script asks for before numpy loads), and the same pair
  with massprops installed from a wheel built from this tree (what users run), in a virtualenv over
  this interpreter.

Speed is measured here, never asserted in tests.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))      # peers.py beside this file

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "_data", "props")
OFFSET = (100.0, -50.0, 25.0)
MIB = 1024.0 * 1024.0
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "BLIS_NUM_THREADS")


def _path(name):
    os.makedirs(DATA, exist_ok=True)
    return os.path.join(DATA, name)


def icosphere_stl():
    """The 1.31M-triangle icosphere of the issue, translated off the origin (written once)."""
    path = _path("icosphere8.stl")
    if not os.path.exists(path):
        import trimesh
        from massprops.io.stl import write_binary
        sphere = trimesh.creation.icosphere(subdivisions=8)
        write_binary(path, sphere.vertices[sphere.faces] + np.array(OFFSET))
    return path


def torus_stl(triangles):
    """A torus (radii 2 and 0.5) of about ``triangles`` triangles, off the origin (written once).

    Written in slabs of rings so that even 10M triangles need little memory.
    """
    rings = max(8, int(round(np.sqrt(triangles / 2.0))))
    sides = max(8, int(round(triangles / (2.0 * rings))))
    path = _path(f"torus_{2 * rings * sides}.stl")
    if os.path.exists(path):
        return path, 2 * rings * sides
    from massprops.io.stl import _RECORD
    u = np.linspace(0.0, 2 * np.pi, rings, endpoint=False)
    v = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    with open(path + ".part", "wb") as f:
        f.write(b"massprops benchmark torus".ljust(80, b" "))
        f.write(np.uint32(2 * rings * sides).tobytes())
        for start in range(0, rings, max(1, 500_000 // sides)):
            i = np.arange(start, min(rings, start + max(1, 500_000 // sides)))
            records = np.zeros((i.size, sides, 2), dtype=_RECORD)
            corners = [_torus_point(u[(i + di) % rings][:, None], v[(np.arange(sides) + dj) % sides][None, :])
                       for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1))]
            records["corners"][:, :, 0] = np.stack([corners[0], corners[1], corners[2]], axis=2)
            records["corners"][:, :, 1] = np.stack([corners[0], corners[2], corners[3]], axis=2)
            records.tofile(f)
    os.replace(path + ".part", path)
    return path, 2 * rings * sides


def _torus_point(u, v, major=2.0, minor=0.5):
    radius = major + minor * np.cos(v)
    return np.stack(np.broadcast_arrays(radius * np.cos(u) + OFFSET[0], radius * np.sin(u) + OFFSET[1],
                                        minor * np.sin(v) + OFFSET[2]), axis=-1)


def box_stl():
    path = _path("box12.stl")
    if not os.path.exists(path):
        from massprops.validation import solids
        from massprops.io.stl import write_binary
        write_binary(path, solids.box((1.0, 2.0, 3.0), (0.5, 0.5, 0.5)).triangles)
    return path


# Runs the command and reports its wall time and peak RSS.  A small launcher
# process is needed: a child's ru_maxrss starts from the RSS of the process
# that forked it, which here holds meshes.
_LAUNCHER = """
import os, subprocess, sys, time
begin = time.perf_counter()
child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
_, status, usage = os.wait4(child.pid, 0)
wall = time.perf_counter() - begin
if os.waitstatus_to_exitcode(status):
    sys.exit(child.stderr.read().decode()[-500:] or 'failed')
print(wall, usage.ru_maxrss / 1024.0)
"""


def measure(argv, env=None):
    """Wall seconds and peak RSS (MiB) of one fresh process; raises if it fails."""
    done = subprocess.run([sys.executable, "-c", _LAUNCHER, *argv], capture_output=True, text=True,
                          env=dict(os.environ, **(env or {})))
    if done.returncode:
        raise RuntimeError(f"{' '.join(argv)} failed: {done.stderr.strip()[-500:]}")
    wall, peak = done.stdout.split()
    return float(wall), float(peak)


def best(argv, repeat, env=None):
    """The fastest of ``repeat`` runs (wall, peak MiB of that run)."""
    return min(measure(argv, env) for _ in range(repeat))


def interleaved(commands, repeat):
    """The fastest run of each command, the commands taking turns ``repeat`` times.

    This machine is shared and its speed drifts over seconds; taking turns
    gives every command the same mix of fast and slow moments, so the ratios
    hold better than the absolute times.

    Parameters
    ----------
    commands : dict
        ``{name: (argv, env, runs per turn)}``.

    Returns
    -------
    dict
        ``{name: (wall s, peak MiB)}`` of each command's fastest run.
    """
    runs = {name: [] for name in commands}
    for _ in range(repeat):
        for name, (argv, env, per_turn) in commands.items():
            runs[name] += [measure(argv, env) for _ in range(per_turn)]
    return {name: min(found) for name, found in runs.items()}


def massprops_cmd(path, *options):
    """The installed ``massprops`` script (what users run), else ``python -m massprops``.

    The script beside this interpreter first: the one on PATH may be a
    version manager's shim (pyenv's is a bash script that execs another,
    tens of ms), which ``python -c "import numpy"`` is not measured through.
    """
    import shutil
    beside = os.path.join(os.path.dirname(sys.executable), "massprops")
    script = beside if os.access(beside, os.X_OK) else shutil.which("massprops")
    return ([script] if script else [sys.executable, "-m", "massprops"]) + ["props", *options, path]


def _seconds(x):
    return f"{x:.2f}" if x >= 0.1 else f"{x:.3f}"


def end_to_end(quick):
    """massprops against trimesh and the peers on the icosphere, each a fresh process (wall, peak RSS)."""
    import peers
    path = icosphere_stl()
    repeat = 2 if quick else 3
    command = massprops_cmd(path, "--format", "json")
    commands = {"massprops": (command, None, 2), "massprops, 1 thread": (command, {"MASSPROPS_THREADS": "1"}, 1),
                "import numpy": ([sys.executable, "-c", "import numpy"], None, 2)}
    skipped = {}
    for name in peers.PEERS:
        if not peers.installed(name):
            skipped[name] = "not installed"
        elif name == "numpy-stl" and quick:
            skipped[name] = "skipped with --quick (~80 s a run)"
        else:
            commands[name] = (peers.command(name, path), None, 1)
    runs = {name: 1 if name == "numpy-stl" else repeat for name in commands}
    found = {}
    for turn in range(max(runs.values())):
        for name, (argv, env, per_turn) in commands.items():
            if turn < runs[name]:
                found.setdefault(name, []).extend(measure(argv, env) for _ in range(per_turn))
    found = {name: min(values) for name, values in found.items()}
    numpy_only = found.pop("import numpy")[0]
    ours = found["massprops"][0]
    size = os.path.getsize(path) / MIB
    rows = [f"1,310,720 triangles (icosphere(8) at {OFFSET}), binary STL of {size:.0f} MiB; best of "
            f"{repeat} fresh processes each (numpy-stl: 1).", "",
            "| tool | computes | wall s | peak MiB | massprops is faster by |", "|---|---|---:|---:|---:|"]
    for name, (wall, peak) in found.items():
        what = "volume, COM, inertia, principal axes, bounds" if name.startswith("massprops") else peers.PEERS[name][2]
        rows.append(f"| {name} | {what} | {_seconds(wall)} | {peak:.0f} | "
                    f"{'' if name.startswith('massprops') else f'{wall / ours:.1f}×'} |")
    rows += [f"| {name} | {peers.PEERS[name][2]} | {why} | | |" for name, why in skipped.items()]
    rows += ["", f"`python -c \"import numpy\"` in the same turns: {_seconds(numpy_only)} s; massprops' own share "
             f"(end to end minus it): {_seconds(ours - numpy_only)} s."]
    return "\n".join(rows)


def _time(function, repeat):
    times = []
    for _ in range(repeat):
        begin = time.perf_counter()
        function()
        times.append(time.perf_counter() - begin)
    return min(times)


def kernel(quick):
    """ns/triangle of the integration kernel on the icosphere, beside trimesh, meshlib and the memory floor."""
    import peers
    import trimesh
    from massprops.core import integrate
    from massprops.io import read
    path = icosphere_stl()
    mesh = read(path)
    triangles = mesh.vertices[mesh.faces]
    m = mesh.faces.shape[0]
    repeat = 3 if quick else 7
    floor = _time(lambda: triangles.sum(), repeat)
    ours = {}
    for threads in ("1", ""):
        os.environ["MASSPROPS_THREADS"] = threads
        ours[threads] = _time(lambda: integrate(mesh.vertices, mesh.faces), repeat)
    os.environ.pop("MASSPROPS_THREADS")
    theirs = _time(lambda: trimesh.triangles.mass_properties(triangles), max(2, repeat // 2))
    meshlib = peers.meshlib_volume_seconds(path, repeat)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    ns = {k: v / m * 1e9 for k, v in ours.items()}
    rows = ["| kernel (1,310,720 triangles, in process) | computes | ns/triangle | trimesh is slower by | × floor |",
            "|---|---|---:|---:|---:|",
            f"| memory-read floor (one pass summing the float64 triangles) | | {floor / m * 1e9:.1f} | | 1 |",
            f"| massprops `core.integrate`, 1 thread | volume, first and second moments, with bounds | {ns['1']:.1f} "
            f"| {theirs / ours['1']:.1f}× | {ours['1'] / floor:.1f} |",
            f"| massprops `core.integrate`, {cores} threads | the same | {ns['']:.1f} | {theirs / ours['']:.1f}× "
            f"| {ours[''] / floor:.1f} |",
            f"| trimesh `triangles.mass_properties` | volume, first and second moments | {theirs / m * 1e9:.0f} "
            f"| 1.0× | {theirs / floor:.0f} |",
            f"| meshlib `Mesh.volume()` | volume only | "
            + (f"{meshlib / m * 1e9:.1f} | | {meshlib / floor:.1f} |" if meshlib else "not installed | | |")]
    return "\n".join(rows)


def torus_obj(triangles):
    """The torus of :func:`torus_stl` as a Wavefront OBJ with shortest round-trip decimals (written once)."""
    stl, m = torus_stl(triangles)
    path = _path(f"torus_{m}.obj")
    if not os.path.exists(path):
        from massprops.core import read_stl
        vertices, faces, _ = read_stl(stl)
        with open(path + ".part", "w") as f:
            f.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
            np.savetxt(f, faces + 1, fmt="f %d %d %d")
        os.replace(path + ".part", path)
    return path, m


def read_weld(quick):
    """ns/triangle of reading and welding in process (``massprops.core.read_stl``, ``read_obj``), 1 and 2 threads.

    Beside the floor of reading the same file: ``numpy.fromfile`` of a binary STL's records, the
    bytes of an OBJ.
    """
    from massprops.core import read_obj, read_stl
    from massprops.io.stl import _RECORD
    repeat = 3 if quick else 5
    rows = ["| file | triangles | file read floor ns/triangle | 1 thread ns/triangle | 2 threads ns/triangle |",
            "|---|---:|---:|---:|---:|"]

    def raw(path):
        with open(path, "rb") as f:
            return f.read()

    files = (("icosphere(8), binary STL", icosphere_stl(), read_stl, lambda p: np.fromfile(p, dtype=_RECORD, offset=84)),
             ("torus, binary STL", torus_stl(1_000_000)[0], read_stl, lambda p: np.fromfile(p, dtype=_RECORD, offset=84)),
             ("torus, OBJ (shortest round-trip decimals)", torus_obj(1_000_000)[0], read_obj, raw))
    for name, path, reader, plain in files:
        m = reader(path)[1].shape[0]
        floor = _time(lambda: plain(path), repeat)
        ours = {}
        for threads in ("1", "2", "1", "2"):       # taking turns: the machine's speed drifts
            os.environ["MASSPROPS_THREADS"] = threads
            ours[threads] = min(ours.get(threads, float("inf")), _time(lambda: reader(path), repeat))
        os.environ.pop("MASSPROPS_THREADS")
        rows.append(f"| {name} | {m:,} | {floor / m * 1e9:.1f} | {ours['1'] / m * 1e9:.1f} | {ours['2'] / m * 1e9:.1f} |")
    return "\n".join(rows)


STARTUP_PROBE = ("import sys; from click.testing import CliRunner; import massprops.cli as c; "
                 "r = CliRunner().invoke(c.main, ['props', sys.argv[1]]); "
                 "print(sorted(m for m in ('trimesh', 'scipy', 'meshio', 'matplotlib', 'dask') if m in sys.modules))")


def wheel_python(scratch):
    """A virtualenv in ``scratch`` with this tree installed from a wheel (what users run), or None.

    It sees this interpreter's site-packages (numpy, click) but imports massprops from the wheel;
    the benchmark's own ``massprops`` may be an editable install, whose start-up differs.
    """
    root = os.path.dirname(HERE)
    venv = os.path.join(scratch, "venv")
    steps = ([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w",
              os.path.join(scratch, "wheel"), root],
             [sys.executable, "-m", "venv", "--system-site-packages", venv])
    for step in steps:
        if subprocess.run(step, capture_output=True).returncode:
            return None
    wheel = [os.path.join(scratch, "wheel", name) for name in os.listdir(os.path.join(scratch, "wheel"))]
    python = os.path.join(venv, "bin", "python")
    done = subprocess.run([python, "-m", "pip", "install", "-q", "--no-deps", *wheel], capture_output=True)
    return python if done.returncode == 0 else None


def startup(quick):
    import tempfile
    path = box_stl()
    repeat = 10 if quick else 25
    one_blas = {name: "1" for name in BLAS_THREADS}
    commands = {"ours": (massprops_cmd(path), None, 1),
                "numpy": ([sys.executable, "-c", "import numpy"], None, 1),
                "numpy, 1 BLAS thread": ([sys.executable, "-c", "import numpy"], one_blas, 1),
                "bare": ([sys.executable, "-c", "pass"], None, 1)}
    with tempfile.TemporaryDirectory() as scratch:
        wheel = None if quick else wheel_python(scratch)
        if wheel:
            script = os.path.join(os.path.dirname(wheel), "massprops")
            commands["wheel"] = ([script, "props", path], None, 1)
            commands["wheel numpy"] = ([wheel, "-c", "import numpy"], None, 1)
            commands["wheel numpy, 1 BLAS thread"] = ([wheel, "-c", "import numpy"], one_blas, 1)
        found = interleaved(commands, repeat)
    ours, numpy_only, bare = found["ours"][0], found["numpy"][0], found["bare"][0]
    numpy_one = found["numpy, 1 BLAS thread"][0]
    rows = []
    if wheel:
        wheel_ours, wheel_numpy = found["wheel"][0], found["wheel numpy"][0]
        wheel_one = found["wheel numpy, 1 BLAS thread"][0]
        rows = [f"| installed from a wheel (a virtualenv over this interpreter): `import numpy` | {wheel_numpy:.3f} "
                f"| 1.00× |",
                f"| the same, one BLAS thread | {wheel_one:.3f} | {wheel_one / wheel_numpy:.2f}× |",
                f"| installed from a wheel: `massprops props box.stl` | {wheel_ours:.3f} "
                f"| {wheel_ours / wheel_numpy:.2f}× ({wheel_ours / wheel_one:.2f}× the one-thread import) |"]
    heavy = subprocess.run([sys.executable, "-c", STARTUP_PROBE, path], capture_output=True,
                           text=True).stdout.strip()
    return "\n".join([
        "| startup, 12-triangle box | wall s | vs `import numpy` |", "|---|---:|---:|",
        f"| `python -c pass` | {bare:.3f} | |",
        f"| `python -c \"import numpy\"` | {numpy_only:.3f} | 1.00× |",
        f"| the same, `OPENBLAS_NUM_THREADS=1` (and MKL, BLIS, Accelerate) | {numpy_one:.3f} "
        f"| {numpy_one / numpy_only:.2f}× |",
        f"| `massprops props box.stl` (asks for one BLAS thread itself) | {ours:.3f} | {ours / numpy_only:.2f}× "
        f"({ours / numpy_one:.2f}× the one-thread import) |", *rows,
        "", f"Heavy modules imported by `massprops props` on a binary STL: {heavy or '[]'}."])


_IN_PROCESS = """
import sys, time
from massprops import mass_properties
times = []
while len(times) < int(sys.argv[2]) or sum(times) < float(sys.argv[3]):
    begin = time.perf_counter()
    result = mass_properties(sys.argv[1])
    times.append(time.perf_counter() - begin)
print(min(times) / result.triangles * 1e9, len(times))
"""


def in_process_ns(path, repeat, budget=0.5):
    """ns/triangle of ``mass_properties(path)`` (read, weld, check, integrate) in a fresh process.

    The best of at least ``repeat`` calls, and of as many as fit in ``budget``
    seconds (as ``timeit`` does): a small mesh's first calls in a process pay
    one-off costs (lazy imports, the allocator's first pages) several times
    its steady time.  Returns the ns/triangle and the number of calls.
    """
    done = subprocess.run([sys.executable, "-c", _IN_PROCESS, path, str(repeat), str(budget)], capture_output=True,
                          text=True, check=True)
    ns, calls = done.stdout.split()
    return float(ns), int(calls)


# One peer's whole path (read the file, compute) in process: the best of at least `repeat` calls and of
# as many as fit in the budget, as for massprops.  argv: path, triangles, repeat, budget, setup, step.
_PEER_IN_PROCESS = """
import sys, time
path, m, repeat, budget = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
exec(sys.argv[5])
step = compile(sys.argv[6], "step", "exec")
times = []
while len(times) < repeat or sum(times) < budget:
    begin = time.perf_counter()
    exec(step, dict(globals(), path=path))
    times.append(time.perf_counter() - begin)
print(min(times) / m * 1e9)
"""

def peers_mujoco_body():
    import peers
    return [line for line in peers._MUJOCO.strip().splitlines() if not line.startswith("import ")]


# (setup, step) of each peer in the scaling table: trimesh, and MuJoCo (the fastest other peer installed
# here: pymeshlab, numpy-stl and meshlib are not).  MuJoCo's step is its end-to-end program's body.
_SCALING_PEERS = {
    "trimesh": ("import trimesh", "trimesh.load(path).mass_properties"),
    "MuJoCo (MjSpec compile)": ("import numpy, mujoco",
                                "\n".join(line.replace("sys.argv[1]", "path") for line in peers_mujoco_body())),
}
PEER_SCALING_LIMIT = 1_500_000            # peers are not run on the 10M mesh (minutes, several GB)


def peer_in_process_ns(name, path, m, repeat, budget=0.5):
    setup, step = _SCALING_PEERS[name]
    done = subprocess.run([sys.executable, "-c", _PEER_IN_PROCESS, path, str(m), str(repeat), str(budget), setup,
                           step], capture_output=True, text=True)
    return float(done.stdout) if done.returncode == 0 else None


def scaling(quick):
    import peers
    sizes = [1_000, 10_000, 100_000, 1_000_000] + ([] if quick else [10_000_000])
    others = [name for name in _SCALING_PEERS if peers.installed(name)]
    rows = ["| triangles | file MiB | `massprops props` s | ns/triangle in process (best of calls) | peak MiB "
            "| peak / file | " + " | ".join(f"{name} ns/triangle in process" for name in others) + " |",
            "|---:|---:|---:|---:|---:|---:|" + "---:|" * len(others)]
    per_triangle = []
    for target in sizes:
        path, m = torus_stl(target)
        repeat = 1 if m > 2_000_000 else 3       # 10M: the peak-memory target (≤ 1.5× the file)
        wall, peak = best(massprops_cmd(path, "--format", "json"), repeat)
        size = os.path.getsize(path) / MIB
        # at least four calls at every size: the first call in a process pays one-off costs (the kernel's
        # first huge pages), and the best of two on the 10M mesh was then the best of one
        ns, calls = in_process_ns(path, 4)
        per_triangle.append(ns)
        theirs = []
        for name in others:
            found = peer_in_process_ns(name, path, m, 2) if m <= PEER_SCALING_LIMIT else None
            theirs.append("not run" if m > PEER_SCALING_LIMIT else "failed" if found is None else f"{found:.0f}")
        rows.append(f"| {m:,} | {size:.1f} | {_seconds(wall)} | {ns:.0f} (of {calls}) | {peak:.0f} | {peak / size:.2f} | "
                    + " | ".join(theirs) + " |")
    return "\n".join(rows) + (f"\n\nTime per triangle in process: largest / smallest = "
                              f"{max(per_triangle) / min(per_triangle):.2f}× over these sizes (massprops); "
                              f"peers not run above {PEER_SCALING_LIMIT:,} triangles.")


def machine():
    import platform
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (f"Machine: {cpu}, {cores} cores available, Python {platform.python_version()}, "
            f"numpy {np.__version__}; load average {os.getloadavg()[0]:.1f} at the start (shared machine).")


def byte_compile():
    """Write massprops' bytecode cache first, as ``pip install`` does for a regular install.

    An editable install compiles on first import, unless PYTHONDONTWRITEBYTECODE
    is set (as on this sandbox): then every fresh process would recompile the
    package (~25 ms), which users' installs do not pay.
    """
    import compileall
    import massprops
    compileall.compile_dir(os.path.dirname(massprops.__file__), quiet=1)


def run(quick: bool = False) -> str:
    """All props tables as Markdown."""
    byte_compile()
    parts = [machine(), "", "**End to end** (best of runs; fresh processes):", "", end_to_end(quick), "",
             "**Kernel**:", "", kernel(quick), "", "**Read and weld** (in process, best of calls):", "",
             read_weld(quick), "", "**Startup**:", "", startup(quick), "",
             "**Scaling** (tori off the origin, binary STL; in process = `mass_properties(path)` without "
             "interpreter start-up):", "", scaling(quick)]
    return "\n".join(parts)


if __name__ == "__main__":
    print(run("--quick" in sys.argv))
