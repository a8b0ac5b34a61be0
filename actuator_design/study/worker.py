"""The work of one chunk of study points, run in a worker process (local pool or Dask worker).

:func:`run_chunk` is a plain module-level function of picklable arguments so that both
``concurrent.futures`` and ``dask.distributed`` can ship it. Each point's configuration is
validated again (:func:`actuator_design.config.load_config`) and every analysis in the list is run
on its scene; the solver built for a scene structure is cached per process by
:func:`actuator_design.equilibrium.solver.get_solver`, and chunks hold consecutive grid points, so a worker
builds it once. A study of ``solve`` alone walks chunks fixed by the grid, one path from rest
per load ray (:mod:`actuator_design.study.walk`); any other study computes its points
independently of each other. Either way a study's results do not depend on the number of
workers, the backend or a resume.

A record (one JSON line of the journal) is
``{"index", "values": {key: value}, "status", "message", "results": {column: value}, "time_s"}``
(``values``: the point's swept values as substituted, checked against the grid on resume) with
status
``ok`` | ``not_converged`` (an analysis reported ``success: false``) | ``invalid`` (the point's
configuration failed validation) | ``error`` (an analysis raised).
"""
from __future__ import annotations

import signal
import threading
from typing import Any, Dict, List

from actuator_design.parallel import die_with_parent, single_threaded_blas
from actuator_design.study.grid import Axis
from actuator_design.study.lock import close_inherited
from actuator_design.study.walk import one_point, run_walk_chunk

__all__ = ["run_chunk", "init_worker"]

# Analyses share per-process caches (solvers, CasADi functions): chunks of one process run one at
# a time even on a threaded Dask worker.
_LOCK = threading.Lock()
_BLAS_SET = False


def run_chunk(task: Dict[str, Any]) -> List[Dict[str, Any]]:
    """Compute the points of one chunk.

    Parameters
    ----------
    task : dict
        ``raw`` (the configuration as loaded), ``axes`` (``Axis.to_dict()`` list), ``analyses``
        (``[{"type": name, **settings}]``), ``points`` (``[(index, value indices), ...]``) and
        ``outputs`` (glob patterns of the result columns to keep, or None for all).

    Returns
    -------
    list of dict
        One record per point (see the module docstring), in the order given.
    """
    if task.get("single_threaded_blas"):  # a Dask worker: set once per process
        global _BLAS_SET
        if not _BLAS_SET:
            single_threaded_blas()
            _BLAS_SET = True
    with _LOCK:
        if task.get("walk"):
            return run_walk_chunk(task)
        axes = [Axis.from_dict(a) for a in task["axes"]]
        return [one_point(task["raw"], axes, task["analyses"], i, idx, task.get("outputs"))
                for i, idx in task["points"]]


def init_worker(parent_pid: int) -> None:
    """Process-pool initializer: workers leave Ctrl-C to the parent (which stops them), let go of
    the study folder's lock inherited by a fork, and die with the parent (also on ``kill -9``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    close_inherited()
    die_with_parent(parent_pid)
    single_threaded_blas()
