"""Parallel sweeps over many independent items, with a progress bar (issue 4, item 6).

:func:`map_parallel` runs ``fn`` over ``items`` on all cores with a
:class:`concurrent.futures.ProcessPoolExecutor` (chunked), keeps the input order, and shows a tqdm
progress bar on stderr when stderr is a terminal. Each worker process builds its own solvers (the
CasADi caches are per process), so ``fn`` should take plain, picklable inputs — scenes, options,
numbers — and return plain results.
"""
from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, List, Optional, TypeVar

__all__ = ["map_parallel", "default_workers"]

T = TypeVar("T")
R = TypeVar("R")


def default_workers() -> int:
    """The number of CPUs this process may use (affinity-aware), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


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
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for r in pool.map(fn, items, chunksize=chunksize):
                out.append(r)
                bar.update(1)
        return out
    finally:
        bar.close()
