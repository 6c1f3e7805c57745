"""Many files, one report: input expansion, per-file rows that never raise, parallel runs, resume.

A batch turns each input file into one *record*: a CSV row with the SPEC's
columns (:data:`massprops.report.CSV_COLUMNS`) or a JSON Lines object (the
full ``props`` object plus ``status`` and ``message``).  A file that fails
gives a record with ``status=error`` and its one-line message; the run goes on.

Records are appended to the report as files finish, so an interrupted run
keeps its work; the finished report is rewritten sorted by path, and a state
file next to it lets ``resume`` skip unchanged files (:mod:`massprops.batch.output`).

Work runs in local worker processes (:mod:`massprops.batch.workers`: a time
limit per file, a dead worker costs only its file) or on a Dask cluster
(``scheduler="local"`` or ``"tcp://HOST:PORT"``); both call the same
:func:`run_one`, so the records are identical.

File names are kept as the file system gives them: bytes that are not UTF-8
are surrogate escapes (Python's ``os.fsdecode``), written to a CSV report as
the original bytes and to JSON as ``\\udcXX`` escapes, so ``os.fsencode``
of a name read back gives the file's name.
"""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from dataclasses import dataclass

from ..model.errors import MassPropsError, MeshReadError, OptionError, printable, render_options
from .inputs import expand_inputs
from .output import ReportWriter, file_stat, is_error, plan, record, state_path
from .workers import TIMED_OUT, WORKER_FAILED, run_workers
from ..model.frames import Pose

__all__ = ["Settings", "Outcome", "BatchSummary", "FORMATS", "DEFAULT_TIMEOUT", "expand_inputs", "run_one",
           "run_chunk", "run_batch", "state_path", "default_jobs"]

FORMATS = ("csv", "jsonl", "json", "text")
RETRIED = (WORKER_FAILED, TIMED_OUT)
DEFAULT_TIMEOUT = 300.0
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
    max_unpacked: int | None = None
    max_instances: int | None = None
    max_depth: int | None = None
    self_intersection: bool | None = None
    only: frozenset | None = None         # the quantities to compute (None: all); see massprops.compute.QUANTITIES
    option_style: str = "python"          # how messages spell options: "python" (repair=True) or "cli" (--repair)

    def key(self):
        """A JSON-able description; a resumed report is reused only if this matches."""
        pose = self.pose or Pose()
        # The graph limits only when given, so that reports written before they existed still resume.
        limits = {name: value for name, value in (("max_instances", self.max_instances),
                                                  ("max_depth", self.max_depth)) if value is not None}
        return {**limits, "density": self.density, "mass": self.mass, "unit": self.unit, "repair": self.repair,
                "density_field": self.density_field, "density_map": self.density_map, "shell": self.shell,
                "max_unpacked": self.max_unpacked, "self_intersection": self.self_intersection,
                **({"only": sorted(self.only)} if self.only is not None else {}),
                "rotation": [repr(float(x)) for x in pose.rotation.ravel()],
                "translation": [repr(float(x)) for x in pose.translation]}


@dataclass(frozen=True)
class Outcome:
    """One file's record: ``line`` is its text in the report (CSV row or JSON line, with newline).

    ``kind`` is ``"ok"``, ``"error"`` (the file's fault), or ``"worker"`` /
    ``"timeout"``: the run's, so ``--resume`` computes such a file again.
    """

    file: str
    status: str
    message: str
    line: str
    kind: str = "ok"
    unit: str | None = None          # the length unit the file was computed in (declared or given)

    @property
    def retry(self):
        return self.kind in RETRIED


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
    units: tuple = ()               # the length unit of each file computed ok (None: none declared or given)

    @property
    def files_per_s(self):
        return self.computed / self.elapsed_s if self.elapsed_s > 0 else float("inf")


def default_jobs():
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


# ---------------------------------------------------------------- one file

def _one_line(text):
    # every kind of line break goes: a report record is one line, whatever a message quotes from a file
    return printable(text).strip()


def error_message(exc, style="python"):
    """The report's message for a failed file: what is wrong and the fix, without the path."""
    if isinstance(exc, MassPropsError):
        return _one_line(exc.render(style, with_path=False))
    if isinstance(exc, MemoryError):
        return "not enough memory to process this mesh — free memory or split the file"
    if isinstance(exc, SystemExit):
        return _one_line(f"a reader tried to end the process (exit status {exc.code}) — please report it")
    return _one_line(f"internal error ({type(exc).__name__}: {exc}) — please report it; "
                     "rerun `massprops props FILE` with MASSPROPS_DEBUG=1 for details")


