"""What the shape designs over hardware share (issue 19 item 2 beyond the tip): the fit of the
centreline at given arc lengths to target points, in least squares, on a forward map
(:class:`~actuator_design.hardware.map.HardwareMap`: the state from rest at a hardware setting v and
its exact implicit derivative), within the hardware's limits,

    min_v  ½ Σ_i |r(s_i; v) − (x_i, y_i)|²    within the limits of :mod:`.current_sqp`,

the points r(s_i) exact linear-then-trigonometric maps of the nodal angles
(:mod:`actuator_design.transcription.arc_points`). Used by the coil currents'
(:mod:`.current_shape`) and the magnet pose's (:mod:`.pose_shape`) shape designs.

The search is Gauss–Newton in a trust region (each step the least linearised miss within the box,
the power and the linearised pointwise limit: the tip design's least-miss step,
:func:`~actuator_design.hardware.current_sqp._least_miss_step`), a step taken when the state from
rest there keeps every limit and lowers the miss by at least a tenth of the predicted decrease. It
stops where the points are met to :data:`EXACT` or the linearised fit would gain less than
:data:`FIT_GAIN` of itself, or, while the fit is not yet accepted, where the miss shrank by less
than 0.1 % over six iterations (the nearest shape: its minimum may sit where the state from rest
changes branch, a kink the steps only crawl along). It runs from the tip design's screened starts
(the last point taken as a tip target), each in a forked copy of this process, and keeps the best
fit. Where the points are met and leave a family of settings (more unknowns than equations, or a
magnet's pose moved along a curve of equal shapes), the tip design's feasible descent then lowers
the effort among the fits as good (every coordinate kept within twice its miss, at least the tip
design's tolerance; never at the cost of the accepted fit): the setting is one answer, not the
point of the family the search ended on. A success is verified on magpylib's field refitted at the answer (the
points must agree to :data:`~actuator_design.hardware.design.VERIFY_TOL`), holds over the lab's
tolerance box (every corner reached from rest, stable, on the designed branch) and fits within
``accept_tol`` (rms); off it, a search that stopped short where the points' Jacobian is thin and
no limit binds is ``not_converged`` (the shape may be reachable), else ``unreachable`` with the
nearest fit found (a local search).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from actuator_design import forked
from actuator_design.equilibrium.pipeline import solve
from actuator_design.hardware.current_sqp import (DELTA_MAX, DELTA_MIN, DELTA_START, STALL_FRACTION,
                                                  STALL_ITERATIONS, RESOLVED, _feasible_descent, _least_miss_step,
                                                  _stopped_short,
                                                  within_limits)
from actuator_design.hardware.design import VERIFY_TOL, judge
from actuator_design.hardware.map import HardwareMap
from actuator_design.transcription.arc_points import arc_points_function

__all__ = ["ShapeFit", "ShapeMap", "check_points", "best_fit", "least_effort_fit", "record_fit", "verify_points",
           "corner_fit", "judge_fit", "fit_message", "ACCEPT_TOL", "MAX_ITERATIONS", "FIT_GAIN", "EXACT", "FAMILY_TOL"]

#: the fit a success needs by default (rms over the points, rod lengths): as the ideal-field shape design's
ACCEPT_TOL = 1e-3
#: a step whose linearised fit would lower ½|miss|² by less than this fraction of itself ends the
#: search (the rms fit could change by ~half of it: far below any tolerance a lab states)
FIT_GAIN = 1e-10
#: every point met to this (rod lengths): the fit is exact to the positions' round-off, and stops
EXACT = 1e-12
#: the points met to this (rod lengths) leave a family of settings to choose the least effort
#: from (:func:`least_effort_fit`); a fit farther off is a least-squares minimum, one setting
FAMILY_TOL = 1e-6
#: Gauss–Newton iterations from each start (each one forward evaluation at least); the verdict rests
#: on the fit, the limits and stability, never on this count
MAX_ITERATIONS = 60


@dataclass(kw_only=True)
class ShapeFit:
    """What a shape design over hardware adds to its design's result (lengths in rod lengths).

    Attributes
    ----------
    points : ndarray, shape (k, 3)
        The target points s, x, y.
    fitted : ndarray, shape (k, 2)
        The design state's centreline at the same s.
    rms_error, max_error : float
        Of |r(s_i) − target_i| over the points. ``tip_error`` is a tip design's measure over every
        point, the largest |dx| or |dy|, and ``worst_tip_error`` its largest over the box's corners
        (nan where a corner was not reached); ``target`` is the last point.
    accept_tol : float
        The rms fit a success needs.
    """

    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    fitted: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rms_error: float = math.nan
    max_error: float = math.nan
    accept_tol: float = ACCEPT_TOL

    def _repr_parts(self) -> list:
        return [f"rms_error={self.rms_error:.3g}"]

    def shape_dict(self) -> dict:
        """The ``shape`` key of the JSON contract."""
        return {"points": [{"s": float(s), "x": float(x), "y": float(y)} for s, x, y in self.points],
                "fitted": [{"x": float(x), "y": float(y)} for x, y in self.fitted],
                "rms_error": self.rms_error, "max_error": self.max_error, "accept_tol": self.accept_tol}


def check_points(points, accept_tol: float, what: str) -> np.ndarray:
    """The points as an array (k, 3); ValueError naming ``what`` for rows that are not (s, x, y)
    with s in (0, 1] increasing, or a non-positive ``accept_tol``."""
    pts = np.asarray(points, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or not len(pts) or not np.all(np.isfinite(pts)) \
            or np.any(pts[:, 0] <= 0) or np.any(pts[:, 0] > 1) or np.any(np.diff(pts[:, 0]) <= 0):
        raise ValueError(f"design over {what}: the shape is rows (s, x, y) with s in (0, 1] increasing and x, y "
                         "finite (rod lengths)")
    if not (math.isfinite(accept_tol) and accept_tol > 0):
        raise ValueError(f"design over {what}: accept_tol must be a positive number, got {accept_tol!r}")
    return pts


class ShapeMap:
    """A hardware map's points, with the centreline at the targets' arc lengths as the "tip": a
    point's ``tip`` is (x_1..x_k, y_1..y_k) and ``tip_jac`` its derivative in v (2k, n), so that
    the tip design's least-miss step serves the fit unchanged; ``tip_point`` is the rod's tip."""

    def __init__(self, hmap: HardwareMap, s_points: np.ndarray):
        self.hmap = hmap
        self.f_points = arc_points_function(hmap.solver.transcription, s_points)

    def positions(self, z: np.ndarray):
        x, y, jx, jy = (np.asarray(v, float) for v in self.f_points(z))
        return x.ravel(), y.ravel(), jx, jy

    def evaluate(self, v: np.ndarray) -> Optional[dict]:
        pt = self.hmap.evaluate(v)
        if pt is None:
            return None
        x, y, jx, jy = self.positions(pt["z"])
        du = self.hmap.state_derivative(pt["z"], v)
        return {**pt, "tip_point": pt["tip"], "tip": np.concatenate([x, y]),
                "tip_jac": np.vstack([jx[:, 1:] @ du, jy[:, 1:] @ du])}

def fit(prob, smap: ShapeMap, w0: np.ndarray, accept_tol: float) -> tuple:
    """Gauss–Newton in a trust region from ``w0`` (see the module docstring): (the end, the
    solves it took), the end (w, point, iterations, settled) or None where the start's state from
    rest does not keep the limits. ``settled``: it ended met exactly or stationary (the linearised
    fit gains nothing, or no step within the limits lowers it), not stalled, cut short by its trust
    region or by :data:`MAX_ITERATIONS`."""
    n0 = smap.hmap.solves
    pt = smap.evaluate(w0)
    if pt is None or not within_limits(prob, w0, pt):
        return None, smap.hmap.solves - n0
    w, delta, it, settled = np.asarray(w0, float).copy(), DELTA_START, 0, False
    half = lambda p: 0.5 * float(np.sum((p["tip"] - prob.target) ** 2))
    history, k = [], prob.target.size // 2
    for it in range(1, MAX_ITERATIONS + 1):
        history.append(half(pt))
        if float(np.max(np.abs(pt["tip"] - prob.target))) <= EXACT:
            settled = True  # met to round-off of the positions: nothing left to gain
            break
        if (len(history) > STALL_ITERATIONS and math.sqrt(2 * history[-1] / k) > accept_tol
                and history[-1] > (1 - STALL_FRACTION) * history[-1 - STALL_ITERATIONS]):
            break  # off the accepted fit, the miss no longer shrinks (the nearest shape found: the
            # minimum may sit where the state from rest changes branch, a kink the steps crawl along)
        e, J = pt["tip"] - prob.target, pt["tip_jac"]
        d = _least_miss_step(prob, w, pt, delta)
        if d is None:  # no step within the limits lowers the linearised miss: they hold it here
            settled = True
            break
        step = float(np.max(np.abs(d) / prob.half))
        pred = half(pt) - 0.5 * float(np.sum((e + J @ d) ** 2))
        # stationary: the linearised fit gains less than FIT_GAIN of itself (the nearest shape of
        # a target out of reach, where Gauss–Newton converges only linearly), or nothing is left
        # (a step that small may still be worth taking where the field is weak and a current
        # moves the rod little: only its gain decides)
        if pred <= FIT_GAIN * half(pt) or pred <= 1e-30:
            settled = True
            break
        new = smap.evaluate(w + d)
        if new is not None and within_limits(prob, w + d, new) and half(pt) - half(new) >= 0.1 * pred:
            ratio = (half(pt) - half(new)) / pred
            w, pt = w + d, new
            if ratio >= 0.75 and step >= 0.99 * delta:
                delta = min(2 * delta, DELTA_MAX)
            elif ratio < 0.25:
                delta = step / 2
            continue
        delta = step / 4
        if delta < DELTA_MIN:
            break
    return (w, pt, it, settled), smap.hmap.solves - n0

def best_fit(prob, smap: ShapeMap, starts, accept_tol: float) -> Optional[tuple]:
    """The fit from each start (the first here, the others forked beside it), the best (least
    squared miss; ties within 1e-9 relative keep the earlier start), or None. ``smap.hmap.solves``
    counts every run's solves, wherever it ran."""
    base = smap.hmap.solves
    beside = [forked.start(lambda ws=ws: fit(prob, smap, ws, accept_tol)) for ws in starts[1:]]
    runs = [fit(prob, smap, starts[0], accept_tol)] + [b.result() for b in beside]
    smap.hmap.solves = base + sum(n for _, n in runs)
    best, least = None, math.inf
    for run, _ in runs:
        if run is None:
            continue
        miss = float(np.sum((run[1]["tip"] - prob.target) ** 2))
        if miss < least * (1 - 1e-9):
            best, least = run, miss
    return best


