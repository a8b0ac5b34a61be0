"""One study point: its configuration validated, every analysis run on its scene, the results
flattened into table columns (a record of the journal, :mod:`actuator_design.study.worker`).

Both ways of computing a chunk use it: independent points (:func:`~actuator_design.study.worker.run_chunk`)
and the walks from rest of a ``solve`` study (:mod:`actuator_design.study.walk`).
"""
from __future__ import annotations

import fnmatch
import time
import warnings
from typing import Any, Dict, List

from actuator_design.analysis import registry
from actuator_design.config import ConfigError, load_config
from actuator_design.io.save import jsonable
from actuator_design.study.grid import point_values, substitute

__all__ = ["one_point", "flatten", "MAX_LIST"]

#: Lists of at most this many scalars become columns ``key.0``, ``key.1``, …; longer ones are
#: left out of the table (e.g. a shape).
MAX_LIST = 8


def flatten(obj: Any, prefix: str, out: Dict[str, Any] = None) -> Dict[str, Any]:
    """Scalars of nested dicts as ``{"prefix.a.b": value}`` (short lists by index)."""
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
                    why = "; ".join(str(out[k]) for k in ("message", "accuracy") if out.get(k))
                    notes.append(f"{name}: {' '.join(why.split())}")
        for w in caught:
            notes.append(f"warning: {' '.join(str(w.message).split())}")
    if outputs is not None:  # keep only the columns the study asked for (smaller journal)
        rec["results"] = {k: v for k, v in rec["results"].items()
                          if any(fnmatch.fnmatchcase(k, p) for p in outputs)}
    if notes and rec["status"] not in ("invalid", "error"):
        rec["message"] = "; ".join(notes)
    rec["time_s"] = time.perf_counter() - t0
    return rec
