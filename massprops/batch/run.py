"""Many files, one report: input expansion, per-file rows that never raise, parallel runs, resume.

A batch turns each input file into one *record*: a CSV row with the SPEC's
columns (:data:`massprops.report.CSV_COLUMNS`) or a JSON Lines object (the
full ``props`` object plus ``status`` and ``message``).  A file that fails
gives a record with ``status=error`` and its one-line message; the run goes on.

Records are appended to the report as files finish, so an interrupted run
keeps its work; the finished report is rewritten sorted by path, and a state
file next to it lets ``resume`` skip unchanged files (:mod:`massprops.batch.report`).

Work runs in this process (one job), in a process pool, or on a Dask cluster
(``scheduler="local"`` or ``"tcp://HOST:PORT"``); every path calls the same
:func:`run_chunk`, so the records are identical.
"""

from __future__ import annotations

import glob
import os
import re
import signal
import time
from contextlib import contextmanager
from dataclasses import dataclass

from ..errors import MassPropsError, MeshReadError, OptionError
from .report import ReportWriter, file_stat, is_error, plan, record, state_path
from ..frames import Pose

__all__ = ["Settings", "Outcome", "BatchSummary", "FORMATS", "expand_inputs", "run_one", "run_chunk",
           "run_batch", "check_settings", "state_path", "default_jobs"]

FORMATS = ("csv", "jsonl")
_GLOB_CHARS = re.compile(r"[*?\[]")
_STATE_VERSION = 1


@dataclass(frozen=True)
class Settings:
    """What every file of a batch is computed with (the ``props`` options)."""

    density: float | None = None
    mass: float | None = None
    unit: str | None = None
    pose: Pose | None = None
    repair: bool = False
    density_field: str | None = None
    density_map: dict | None = None
    shell: float | None = None
    self_intersection: bool | None = None

    def key(self):
        """A JSON-able description; a resumed report is reused only if this matches."""
        pose = self.pose or Pose()
        return {"density": self.density, "mass": self.mass, "unit": self.unit, "repair": self.repair,
                "density_field": self.density_field, "density_map": self.density_map, "shell": self.shell,
                "self_intersection": self.self_intersection,
                "rotation": [repr(float(x)) for x in pose.rotation.ravel()],
                "translation": [repr(float(x)) for x in pose.translation]}


@dataclass(frozen=True)
class Outcome:
    """One file's record: ``line`` is its text in the report (CSV row or JSON line, with newline)."""

    file: str
    status: str
    message: str
    line: str


@dataclass(frozen=True)
class BatchSummary:
    """What a batch did.  ``ok``/``failed`` count every record of the report, reused ones included."""

    ok: int
    failed: int
    computed: int
    unchanged: int
    elapsed_s: float
    failures: tuple = ()
    notes: tuple = ()
    text: str | None = None

    @property
    def files_per_s(self):
        return self.computed / self.elapsed_s if self.elapsed_s > 0 else float("inf")


def default_jobs():
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


# ---------------------------------------------------------------- inputs

def _mesh_files_in(directory, recursive, skipped=None):
    from ..io import EXTENSIONS
    found = []
    for root, dirs, names in os.walk(directory):
        dirs.sort()
        for name in sorted(names):
            extension = os.path.splitext(name)[1].lower()
            if extension in EXTENSIONS:
                found.append(os.path.join(root, name))
            elif skipped is not None:
                skipped[extension or "(none)"] = skipped.get(extension or "(none)", 0) + 1
        if not recursive:
            break
    return found