def least_effort_fit(prob, smap: ShapeMap, w: np.ndarray, pt: dict, iterations: int, accept_tol: float,
                     progress=None) -> tuple:
    """Where the points are met (to :data:`FAMILY_TOL`) and leave a family of settings (the points
    resolve fewer directions than there are unknowns: more coils than equations, or a magnet's pose
    moved along a curve of equal shapes): the least effort among the fits as good (every coordinate
    within twice its miss, at least the tip design's tolerance: near the straight rod a point's
    motion along it is second order, and the fit stalls ~1e-7 short of exact), by the tip design's
    feasible descent on the directions the points resolve, so that the setting is one answer, not
    the point of the family the search ended on. The descent's end is taken only if every
    coordinate stays within that bound and the rms fit within ``accept_tol``. Elsewhere (the fit
    fixes the setting, or a least-squares fit off the points, whose minimiser is one point) the
    setting stays. Returns (w, point, iterations, least_effort, descended)."""
    e = pt["tip"] - prob.target
    miss = float(np.max(np.abs(e)))
    sv = np.linalg.svd(pt["tip_jac"] * prob.half, compute_uv=False)
    resolved = int(np.sum(sv >= RESOLVED * sv[0])) if sv.size and sv[0] > 0 else 0
    if not (miss <= FAMILY_TOL and resolved < w.size):
        return w, pt, iterations, False, False  # the fit fixes the setting (or is a least-squares fit: no family)
    keep = replace(prob, tip_tol=max(prob.tip_tol, 2.0 * miss))
    w2, pt2, iterations, least = _feasible_descent(keep, smap.evaluate, w, pt, iterations, [], progress)
    e2 = pt2["tip"] - prob.target
    if float(np.max(np.abs(e2))) > keep.tip_tol or math.sqrt(np.mean(e2 ** 2) * 2) > accept_tol:
        return w, pt, iterations, False, False  # (never trade the fit for effort: the point before stands)
    return w2, pt2, iterations, bool(least), True


