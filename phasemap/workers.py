"""Independent calls in processes of their own, a few at once: what ``phasemap tour`` and
``phasemap warm`` run on (numba compiles on one thread, so a cold cache compiles faster
in several processes).

:func:`in_processes` yields each call's result in order as it is ready.  At most
``jobs`` calls are in flight, each worker a fresh interpreter (``spawn``: forking a process
that has numba's threads and LLVM loaded is not safe) that gives numba ``cores // jobs``
threads, so that the workers together do not oversubscribe the cores.  Only this
process answers Ctrl-C (the workers ignore SIGINT, which a terminal sends to them all):
it ends the workers with SIGTERM, which phasemap's code in them turns into an exception
that removes its temporary files (:func:`phasemap.atlas.atomic.removed_on_signals`), after
which the worker exits rather than take more work.

A script that calls ``phasemap.tour.tour`` or ``phasemap.warm.warm`` with several jobs must
keep its own work under ``if __name__ == "__main__":``, as every ``spawn`` pool requires:
each worker imports the script's main module.
"""

from __future__ import annotations

import contextlib
import os
import signal
from typing import Callable, Iterator, Sequence


def default_jobs() -> int:
    """One job per core this process may run on."""
    with contextlib.suppress(AttributeError, OSError):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def _setup(threads: int) -> None:
    """In each worker: Ctrl-C is the parent's to handle; numba gets its share of cores."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import numba

    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))


def in_processes(fn: Callable, calls: Sequence[tuple], jobs: int,
                 status: Callable[[list[int], int], None] | None = None
                 ) -> Iterator[tuple[int, object]]:
    """Yield ``(i, fn(*calls[i]))`` for every call, in order, running at most ``jobs`` at
    once; ``status(running, done)`` is told which calls run (their indices) and how many
    have been yielded, about twice a second.  ``fn`` must be importable (a module-level
    function).  An error in a call is raised here when its turn comes; leaving the loop
    early (an error, Ctrl-C) ends every worker."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    threads = max(1, default_jobs() // max(jobs, 1))
    pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_setup, initargs=(threads,))
    futures: dict = {}
    submitted = done = 0
    finished = False
    try:
        while done < len(calls):
            # no more in flight than workers: nothing waits in the pool's queue, where
            # a worker freed by the end of a run could still pick it up
            while submitted < len(calls) and \
                    sum(not f.done() for f in futures.values()) < jobs:
                futures[submitted] = pool.submit(fn, *calls[submitted])
                submitted += 1
            if status is not None:
                status(sorted(i for i, f in futures.items() if f.running()), done)
            if not futures[done].done():
                wait([f for f in futures.values() if not f.done()], timeout=0.5,
                     return_when=FIRST_COMPLETED)
                continue
            result = futures.pop(done).result()
            yield done, result
            done += 1
        finished = True
    finally:
        if finished:
            pool.shutdown()
        else:
            stop(pool)


def stop(pool) -> None:
    """Cancel what has not started and end the workers: SIGTERM, a wait of up to 30 s
    for them to remove their temporary files, then SIGKILL for any left."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # no public handle
    try:
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in processes:
            if proc.is_alive():
                proc.terminate()
        for proc in processes:
            proc.join(timeout=30)
    finally:  # also after a second Ctrl-C: no worker outlives this process
        for proc in processes:
            if proc.is_alive():
                proc.kill()


@contextlib.contextmanager
def ended_by_signal() -> Iterator[None]:
    """In a worker: the work's own temporary files are removed on SIGTERM (or SIGHUP),
    and then the worker exits (status 1) instead of taking the pool's next call.  In a
    process that is not a worker, nothing changes."""
    import multiprocessing

    from phasemap.atlas.atomic import Terminated, removed_on_signals

    if multiprocessing.parent_process() is None:  # not a worker: nothing changes
        yield
        return
    try:
        with removed_on_signals():
            yield
    except (Terminated, KeyboardInterrupt):
        os._exit(1)