def _read_list(list_path):
    """Paths listed one per line in ``list_path`` (blank lines and ``#`` comments skipped)."""
    try:
        with open(list_path, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except OSError as exc:
        raise MeshReadError(f"cannot read the list of paths ({exc.strerror or exc})", path=list_path,
                            fix="give an existing text file with one path per line after @") from None
    folder = os.path.dirname(list_path)
    # a relative path in a list means relative to the list, so a list travels with its folder
    return [os.path.join(folder, s) for s in (line.strip() for line in lines) if s and not s.startswith("#")]


def expand_inputs(paths, *, recursive=False, skipped=None):
    """The mesh files that ``paths`` name, in order, each once.

    Parameters
    ----------
    paths : iterable of str
        Files; directories (their mesh files, by registered extension;
        sub-directories too with ``recursive``); glob patterns (``**`` with
        ``recursive``); ``@LIST`` for a text file of such paths, one a line,
        relative to the list's folder.  A name that matches nothing, or a
        folder with no mesh files, is kept, so the report says what is wrong.
    skipped : dict, optional
        Filled with ``{extension: count}`` of the files in the directories
        walked that are not in a format massprops reads.

    Raises
    ------
    MeshReadError
        An ``@LIST`` file cannot be read.
    """
    files, seen = [], set()

    def add(path):
        path = os.path.normpath(path)
        if path not in seen:
            seen.add(path)
            files.append(path)

    def expand(path, depth=0):
        if path.startswith("@") and depth < 8:
            for listed in _read_list(path[1:]):
                expand(listed, depth + 1)
        elif os.path.isdir(path):
            # a named folder with no mesh files still gets its row, so the report shows the mistake
            for found in _mesh_files_in(path, recursive, skipped) or [path]:
                add(found)
        elif _GLOB_CHARS.search(path) and not os.path.exists(path):
            matches = sorted(glob.glob(path, recursive=recursive))
            for match in matches or [path]:
                expand(match, depth + 1) if os.path.isdir(match) else add(match)
        else:
            add(path)

    for path in paths:
        expand(os.fspath(path))
    return files


# ---------------------------------------------------------------- one file

def _one_line(text):
    # every kind of line break goes: a report record is one line, whatever a message quotes from a file
    return " ".join(filter(None, (part.strip() for part in text.splitlines())))


def error_message(exc):
    """The report's message for a failed file: what is wrong and the fix, without the path."""
    if isinstance(exc, MassPropsError):
        return _one_line(exc.problem + (f" — {exc.fix}" if exc.fix else ""))
    if isinstance(exc, MemoryError):
        return "not enough memory to process this mesh — free memory or split the file"
    return _one_line(f"internal error ({type(exc).__name__}: {exc}) — please report it; "
                     "rerun `massprops props FILE` with MASSPROPS_DEBUG=1 for details")


def run_one(path, settings=Settings(), output_format="csv"):
    """Compute one file's record; never raises for a bad file (it becomes an error record)."""
    from .. import report
    from ..compute import mass_properties
    try:
        if os.path.isdir(path):
            raise MeshReadError("is a directory holding no mesh files", path=path,
                                fix="pass --recursive to search its sub-directories, or name the files")
        result = mass_properties(path, density=settings.density, mass=settings.mass, unit=settings.unit,
                                 pose=settings.pose, repair=settings.repair, density_field=settings.density_field,
                                 density_map=settings.density_map, shell=settings.shell,
                                 self_intersection=settings.self_intersection)
        obj = report.result_dict(result)
        return Outcome(path, "ok", "", record(obj, "ok", "", output_format))
    except Exception as exc:  # noqa: BLE001 - a batch reports every failure as a row and goes on
        message = error_message(exc)
        return Outcome(path, "error", message, record({"file": path}, "error", message, output_format))


def run_chunk(paths, settings=Settings(), output_format="csv"):
    """:func:`run_one` over ``paths``: the unit of work sent to a process or a Dask worker."""
    return [run_one(p, settings, output_format) for p in paths]


def check_settings(settings):
    """Raise the OptionError a bad setting would give on every file, before the run starts."""
    from ..compute import mass_properties
    from ..validation.solids import tetrahedron
    mass_properties(tetrahedron(), density=settings.density, mass=settings.mass, unit=settings.unit,
                    pose=settings.pose, repair=settings.repair)
    return True


# ---------------------------------------------------------------- running

def _chunks(files, workers):
    # a few chunks per worker keep them all busy to the end; chunks amortise the per-task IPC cost
    size = max(1, min(16, len(files) // (4 * max(1, workers or 1))))
    return [tuple(files[i:i + size]) for i in range(0, len(files), size)]


def _failed_chunk(chunk, exc, output_format):
    message = _one_line(f"the worker failed ({type(exc).__name__}: {exc}) — rerun with --resume; "
                        "if it fails again, run `massprops props` on the file")
    return [Outcome(p, "error", message, record({"file": p}, "error", message, output_format)) for p in chunk]


def _collect(futures, as_completed, output_format):
    """Yield each finished chunk's outcomes; a crashed worker turns its chunk into error records."""
    for future in as_completed(list(futures)):
        chunk = futures[future]
        try:
            yield future.result()
        except Exception as exc:  # noqa: BLE001 - a dead worker must not end the run
            yield _failed_chunk(chunk, exc, output_format)


def _init_worker(jobs):
    # Ctrl-C reaches the whole process group: the parent alone handles it, keeping the workers quiet
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # the cores are shared out between the workers, so the integration's threads do not oversubscribe them
    os.environ.setdefault("MASSPROPS_THREADS", str(max(1, default_jobs() // jobs)))


def _run_pool(chunks, settings, output_format, jobs):
    from concurrent.futures import ProcessPoolExecutor, as_completed
    pool = ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker, initargs=(jobs,))
    try:
        futures = {pool.submit(run_chunk, c, settings, output_format): c for c in chunks}
        yield from _collect(futures, as_completed, output_format)
    except BaseException:
        # interrupted: what the workers are doing now would not be written, so stop them at once
        for process in (getattr(pool, "_processes", None) or {}).values():
            process.terminate()
        raise
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _run_dask(todo, settings, output_format, client):
    chunks = _chunks(todo, sum(client.nthreads().values()))
    from dask.distributed import as_completed
    submitted = client.map(run_chunk, chunks, settings=settings, output_format=output_format, pure=False)
    yield from _collect(dict(zip(submitted, chunks)), as_completed, output_format)


@contextmanager
def dask_client(scheduler, *, workers=None, processes=True):
    """A ``dask.distributed.Client`` as a context manager, closed (with its LocalCluster) on leaving.

    Parameters
    ----------
    scheduler : str
        ``"local"`` starts a LocalCluster of ``workers`` single-threaded
        workers (processes, or threads with ``processes=False``); otherwise
        the address of a running scheduler, ``tcp://HOST:PORT``.

    Raises
    ------
    OptionError
        dask.distributed is not installed, or the scheduler cannot be reached.
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise OptionError("--scheduler needs dask.distributed, which is not installed",
                          fix='pip install "massprops[dask]"') from None
    if scheduler == "local":
        import logging
        with LocalCluster(n_workers=workers or default_jobs(), threads_per_worker=1, processes=processes,
                          dashboard_address=None, silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
            yield client
        return
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, ValueError) as exc:
        raise OptionError(f"cannot reach the Dask scheduler at {scheduler!r} ({_one_line(str(exc))})",
                          fix="start one with `dask scheduler` and workers with `dask worker ADDRESS`, "
                              "or check the address (tcp://HOST:PORT)") from None
    with client:
        yield client


def _outcomes(todo, settings, output_format, jobs, scheduler, client):
    """Yield lists of outcomes as work finishes, on the backend asked for."""
    if client is not None:
        yield from _run_dask(todo, settings, output_format, client)
    elif scheduler is not None:
        with dask_client(scheduler, workers=jobs) as client:
            yield from _run_dask(todo, settings, output_format, client)
    elif jobs <= 1 or len(todo) <= 1:
        for path in todo:
            yield run_chunk((path,), settings, output_format)
    else:
        yield from _run_pool(_chunks(todo, jobs), settings, output_format, min(jobs, len(todo)))


def run_batch(files, settings=Settings(), *, output=None, output_format="csv", jobs=None, scheduler=None,
              client=None, resume=False, on_start=None, on_outcome=None):
    """Compute a record for every file and write the report, sorted by path.

    Parameters
    ----------
    files : list of str
        Mesh files (see :func:`expand_inputs`).
    settings : Settings
        Density, mass, unit, pose and repair for every file.
    output : str, optional
        Report path; rows are appended as files finish, then the file is
        rewritten sorted.  None: the sorted text is returned in
        ``BatchSummary.text``.
    output_format : {"csv", "jsonl"}
    jobs : int, optional
        Worker processes (default: all cores); 1 runs in this process.  With a
        local Dask cluster, its number of workers.
    scheduler : str, optional
        ``"local"`` or a Dask scheduler address ``tcp://HOST:PORT``.
    client : dask.distributed.Client, optional
        Run on this client instead (not closed here).
    resume : bool
        Reuse the records of ``output`` whose file has the same size and
        modification time as when it was computed, with the same settings.
    on_start, on_outcome : callable, optional
        Called with the number of files to compute once the resume plan is
        made, and with each :class:`Outcome` as it arrives (progress display).

    Returns
    -------
    BatchSummary
    """
    if output_format not in FORMATS:
        raise OptionError(f"unknown report format {output_format!r}", fix=f"pick one of {', '.join(FORMATS)}")
    if resume and output is None:
        raise OptionError("resuming needs the report file", fix="give the report path with -o")
    start = time.perf_counter()
    header = {"massprops_batch": _STATE_VERSION, "format": output_format, "settings": settings.key()}
    kept, todo, notes = plan(files, output, output_format, header, resume)
    writer = ReportWriter(output, output_format, header, kept)
    status = {}
    if on_start is not None:
        on_start(len(todo))
    try:
        stats = {path: file_stat(path) for path in todo}  # before the work reads them: a later change shows
        for outcomes in _outcomes(todo, settings, output_format, jobs or default_jobs(), scheduler, client):
            for outcome in outcomes:
                writer.add(outcome, stats[outcome.file])
                status[outcome.file] = (outcome.status, outcome.message)
                if on_outcome is not None:
                    on_outcome(outcome)
    finally:
        writer.close()
    text = writer.finish()
    failures = tuple(sorted((f, m) for f, (s, m) in status.items() if s != "ok"))
    failed = len(failures) + sum(is_error(line, output_format) for line, _ in kept.values())
    return BatchSummary(ok=len(files) - failed, failed=failed, computed=len(todo), unchanged=len(kept),
                        elapsed_s=time.perf_counter() - start, failures=failures, notes=tuple(notes), text=text)
