"""Where a study's chunks run: this process, local worker processes, or a Dask cluster
(:mod:`actuator_design.study.dask_cluster`: every wait bounded).

Each backend is a generator of finished chunks (lists of point records,
:func:`actuator_design.study.worker.run_chunk`) in the order they finish. Closing the generator
early (an interrupt) drops the chunks not started and stops the workers. Local workers die with
the study process even when it is killed outright
(:func:`actuator_design.study.worker.init_worker`).
"""
from __future__ import annotations

import multiprocessing
import os
import threading
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Iterator, List

from actuator_design.study import worker  # called as worker.run_chunk: the seam a test replaces
from actuator_design.study.dask_cluster import connect as connect_bounded
from actuator_design.study.dask_cluster import run_on_dask

__all__ = ["StopRequest", "serial", "processes", "connect", "on_dask"]


class StopRequest:
    """Signal handler for SIGINT/SIGTERM during a run: the first signal asks to stop after the
    point (serial) or chunk (parallel) in progress — IPOPT swallows a KeyboardInterrupt raised
    inside it and would return a spurious failure that a resume would then keep —, a second one
    stops at once."""

    def __init__(self):
        self.requested = False

    def __call__(self, signum, frame):
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def check(self) -> None:
        if self.requested:
            raise KeyboardInterrupt


def serial(tasks, stop: StopRequest) -> Iterator[List[dict]]:
    """Points in this process, one at a time (journaled per point), or a walked chunk at a time."""
    for t in tasks:
        if t.get("walk"):  # a walked chunk is one path from rest: journaled when it is done
            stop.check()
            yield worker.run_chunk(t)
            continue
        for item in t["points"]:
            stop.check()
            yield worker.run_chunk({**t, "points": [item]})


def processes(tasks, workers: int) -> Iterator[List[dict]]:
    """Submit every chunk to a local process pool now; the generator yields results as they
    complete. Workers are forked when this process runs no other thread (they then inherit the
    imported modules: no start-up cost), spawned otherwise."""
    method = ("fork" if "fork" in multiprocessing.get_all_start_methods()
              and threading.active_count() == 1 else "spawn")
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context(method),
                             initializer=worker.init_worker, initargs=(os.getpid(),))
    futures = [ex.submit(worker.run_chunk, t) for t in tasks]

    def results():
        finished = False
        try:
            for f in as_completed(futures):
                yield f.result()
            finished = True
        finally:
            if finished:
                ex.shutdown(wait=True)
            else:  # interrupted: drop queued chunks and stop the workers now
                procs = list((getattr(ex, "_processes", None) or {}).values())
                ex.shutdown(wait=False, cancel_futures=True)
                for p in procs:
                    try:
                        p.terminate()
                    except Exception:  # noqa: BLE001 - already gone
                        pass

    return results()


def connect(scheduler):
    """A Dask client for an address (or the client given) with at least one worker, and its
    number of worker threads; the address is checked and every wait bounded
    (:func:`actuator_design.study.dask_cluster.connect`, which raises
    :class:`~actuator_design.study.dask_cluster.ClusterError`)."""
    return connect_bounded(scheduler)


def on_dask(tasks, client) -> Iterator[List[dict]]:
    """Chunks as Dask futures on ``client``; pending ones are cancelled when closed early. Lost
    workers or a lost scheduler stop it with a resumable
    :class:`~actuator_design.study.dask_cluster.ClusterError` once past their bounds
    (:func:`actuator_design.study.dask_cluster.run_on_dask`)."""
    return run_on_dask(tasks, client)