def record_fit(out: ShapeFit, pt: dict) -> None:
    """The fit of the point ``pt`` in ``out``: ``fitted``, rms and largest miss, ``tip_error``."""
    k = len(out.points)
    out.fitted = np.column_stack([pt["tip"][:k], pt["tip"][k:]])
    err = np.hypot(*(out.fitted - out.points[:, 1:]).T)
    out.rms_error, out.max_error = float(np.sqrt(np.mean(err ** 2))), float(np.max(err))
    out.tip_error = float(np.max(np.abs(out.fitted - out.points[:, 1:])))  # a tip design's: the largest |dx|, |dy|

def verify_points(out: ShapeFit, refitted, options) -> None:
    """Solve the refitted scene from rest; its centreline at the points must agree with the
    design's to :data:`VERIFY_TOL` (and the state be stable)."""
    r = solve(refitted, options)
    ev = r.evaluate(out.points[:, 0])
    got = np.column_stack([np.asarray(ev["x"], float), np.asarray(ev["y"], float)])
    err = float(np.max(np.hypot(*(got - out.fitted).T)))
    fit = np.hypot(*(got - out.points[:, 1:]).T)
    out.verification = {"tip": {"x": r.tip["x"], "y": r.tip["y"], "angle": r.tip["angle"]}, "error": err,
                        "rms_error": float(np.sqrt(np.mean(fit ** 2))), "success": bool(r.success),
                        "stable": bool(r.stable), "status": r.status}
    out.verified = bool(r.success and r.stable and err <= VERIFY_TOL)


