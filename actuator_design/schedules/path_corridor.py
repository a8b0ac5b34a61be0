"""A tip path with a tolerance (issue 19 item 3): the waypoints of a schedule read as a polyline
the tip must stay near, not only points it must pass.

After a schedule is verified (its states replayed as one loading path), the replayed tip at every
schedule step from the first waypoint on is measured against the polyline through the waypoints;
the schedule holds to the path when the largest distance is at most the tolerance. Between steps
the tip is not measured: more steps (``substeps``, or the ``nodes`` of an optimised schedule) check
it more finely. The tolerance is a check of the reported schedule, not a constraint of its search:
an optimised schedule that strays is reported as such, not replaced by the greedy one. Works on every schedule
result: an ideal field's (:class:`~actuator_design.schedules.schedule.ScheduleResult`), coil currents' and a magnet's pose's.
Lengths in rod lengths.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

__all__ = ["distance_to_path", "hold_to_path"]


def distance_to_path(points: np.ndarray, waypoints: Sequence[Sequence[float]]) -> np.ndarray:
    """The distance of each point (n, 2) from the polyline through ``waypoints`` (m, 2), shape (n,)."""
    p = np.asarray(points, float).reshape(-1, 2)
    w = np.asarray(waypoints, float).reshape(-1, 2)
    if len(w) == 1:
        return np.hypot(*(p - w[0]).T)
    a, ab = w[:-1], np.diff(w, axis=0)  # segments a + t ab, t in [0, 1]
    length2 = np.einsum("ij,ij->i", ab, ab)
    rel = p[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nij,ij->ni", rel, ab) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    return np.min(np.linalg.norm(rel - t[..., None] * ab[None], axis=2), axis=1)


def hold_to_path(result, waypoints, tolerance: float, optimised: Optional[bool] = None) -> dict:
    """Measure a verified schedule ``result`` against the path through ``waypoints`` and, when its
    tip strays farther than ``tolerance`` (rod lengths, > 0), make it a failure that says so
    (``optimised``: whether its steps are an optimised schedule's time nodes, for the advice;
    None: the result's own ``optimal``).

    Returns
    -------
    dict
        ``tolerance``, ``largest_deviation`` (rod lengths; None when there are no replayed states),
        ``step`` (where it is largest) and ``within``: the JSON ``path`` of the schedule commands.
    """
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"path tolerance: must be a finite number > 0 (rod lengths), got {tolerance!r}")
    replay = getattr(result, "verification", None) or result
    states, index = list(getattr(replay, "states", []) or []), list(result.waypoint_index)
    out = {"tolerance": float(tolerance), "largest_deviation": None, "step": None, "within": False}
    if not states or not index or len(states) <= index[-1]:
        return out
    tips = np.array([[s.tip["x"], s.tip["y"]] for s in states[index[0]:]])
    d = distance_to_path(tips, waypoints)
    k = int(np.argmax(d))
    out.update(largest_deviation=float(d[k]), step=index[0] + k, within=bool(d[k] <= tolerance))
    if not out["within"] and result.success:
        result.success = False
        if hasattr(result, "status"):
            result.status = "not_verified"
        if hasattr(result, "verified"):  # (an ideal field's result: verified means success there)
            result.verified = False
        optimised = getattr(result, "optimal", False) if optimised is None else optimised
        more = "--nodes: the optimised schedule's steps are its time nodes" if optimised else "--substeps"
        result.message = (f"the tip strays {d[k]:.3g} rod lengths from the path through the waypoints at step "
                          f"{index[0] + k}, beyond the tolerance {tolerance:g} (more waypoints along the path hold "
                          f"the tip closer to it; more steps check it more finely: {more}); {result.message}")
    return out