def run_one(path, settings=Settings(), output_format="csv"):
    """Compute one file's record; never raises for a bad file (it becomes an error record)."""
    from .. import report
    from ..api import mass_properties
    try:
        if os.path.isdir(path):
            raise MeshReadError("is a directory holding no mesh files", path=path,
                                fix="pass {recursive} to search its sub-directories, or name the files")
        result = mass_properties(path, density=settings.density, mass=settings.mass, unit=settings.unit,
                                 pose=settings.pose, repair=settings.repair, density_field=settings.density_field,
                                 density_map=settings.density_map, shell=settings.shell,
                                 max_unpacked=settings.max_unpacked, max_instances=settings.max_instances,
                                 max_depth=settings.max_depth, self_intersection=settings.self_intersection,
                                 only=settings.only)
        if output_format == "csv" and settings.only is None:
            line = report.tables.result_csv_line(result)       # the row's numbers straight from the result
        else:
            # a CSV row reads a few of the object's keys: the brief object has them, with the same values
            obj = report.result_dict(result, only=settings.only, brief=output_format == "csv")
            line = record(obj, "ok", "", output_format)
        return Outcome(path, "ok", "", line, unit=result.properties.unit)
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - a batch reports every failure as a row and goes on
        message = error_message(exc, settings.option_style)
        return Outcome(path, "error", message, record({"file": path}, "error", message, output_format), "error")


def run_chunk(paths, settings=Settings(), output_format="csv"):
    """:func:`run_one` over ``paths``: the unit of work sent to a Dask worker."""
    return [run_one(p, settings, output_format) for p in paths]


def failed_outcome(path, kind, detail, settings, output_format, timeout=None):
    """The record of a file the run could not finish: its worker died twice, or it ran out of time."""
    if kind == TIMED_OUT:
        message = (f"timed out after {timeout:g} s — rerun with {{resume}} and a larger {{timeout=SECONDS}} "
                   "(0 for none), or look at it with `massprops props FILE`")
    else:
        message = (f"the worker process died computing this file, each time it was tried ({detail}) — rerun "
                   "with {resume} to try again; `massprops props FILE` shows what fails")
    message = _one_line(render_options(message, settings.option_style))
    return Outcome(path, "error", message, record({"file": path}, "error", message, output_format), kind)


# ---------------------------------------------------------------- running

