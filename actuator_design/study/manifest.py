"""The manifest of a study folder: what was asked, what ran, where every point stands.

:func:`manifest_base` is the part fixed by the plan (configuration, resolved sweep, versions,
solver settings); a run adds its status, counts, the list of points and the history of runs
(:mod:`actuator_design.study.runner`). :func:`read_manifest` reads it back *truthfully*: a run
killed outright (``kill -9``, a power cut) leaves its manifest at ``running``; when no live run
holds the folder's lock (:mod:`actuator_design.study.lock`) that status, and the last run's, are
reported as ``interrupted`` — resume with ``--resume``.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Dict, List, Optional

from actuator_design import __version__
from actuator_design.io.safe_files import open_regular
from actuator_design.io.save import scene_to_dict
from actuator_design.study.grid import point_values
from actuator_design.study.journal import JOURNAL_NAME
from actuator_design.study.lock import holder_of
from actuator_design.study.outputs import versions
from actuator_design.study.plan import MANIFEST_NAME

__all__ = ["MANIFEST_NAME", "manifest_base", "counts", "point_list", "read_manifest",
           "previous_manifest"]

_DEAD_RUN_NOTE = ("the run that wrote this manifest ended without finishing (its process is gone); "
                  "resume it with --resume")


def _load(folder) -> Optional[dict]:
    """The manifest's JSON (not through a link, not from a FIFO), or None when there is none or it
    is not a JSON object."""
    try:
        with os.fdopen(open_regular(Path(folder) / MANIFEST_NAME, os.O_RDONLY), "rb") as fh:
            manifest = json.loads(fh.read())
    except (OSError, ValueError, RecursionError):  # OutputFolderError is a ValueError
        return None
    return manifest if isinstance(manifest, dict) else None


def _as_interrupted(manifest: dict) -> dict:
    """A manifest left at ``running`` by a dead run, told as it is."""
    if manifest.get("status") == "running":
        manifest["status"] = "interrupted"
        manifest["note"] = _DEAD_RUN_NOTE
    runs = manifest.get("runs") or []
    if runs and isinstance(runs[-1], dict) and runs[-1].get("status") == "running":
        runs[-1]["status"] = "interrupted"
    return manifest


def read_manifest(folder) -> Optional[dict]:
    """A study folder's manifest, with a dead run's ``running`` reported as ``interrupted``.

    Parameters
    ----------
    folder : str or Path
        The study folder.

    Returns
    -------
    dict or None
        The manifest (None when there is none, or it is not JSON). When it says ``running`` but
        no live run holds the folder, ``status`` and the last run's status are ``interrupted``
        and ``note`` says why.
    """
    manifest = _load(folder)
    if manifest is not None and manifest.get("status") == "running" and holder_of(folder) is None:
        _as_interrupted(manifest)
    return manifest


def previous_manifest(folder) -> Optional[dict]:
    """The manifest of earlier runs, read by the run that now holds the folder's lock: a run it
    still calls ``running`` is dead (it would hold the lock), so it is reported ``interrupted``."""
    manifest = _load(folder)
    return _as_interrupted(manifest) if manifest is not None else None


def manifest_base(plan, previous: Optional[dict]) -> dict:
    """The keys of the manifest that the plan fixes (``started``: of the first run)."""
    scene = plan.config.to_scene()
    return {
        "manifest": "actuator-design study",
        "name": plan.name,
        "description": plan.config.description,
        "study_id": plan.study_id,
        "package_version": __version__,
        "versions": versions(),
        "config": plan.raw,
        "resolved": {
            "grid": plan.spec.grid,
            "sweep": [a.to_dict() for a in plan.axes],
            "analyses": plan.analyses,
            "outputs": plan.spec.outputs,
            "figures": [f.model_dump() for f in plan.spec.figures] if plan.spec.figures else None,
            "base_scene": scene_to_dict(scene),
        },
        "solver": plan.config.solver_options().as_dict(),
        "n_points": plan.n_points,
        "started": previous.get("started") if previous else None,
        "files": {"journal": JOURNAL_NAME},
    }


def counts(records: Dict[int, dict], n: int) -> Dict[str, int]:
    """Points by status, ``pending`` for those without a record."""
    out = {"ok": 0, "not_converged": 0, "invalid": 0, "error": 0}
    for r in records.values():
        out[r.get("status", "error")] = out.get(r.get("status", "error"), 0) + 1
    out["pending"] = n - len(records)
    return out


def point_list(plan, records: Dict[int, dict]) -> List[dict]:
    """``[{"index", "values", "status"[, "message"]}]`` for every point of the grid."""
    pts = []
    for i, idx in enumerate(plan.indices):
        rec = records.get(i)
        entry = {"index": i, "values": point_values(plan.axes, idx),
                 "status": rec.get("status") if rec else "pending"}
        if rec and rec.get("message"):
            entry["message"] = rec["message"]
        pts.append(entry)
    return pts
