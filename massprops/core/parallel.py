"""Threads where they pay: numpy releases the GIL inside large array operations.

Large meshes are checked and integrated on several cores by running
independent numpy work in threads (no processes, no copies).  Every result is
the same whichever thread computes it.  ``MASSPROPS_THREADS`` caps the thread
count (1 turns threading off); by default it is the number of CPUs this
process may use.
"""

from __future__ import annotations

import os

__all__ = ["thread_count", "start"]

PARALLEL_ABOVE = 1 << 16      # faces; below this a thread costs more than it saves (measured: 40k no gain, 100k 1.3×)


def thread_count():
    """Threads to use: ``MASSPROPS_THREADS`` if set, else the CPUs available to this process."""
    wanted = os.environ.get("MASSPROPS_THREADS", "").strip()
    if wanted:
        return max(1, int(wanted))
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def start(function, *args, threaded=True, **kwargs):
    """Begin ``function(*args, **kwargs)``, in a thread if ``threaded`` and threads are allowed.

    Returns
    -------
    callable
        ``result()`` waits for the call and returns its value (or raises its
        exception).  Without a thread the call runs inside ``result()``.
    """
    if not threaded or thread_count() < 2:
        return lambda: function(*args, **kwargs)
    from concurrent.futures import ThreadPoolExecutor

    pool = ThreadPoolExecutor(1)
    future = pool.submit(function, *args, **kwargs)
    pool.shutdown(wait=False)
    return future.result