def _chunks(files, workers):
    # a few chunks per worker keep them all busy to the end; chunks amortise the per-task cost of Dask
    size = max(1, min(16, len(files) // (4 * max(1, workers or 1))))
    return [tuple(files[i:i + size]) for i in range(0, len(files), size)]


def _run_local(todo, settings, output_format, jobs, timeout):
    """Outcomes from local worker processes (:mod:`massprops.batch.workers`), one list per file."""
    from functools import partial
    compute = partial(run_one, settings=settings, output_format=output_format)
    failed = partial(_failed_locally, settings=settings, output_format=output_format, timeout=timeout)
    threads = max(1, default_jobs() // jobs)        # cores shared out: no oversubscription by kernel threads
    yield from run_workers(todo, compute, failed, jobs=jobs, timeout=timeout, threads=threads)


def _failed_locally(path, kind, detail, *, settings, output_format, timeout):
    return failed_outcome(path, kind, detail, settings, output_format, timeout)


def _run_dask(todo, settings, output_format, client):
    """Outcomes from Dask, chunk by chunk; a chunk whose worker died is split into files, each tried alone.

    So a file that kills its worker (Dask retries it on other workers, then
    gives up) costs only itself, not the innocent files of its chunk.
    """
    from dask.distributed import as_completed
    chunks = _chunks(todo, sum(client.nthreads().values()))
    submitted = client.map(run_chunk, chunks, settings=settings, output_format=output_format, pure=False)
    futures = dict(zip(submitted, chunks))
    finished = as_completed(list(futures))
    for future in finished:
        chunk = futures.pop(future)
        try:
            yield future.result()
        except Exception as exc:  # noqa: BLE001 - a dead worker must not end the run
            if len(chunk) == 1:
                detail = _one_line(f"{type(exc).__name__}: {exc}")
                yield [failed_outcome(chunk[0], WORKER_FAILED, detail, settings, output_format)]
                continue
            for path in chunk:
                alone = client.submit(run_chunk, (path,), settings=settings, output_format=output_format,
                                      pure=False)
                futures[alone] = (path,)
                finished.add(alone)


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
        raise OptionError("{scheduler} needs dask.distributed, which is not installed",
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


def _outcomes(todo, settings, output_format, jobs, scheduler, client, timeout):
    """Yield lists of outcomes as work finishes, on the backend asked for."""
    if client is not None:
        yield from _run_dask(todo, settings, output_format, client)
    elif scheduler is not None:
        with dask_client(scheduler, workers=jobs) as client:
            yield from _run_dask(todo, settings, output_format, client)
    elif todo:
        yield from _run_local(todo, settings, output_format, min(jobs, len(todo)), timeout)


def _forget_state(output):
    """Remove the resume state of a complete run: nothing is left to resume (a ``--resume`` run keeps it)."""
    try:
        os.remove(state_path(output))
    except OSError:
        pass


def run_batch(files, settings=Settings(), *, output=None, output_format="csv", jobs=None, scheduler=None,
              client=None, resume=False, timeout=DEFAULT_TIMEOUT, on_start=None, on_outcome=None):
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
    output_format : {"csv", "jsonl", "json", "text"}
        ``json`` (one array) and ``text`` (each file's block as ``props``
        prints it, then a count line) are written whole at the end; their
        records, for ``resume``, are kept in the state file.
    jobs : int, optional
        Worker processes (default: all cores).  Each takes one file at a time;
        a worker that dies costs only its file (retried once in a fresh
        worker).  With a local Dask cluster, its number of workers.
    scheduler : str, optional
        ``"local"`` or a Dask scheduler address ``tcp://HOST:PORT``.
    client : dask.distributed.Client, optional
        Run on this client instead (not closed here).
    resume : bool
        Reuse the records of ``output`` whose file has the same size and
        modification time as when it was computed, with the same settings;
        files whose worker died or that timed out are computed again.  The
        state this needs (``REPORT.state.jsonl``) is kept after an interrupted
        run, a run with files to retry, or a ``resume`` run (for the next
        one); a complete run without ``resume`` removes it.
    timeout : float or None
        Seconds one file may take in a local worker (default 300); None for
        no limit.  Dask runs are bounded by the cluster's own settings.
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
    if timeout is not None and not (isinstance(timeout, (int, float)) and timeout > 0):
        raise OptionError(f"{{timeout}} must be a positive number of seconds or None, got {timeout!r}")
    start = time.perf_counter()
    header = {"massprops_batch": _STATE_VERSION, "format": output_format, "settings": settings.key()}
    kept, todo, notes = plan(files, output, output_format, header, resume)
    writer = ReportWriter(output, output_format, header, kept)
    status, units, unfinished = {}, [], False
    if on_start is not None:
        on_start(len(todo))
    stats = {path: file_stat(path) for path in todo}      # before the work reads them: a later change shows
    arriving = _outcomes(todo, settings, output_format, jobs or default_jobs(), scheduler, client, timeout)
    try:
        for outcomes in arriving:
            for outcome in outcomes:
                writer.add(outcome, stats[outcome.file], retry=outcome.retry)
                status[outcome.file] = (outcome.status, outcome.message)
                unfinished |= outcome.retry
                if outcome.status == "ok":
                    units.append(outcome.unit)
                if on_outcome is not None:
                    on_outcome(outcome)
            writer.flush()
    finally:
        arriving.close()                                  # stops the workers now, whatever ended the loop
        writer.close()
    text = writer.finish()
    if output is not None and not resume and not unfinished:
        _forget_state(output)
    failures = tuple(sorted((f, m) for f, (s, m) in status.items() if s != "ok"))
    failed = len(failures) + sum(is_error(line, output_format) for line, _ in kept.values())
    return BatchSummary(ok=len(files) - failed, failed=failed, computed=len(todo), unchanged=len(kept),
                        elapsed_s=time.perf_counter() - start, failures=failures, notes=tuple(notes), text=text,
                        units=tuple(units))
