"""The work of one chunk of study points, run in a worker process (local pool or Dask worker).

:func:`run_chunk` is a plain module-level function of picklable arguments so that both
``concurrent.futures`` and ``dask.distributed`` can ship it. Each point's configuration is
validated again (:func:`actuator_design.config.load_config`) and every analysis in the list is run
on its scene; the solver built for a scene structure is cached per process by
:func:`actuator_design.solver.get_solver`, and chunks hold consecutive grid points, so a worker
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

import threading
import time
import warnings
from typing import Any, Dict, List

__all__ = ["run_chunk", "one_point", "flatten", "init_worker", "MAX_LIST"]

#: Lists of at most this many scalars become columns ``key.0``, ``key.1``, …; longer ones are
#: left out of the table (e.g. a shape).
MAX_LIST = 8

# Analyses share per-process caches (solvers, CasADi functions): chunks of one process run one at
# a time even on a threaded Dask worker.
_LOCK = threading.Lock()
_BLAS_SET = False


def flatten(obj: Any, prefix: str, out: Dict[str, Any] = None) -> Dict[str, Any]:
    """Scalars of nested dicts as ``{"prefix.a.b": value}`` (short lists by index)."""
    from ..io import jsonable

    out = {} if out is None else out
    if isinstance(obj, dict):
        for k, v in obj.items():
            flatten(v, f"{prefix}.{k}", out)
    elif isinstance(obj, (list, tuple)):
        if len(obj) <= MAX_LIST and all(not isinstance(v, (dict, list, tuple)) for v in obj):
            for i, v in enumerate(obj):
                out[f"{prefix}.{i}"] = jsonable(v)
    else:
        out[prefix] = jsonable(obj)
    return out


def one_point(raw: dict, axes, analyses, index: int, idx, outputs=None) -> Dict[str, Any]:
    """One point's record: its configuration validated, every analysis run on its scene."""
    from ..analysis import registry
    from ..config import ConfigError, load_config
    from .grid import point_values, substitute

    t0 = time.perf_counter()
    rec: Dict[str, Any] = {"index": int(index), "values": point_values(axes, idx), "status": "ok",
                           "message": "", "results": {}}
    notes: List[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            config = load_config(substitute(raw, axes, idx))
            scene, options = config.to_scene(), config.solver_options()
        except ConfigError as err:
            rec.update(status="invalid", message=str(err))
            scene = None
        if scene is not None:
            for entry in analyses:
                name = entry["type"]
                settings = {k: v for k, v in entry.items() if k != "type"}
                try:
                    out = registry.get(name)(scene, options, **settings)
                except Exception as err:  # noqa: BLE001 - recorded per point, the study goes on
                    rec.update(status="error", message=f"{name}: {type(err).__name__}: "
                                                       f"{' '.join(str(err).split())}")
                    break
                flatten(out, name, rec["results"])
                if isinstance(out, dict) and out.get("success") is False:
                    rec["status"] = "not_converged"
                    notes.append(f"{name}: {' '.join(str(out.get('message', '')).split())}")
        for w in caught:
            notes.append(f"warning: {' '.join(str(w.message).split())}")
    if outputs is not None:  # keep only the columns the study asked for (smaller journal)
        import fnmatch
        rec["results"] = {k: v for k, v in rec["results"].items()
                          if any(fnmatch.fnmatchcase(k, p) for p in outputs)}
    if notes and rec["status"] not in ("invalid", "error"):
        rec["message"] = "; ".join(notes)
    rec["time_s"] = time.perf_counter() - t0
    return rec


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
    from .grid import Axis

    if task.get("single_threaded_blas"):  # a Dask worker: set once per process
        global _BLAS_SET
        if not _BLAS_SET:
            from ..parallel import single_threaded_blas
            single_threaded_blas()
            _BLAS_SET = True
    with _LOCK:
        if task.get("walk"):
            from .walk import run_walk_chunk
            return run_walk_chunk(task)
        axes = [Axis.from_dict(a) for a in task["axes"]]
        return [one_point(task["raw"], axes, task["analyses"], i, idx, task.get("outputs"))
                for i, idx in task["points"]]


def init_worker(parent_pid: int) -> None:
    """Process-pool initializer: workers leave Ctrl-C to the parent (which stops them), let go of
    the study folder's lock inherited by a fork, and die with the parent (also on ``kill -9``)."""
    import signal

    from ..parallel import die_with_parent
    from .lock import close_inherited

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    close_inherited()
    die_with_parent(parent_pid)
    from ..parallel import single_threaded_blas
    single_threaded_blas()