def corner_fit(smap: ShapeMap, corner: dict, points: np.ndarray) -> dict:
    """A box corner's fit (``tip_error``: the largest |dx|, |dy| over the points; ``rms_error``),
    nan where the corner's state from rest was not reached."""
    if "z" in corner:
        x, y, _, _ = smap.positions(corner["z"])
        dx, dy = x - points[:, 1], y - points[:, 2]
    else:
        dx = dy = np.full(len(points), math.nan)
    return {"tip_error": float(np.max(np.maximum(np.abs(dx), np.abs(dy)))),
            "rms_error": float(np.sqrt(np.mean(dx ** 2 + dy ** 2)))}


def judge_fit(out, prob, w: np.ndarray, pt: dict, settled: bool) -> None:
    """The verdict of a shape design whose fit, verification and box are recorded in ``out``."""
    judge(out, out.box)  # verified, and on the designed branch and stable at every corner
    out.success = bool(out.success and out.rms_error <= out.accept_tol)
    # off the accepted fit: a search that stalled or ran out of steps where no limit binds and the
    # points' Jacobian is thin (as the tip design judges, current_sqp._stopped_short) stopped short,
    # and the shape may still be reachable; else it found its nearest shape
    short = not settled and _stopped_short(prob, w, pt)
    out.status = ("success" if out.success else
                  ("not_converged" if short else "unreachable") if out.rms_error > out.accept_tol
                  else "not_verified" if not out.verified else "not_robust")


def fit_message(out, setting: str, hardware: str) -> str:
    """The closing message: ``setting`` (the currents, the pose) fits the points, the verdicts;
    ``hardware`` names what else might reach the shape ("setting of the currents within the limits")."""
    k = len(out.points)
    text = (f"{setting} fit{'s' * setting.startswith('the magnet')} the {k} point{'s' * (k != 1)} with rms error "
            f"{out.rms_error:.3g} (largest {out.max_error:.3g}) rod lengths")
    if out.status == "not_converged" and out.rms_error > out.accept_tol:
        text += (f"; NOT within the accepted {out.accept_tol:g} rms, and the search stopped short there (it no "
                 f"longer gained, or ran out of steps) with no limit binding: the shape may be reachable by a "
                 f"{hardware}, but none was found")
    elif out.rms_error > out.accept_tol:
        binds = f" ({', '.join(out.limits_active)} at the limit)" if out.limits_active else ""
        text += (f"; NOT within the accepted {out.accept_tol:g} rms: the nearest shape found (a local search, "
                 f"not certified the nearest){binds}")
    return out.closing_message(text, what="points")
