"""How many threads the compiled core may use: ``MASSPROPS_THREADS``, else the CPUs this process may use."""

from __future__ import annotations

import os
from functools import lru_cache

from ..model.errors import OptionError

__all__ = ["thread_count", "threads_for"]


def thread_count():
    """Threads for the compiled core.

    ``MASSPROPS_THREADS`` caps the count (1 turns threading off); by default
    it is the number of CPUs this process may use (found at the first call).  Results never depend on
    it: work is split into fixed blocks whose results are combined exactly.

    Raises
    ------
    OptionError
        ``MASSPROPS_THREADS`` is set to something other than a whole number.
    """
    setting = os.environ.get("MASSPROPS_THREADS")
    if setting is None:
        return _cpus()
    wanted = setting.strip()
    if wanted:
        try:
            return max(1, int(wanted))
        except ValueError:
            raise OptionError(f"MASSPROPS_THREADS must be a whole number of threads, got {wanted!r}",
                              fix="set it to 1, 2, ... or unset it") from None
    return _cpus()


@lru_cache(maxsize=None)
def _cpus():
    # Asked once per process: every compiled call asks for the thread count, and the system call is a
    # microsecond each time (issue 24's per-call cost).
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def threads_for(items, above):
    """Threads for a job of ``items`` faces: one up to ``above`` (there starting a thread costs more than it
    saves), else :func:`thread_count`.  ``MASSPROPS_THREADS`` is checked either way."""
    threads = thread_count()
    return threads if items > above else 1
