"""Local worker processes for a batch: a time limit per file, and a dead worker costs only its file.

Each worker is a process fed files over its own pipe, a few queued ahead so
it never waits for the next (as many as keep it busy for a few milliseconds:
the parent, woken by an outcome, lets the others gather before it takes them,
so it wakes once for several files).  A worker sends each outcome as soon as
it has it, so the parent always knows which file a worker holds, and:

* a worker that dies (a crash in a compiled reader, the out-of-memory killer,
  ``kill -9``) costs only the file it held: that file is retried once in a
  fresh worker, then reported as a worker failure; the queued file goes back
  to the queue untouched;
* a file that takes longer than the time limit has its worker killed and is
  reported as timed out; a fresh worker takes the next file.

Workers die with their parent: on Linux the kernel kills them when it exits
(``PR_SET_PDEATHSIG``); elsewhere a thread in each worker watches the parent.
So ``kill -9`` of a batch leaves no orphans.
"""

from __future__ import annotations

import gc
import math
import os
import signal
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field

__all__ = ["run_workers", "WORKER_FAILED", "TIMED_OUT"]

WORKER_FAILED = "worker"
TIMED_OUT = "timeout"
_QUEUED = 2                      # files sent to a worker ahead at least: the one it computes and the next
_MOST_QUEUED = 16                # and at most, so the last files are shared out evenly
_SETTLE = 0.004                  # seconds the parent lets outcomes gather after a wake, while files are queued
_PR_SET_PDEATHSIG = 1


def _die_with_parent(parent):
    """Make this process end when ``parent`` (a pid) does."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):
            pass
        else:
            if os.getppid() != parent:       # the parent was gone before the request took effect
                os._exit(1)
            return

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _serve(connection, parent, threads, compute):
    """A worker's life: compute each path received, send its outcome back, until told to stop."""
    _die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)       # Ctrl-C is the parent's to handle
    os.environ.setdefault("MASSPROPS_THREADS", str(threads))
    gc.freeze()               # the parent's objects, inherited: never traversed (nor their pages copied) by collections
    while True:
        try:
            paths = connection.recv()
        except (EOFError, OSError):
            return
        if paths is None:
            return
        for path in paths:
            connection.send(compute(path))


@dataclass(eq=False)
class _Worker:
    process: object
    connection: object
    held: deque = field(default_factory=deque)       # (path, attempt) sent, in order; the first is being computed
    began: float = 0.0                                 # when it began the first of ``held``
    per_file: float = math.inf                         # seconds a file takes it, as last seen by the parent
    collected: float = 0.0                             # when its outcomes were last collected
    has_data: object = None                            # has_data(timeout): whether an outcome is waiting

    def __post_init__(self):
        wait = _waiter([self.connection])
        self.has_data = lambda timeout=0: bool(wait(timeout))

    def stop(self, *, kill=False):
        if kill and self.process.is_alive():
            self.process.kill()
        try:
            self.connection.close()
        except OSError:
            pass
        self.process.join(timeout=None if kill else 2.0)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()


def _start(context, compute, threads):
    parent_end, child_end = context.Pipe()
    process = context.Process(target=_serve, args=(child_end, os.getpid(), threads, compute), daemon=True,
                              name="massprops-batch-worker")
    process.start()
    child_end.close()
    return _Worker(process, parent_end)


def _cause(exitcode):
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit status {exitcode}"


