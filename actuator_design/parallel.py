"""Parallel sweeps over many independent items, with a progress bar (issue 4, item 6).

:func:`map_parallel` runs ``fn`` over ``items`` on all cores with a
:class:`concurrent.futures.ProcessPoolExecutor` (chunked), keeps the input order, and shows a tqdm
progress bar on stderr when stderr is a terminal. Each worker process builds its own solvers (the
CasADi caches are per process), so ``fn`` should take plain, picklable inputs — scenes, options,
numbers — and return plain results.

Worker processes die with their parent (:func:`die_with_parent`, run by every pool's initializer):
a parent killed outright (``kill -9``) leaves no worker computing for nobody.
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, List, Optional, TypeVar

__all__ = ["map_parallel", "default_workers", "die_with_parent", "single_threaded_blas", "in_worker", "end_with_parent"]

#: environment variables by which a user chooses the BLAS/OpenMP thread count themselves
_THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")

#: prctl(2) option: the signal this process gets when its parent dies (Linux).
_PR_SET_PDEATHSIG = 1

T = TypeVar("T")
R = TypeVar("R")


def default_workers() -> int:
    """The number of CPUs this process may use (affinity-aware), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def single_threaded_blas() -> None:
    """Limit BLAS/OpenMP to one thread in this process, unless the user set a thread count.

    The matrices here are small (tens to a few hundred unknowns): a multi-threaded BLAS gains
    nothing on them, and its spinning threads take a whole core from the next worker process
    (measured: a walked study chunk cost 0.82 ms CPU per point with OpenBLAS threads, 0.42 ms
    without). Parallelism comes from worker processes instead.
    """
    if any(os.environ.get(v) for v in _THREAD_ENV):
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # an install without it: BLAS keeps its own default
        return
    threadpool_limits(limits=1)


_IN_WORKER = False


def in_worker() -> bool:
    """Whether this process is a worker of :func:`map_parallel` (its cores are the pool's: it forks
    no further work, :mod:`actuator_design.forked`)."""
    return _IN_WORKER


def _exit_now() -> None:
    os._exit(1)  # no clean-up: the parent that would use this worker's results is gone


def end_with_parent() -> None:
    """On Linux, ask the kernel to send this process SIGKILL when its parent dies
    (``prctl(PR_SET_PDEATHSIG)`` through ctypes); elsewhere, nothing."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            pass


def _watch_parent(parent_pid: int, poll_s: float) -> None:
    while True:
        time.sleep(poll_s)
        if os.getppid() != parent_pid:  # reparented: the parent is gone
            _exit_now()


def die_with_parent(parent_pid: int, poll_s: float = 1.0) -> None:
    """Make this (worker) process end when the process ``parent_pid`` dies, however it dies.

    On Linux the kernel sends SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``, through
    ctypes); everywhere, a daemon thread polls :func:`os.getppid` every ``poll_s`` seconds and
    ends the process once it has been reparented (the portable fallback). A parent that died
    before this call ends the process at once.

    Parameters
    ----------
    parent_pid : int
        Process id of the parent, taken in the parent (``os.getpid()`` passed as initarg).
    poll_s : float
        Seconds between two checks of the watchdog thread.
    """
    global _IN_WORKER
    _IN_WORKER = True
    end_with_parent()  # (the watchdog below holds where it cannot)
    if os.getppid() != parent_pid:
        _exit_now()
    threading.Thread(target=_watch_parent, args=(parent_pid, poll_s), name="die-with-parent",
                     daemon=True).start()


def _progress(total: int, desc: str, enabled: Optional[bool]):
    from tqdm import tqdm
    if enabled is None:
        enabled = sys.stderr.isatty()
    return tqdm(total=total, desc=desc, file=sys.stderr, disable=not enabled, leave=False)


def map_parallel(fn: Callable[[T], R], items: Iterable[T], workers: Optional[int] = None,
                 desc: str = "", chunksize: Optional[int] = None,
                 progress: Optional[bool] = None) -> List[R]:
    """``[fn(x) for x in items]`` on several processes, in input order, with progress.

    Parameters
    ----------
    fn : callable
        A picklable (module-level) function of one item.
    items : iterable
        Inputs; consumed into a list.
    workers : int, optional
        Processes; default all usable cores. ``1`` (or a single item) runs in this process.
    desc : str
        Label of the progress bar.
    chunksize : int, optional
        Items per task sent to a worker; default ≈ len(items) / (4 · workers), at least 1.
    progress : bool, optional
        Force the progress bar on or off; default: on when stderr is a terminal.

    Returns
    -------
    list
        ``fn(item)`` for each item, in order. An exception in ``fn`` propagates.
    """
    items = list(items)
    workers = default_workers() if workers is None else max(1, int(workers))
    workers = min(workers, max(1, len(items)))
    bar = _progress(len(items), desc, progress)
    try:
        if workers == 1:
            out = []
            for x in items:
                out.append(fn(x))
                bar.update(1)
            return out

        if chunksize is None:
            chunksize = max(1, len(items) // (4 * workers))
        out = []
        with ProcessPoolExecutor(max_workers=workers, initializer=die_with_parent,
                                 initargs=(os.getpid(),)) as pool:
            for r in pool.map(fn, items, chunksize=chunksize):
                out.append(r)
                bar.update(1)
        return out
    finally:
        bar.close()