def run_workers(paths, compute, failed, *, jobs, timeout=None, threads=1):
    """Yield ``compute(path)`` for every path, computed in ``jobs`` worker processes, as they finish.

    Parameters
    ----------
    compute : callable
        ``compute(path) -> outcome``, run in a worker; must not raise (a batch
        turns every failure into an outcome).
    failed : callable
        ``failed(path, kind, detail) -> outcome`` for a file whose worker died
        twice (``kind`` :data:`WORKER_FAILED`) or ran out of time
        (:data:`TIMED_OUT`).
    timeout : float, optional
        Seconds a file may take; None for no limit.
    threads : int
        ``MASSPROPS_THREADS`` for each worker (the cores shared out).
    """
    import multiprocessing

    context = multiprocessing.get_context()
    queue = deque((path, 0) for path in paths)
    workers = []
    waiting, wait = (), None                           # the busy workers last waited on, and their waiter
    try:
        while queue or any(w.held for w in workers):
            while len(workers) < min(jobs, len(queue) + sum(len(w.held) for w in workers)):
                workers.append(_start(context, compute, threads))
            for worker in workers:
                _feed(worker, queue)
            busy = [w for w in workers if w.held]
            limit = None if timeout is None else max(0.0, min(w.began for w in busy) + timeout - time.monotonic())
            if len(busy) != len(waiting) or any(a is not b for a, b in zip(busy, waiting)):
                waiting = tuple(busy)          # the same workers as the last wait, mostly: one poll object for them
                wait = _waiter([w.connection for w in busy] + [w.process.sentinel for w in busy])
            ready = wait(limit)
            if queue and ready and not any(isinstance(item, int) for item in ready):
                time.sleep(_SETTLE)            # let more outcomes arrive: one wake for several files
            ended = {item for item in ready if isinstance(item, int)}          # sentinels: processes that exited
            finished = []
            for worker in list(busy):
                done, lost = _collect(worker, timeout, worker.process.sentinel in ended)
                finished += done
                if lost is not None:
                    workers.remove(worker)
                    worker.stop(kill=True)
                    finished += _lost(worker, lost, queue, failed)
            if finished:
                yield finished
    finally:
        for worker in workers:
            try:
                worker.connection.send(None)
            except OSError:
                pass
        for worker in workers:
            worker.stop(kill=sys.exc_info()[0] is not None)


def _waiter(objects):
    """``wait(timeout)``: the connections and sentinels of ``objects`` that are ready (data, end of file, or an
    exited process), waiting at most ``timeout`` seconds (None: until one is).

    ``multiprocessing.connection.wait`` with one ``poll`` object, made once for
    the objects and kept while they are the ones waited on: that function builds
    a selector and registers every descriptor at each call, and a batch waits
    about three times per file (here a few microseconds, there some 20).
    Elsewhere than where ``poll`` exists, that function itself.
    """
    import select
    if not hasattr(select, "poll"):
        from multiprocessing.connection import wait as wait_on
        return lambda timeout=None: wait_on(objects, timeout)
    poller, by_fd = select.poll(), {}
    for item in objects:
        fd = item if isinstance(item, int) else item.fileno()
        by_fd[fd] = item
        poller.register(fd, select.POLLIN)

    def wait(timeout=None):
        ready = poller.poll(None if timeout is None else math.ceil(max(0.0, timeout) * 1000))
        return [by_fd[fd] for fd, _ in ready]

    return wait


def _depth(worker):
    """How many files ``worker`` should hold: enough for it to stay busy while the parent lets outcomes gather
    (:data:`_SETTLE`, twice over), from the time a file takes it; :data:`_QUEUED` until that is known, and for
    slow files."""
    if worker.per_file == math.inf:
        return _QUEUED
    return min(_MOST_QUEUED, _QUEUED + math.ceil(2 * _SETTLE / max(worker.per_file, 1e-6)))


def _feed(worker, queue):
    """Send ``worker`` files until it holds :func:`_depth`; a worker found dead keeps them (then retried)."""
    count = min(len(queue), _depth(worker) - len(worker.held))
    if count <= 0:
        return
    if not worker.held:
        worker.began = time.monotonic()
    sent = [queue.popleft() for _ in range(count)]
    worker.held.extend(sent)
    try:
        worker.connection.send(tuple(path for path, _ in sent))        # one message: the worker wakes once
    except OSError:
        pass                          # it died: its sentinel is ready, and _collect says so


def _collect(worker, timeout, ended=True):
    """The outcomes ``worker`` has sent, and why it is lost (None if it is fine).

    ``ended``: its process's sentinel was ready (else it was running at the wait, and is not asked again).
    """
    done = []
    try:
        while worker.held and worker.has_data():
            done.append(worker.connection.recv())
            worker.held.popleft()
            worker.began = time.monotonic()
    except (EOFError, OSError):
        pass
    if done:
        now = time.monotonic()
        if worker.collected:
            worker.per_file = (now - worker.collected) / len(done)
        worker.collected = now
    if not worker.held:
        return done, None
    if ended and not worker.process.is_alive():
        return done, _cause(worker.process.exitcode)
    if timeout is not None and time.monotonic() - worker.began > timeout:
        return done, TIMED_OUT
    return done, None


def _lost(worker, cause, queue, failed):
    """The held file's outcome or its retry; the files queued behind it go back untouched."""
    (path, attempt), *waiting = worker.held
    queue.extendleft(reversed(waiting))
    if cause == TIMED_OUT:
        yield failed(path, TIMED_OUT, "")
    elif attempt == 0:
        queue.appendleft((path, 1))
    else:
        yield failed(path, WORKER_FAILED, cause)
