"""Coil currents for a target shape (issue 19 item 2 beyond the tip): the currents within each
driver's limit whose rod, loaded from rest, passes nearest the points (s_i, x_i, y_i), in least
squares,

    min_w  ½ Σ_i |r(s_i; w) − (x_i, y_i)|²    within the limits of :mod:`.current_sqp`
           (|I_k| ≤ I_max,k; Σ R_k I_k² ≤ P_max; |μ0 H| ≤ B_max on the rod),

with r(s) the centreline of the state from rest at the coil weights w (I_k = w_k × the configured
current), on the forward map (:class:`~actuator_design.hardware.current_map.CurrentMap`: the state
and its exact implicit derivative; the points r(s_i) are exact linear-then-trigonometric maps of
the nodal angles, :mod:`actuator_design.transcription.arc_points`).

The search is Gauss–Newton in a trust region (each step the least linearised miss within the box,
the power and the linearised field limit: the tip design's least-miss step,
:func:`~actuator_design.hardware.current_sqp._least_miss_step`), a step taken when the state from
rest there keeps every limit and lowers the miss by at least a tenth of the predicted decrease. It
stops where the points are met to :data:`EXACT` or the linearised fit would gain less than
:data:`FIT_GAIN` of itself, or, while the fit is not yet accepted, where the miss shrank by less than 0.1 % over six
iterations (the nearest shape: its minimum may sit where the state from rest changes branch, a
kink the steps only crawl along). It runs from the tip design's screened starts (the last point
taken as a tip target), each in a forked copy of this process, and keeps the best fit. With more
coils than equations (2 per point) and the fit accepted, the tip design's feasible descent then
lowers the power among the fits as good (every coordinate kept within twice its miss, at least the
tip design's tolerance; ``least_effort`` says whether it settled); otherwise the fit fixes the
currents. Then, as every design over hardware: **verified** on
magpylib's field refitted at the currents (solved from rest on its own mesh: the points must agree
with the design's to :data:`~actuator_design.hardware.design.VERIFY_TOL` and the state be stable),
and **judged over the lab's tolerance box** (every corner switched on from rest must be stable and
on the designed branch; the worst fit over the corners is reported). A success also fits the shape
within ``accept_tol`` (rms, rod lengths); a nearer shape the limits and the rod do not allow is
``unreachable``, with the nearest fit found (a local search: not certified the nearest).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from actuator_design import forked
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.hardware.current_design import (CurrentDesign, _active, _corners, _even, _field_report,
                                                     _screen, coil_problem, scene_at_currents)
from actuator_design.hardware.current_map import CurrentMap, at_weights
from actuator_design.hardware.current_sqp import (DELTA_MAX, DELTA_MIN, DELTA_START, STALL_FRACTION,
                                                  STALL_ITERATIONS, _feasible_descent, _least_miss_step, _stopped_short,
                                                  within_limits)
from actuator_design.hardware.design import VERIFY_TOL
from actuator_design.model.scene import Scene
from actuator_design.robust.tolerances import Tolerances, apply_deltas
from actuator_design.transcription.arc_points import arc_points_function

__all__ = ["design_current_shape", "CurrentShapeDesign", "ACCEPT_TOL", "MAX_ITERATIONS", "FIT_GAIN", "EXACT"]

#: the fit a success needs by default (rms over the points, rod lengths): as the ideal-field shape design's
ACCEPT_TOL = 1e-3
#: a step whose linearised fit would lower ½|miss|² by less than this fraction of itself ends the
#: search (the rms fit could change by ~half of it: far below any tolerance a lab states)
FIT_GAIN = 1e-10
#: every point met to this (rod lengths): the fit is exact to the positions' round-off, and stops
EXACT = 1e-12
#: Gauss–Newton iterations from each start (each one forward evaluation at least); the verdict rests
#: on the fit, the limits and stability, never on this count
MAX_ITERATIONS = 60


@dataclass
class CurrentShapeDesign(CurrentDesign):
    """The result of :func:`design_current_shape` (currents in A, lengths in rod lengths).

    Attributes
    ----------
    points : ndarray, shape (k, 3)
        The target points s, x, y.
    fitted : ndarray, shape (k, 2)
        The design state's centreline at the same s.
    rms_error, max_error : float
        Of |r(s_i) − target_i| over the points (rod lengths). ``tip_error`` is a tip design's
        measure over every point, the largest |dx| or |dy|, and ``worst_tip_error`` its largest over
        the box's corners (nan where a corner was not reached); ``target`` is the last point.
    accept_tol : float
        The rms fit a success needs.
    """

    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    fitted: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rms_error: float = math.nan
    max_error: float = math.nan
    accept_tol: float = ACCEPT_TOL

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``design --target-shape`` on a coil scene (the keys of
        a coil design, and ``shape``)."""
        out = super().to_dict()
        out["shape"] = {"points": [{"s": float(s), "x": float(x), "y": float(y)} for s, x, y in self.points],
                        "fitted": [{"x": float(x), "y": float(y)} for x, y in self.fitted],
                        "rms_error": self.rms_error, "max_error": self.max_error, "accept_tol": self.accept_tol}
        return out


class _ShapeMap:
    """The forward map's points, with the centreline at the targets' arc lengths as the "tip": a
    point's ``tip`` is (x_1..x_k, y_1..y_k) and ``tip_jac`` its derivative in w (2k, n), so that
    the tip design's least-miss step serves the fit unchanged."""

    def __init__(self, cmap: CurrentMap, s_points: np.ndarray):
        self.cmap = cmap
        self.f_points = arc_points_function(cmap.solver.transcription, s_points)

    def positions(self, z: np.ndarray):
        x, y, jx, jy = (np.asarray(v, float) for v in self.f_points(z))
        return x.ravel(), y.ravel(), jx, jy

    def evaluate(self, w: np.ndarray) -> Optional[dict]:
        pt = self.cmap.evaluate(w)
        if pt is None:
            return None
        x, y, jx, jy = self.positions(pt["z"])
        du = self.cmap.state_derivative(pt["z"], w)
        return {**pt, "tip_point": pt["tip"], "tip": np.concatenate([x, y]),
                "tip_jac": np.vstack([jx[:, 1:] @ du, jy[:, 1:] @ du])}


def _fit(prob, smap: _ShapeMap, w0: np.ndarray, accept_tol: float) -> tuple:
    """Gauss–Newton in a trust region from ``w0`` (see the module docstring): (the end, the
    solves it took), the end (w, point, iterations, settled) or None where the start's state from
    rest does not keep the limits. ``settled``: it ended met exactly or stationary (the linearised
    fit gains nothing, or no step within the limits lowers it), not stalled, cut short by its trust
    region or by :data:`MAX_ITERATIONS`."""
    n0 = smap.cmap.solves
    pt = smap.evaluate(w0)
    if pt is None or not within_limits(prob, w0, pt):
        return None, smap.cmap.solves - n0
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
    return (w, pt, it, settled), smap.cmap.solves - n0


def design_current_shape(scene: Scene, points, *, tolerances: Optional[Tolerances] = None,
                         options: Optional[SolverOptions] = None, verify: bool = True,
                         accept_tol: float = ACCEPT_TOL,
                         progress: Optional[Callable[[str], None]] = None) -> CurrentShapeDesign:
    """The coil currents whose rod passes nearest ``points`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene with a coil field (the configured currents start the design).
    points : array_like, shape (k, 3)
        s ∈ (0, 1], x, y (rod lengths) of each target point
        (:func:`~actuator_design.inverse.shape.read_shape_points` reads them from a CSV).
    tolerances : Tolerances, optional
        The lab's tolerance box (default ±5 % on each current, ±2° on the mount).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solve from rest (a design without it is not a success).
    accept_tol : float
        The rms fit a success needs (rod lengths).

    Returns
    -------
    CurrentShapeDesign
        Never raises for a shape out of reach (``status="unreachable"``); raises ValueError for
        points that are not (s, x, y) rows, a scene without coils or a coil without a current limit.
    """
    t0 = time.perf_counter()
    pts = np.asarray(points, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or not len(pts) or not np.all(np.isfinite(pts)) \
            or np.any(pts[:, 0] <= 0) or np.any(pts[:, 0] > 1) or np.any(np.diff(pts[:, 0]) <= 0):
        raise ValueError("design over currents: the shape is rows (s, x, y) with s in (0, 1] increasing and x, y "
                         "finite (rod lengths)")
    if not (math.isfinite(accept_tol) and accept_tol > 0):
        raise ValueError(f"design over currents: accept_tol must be a positive number, got {accept_tol!r}")
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    k = len(pts)
    tip_prob = coil_problem(scene, pts[-1, 1:])  # the screen ranks its starts by the last point
    prob = replace(tip_prob, target=np.concatenate([pts[:, 1], pts[:, 2]]))
    coils = scene.field.sources
    i0 = np.array([c.current for c in coils])
    out = CurrentShapeDesign(success=False, status="not_converged", message="", target=tuple(pts[-1, 1:].tolist()),
                             coils=tuple(getattr(c, "name", "") or f"coil {j + 1}" for j, c in enumerate(coils)),
                             start_currents=tuple(i0.tolist()), max_current=tuple(c.max_current for c in coils),
                             resistance=tuple(c.resistance for c in coils), tolerances=tol, points=pts,
                             accept_tol=accept_tol)
    w0 = np.ones(i0.size)
    start = solve(at_weights(scene, w0), options)
    if not (start.success and start.stable):
        out.message = f"the state from rest at the configured currents did not converge: {start.message}"
        return out
    cmap = CurrentMap(scene, start, w0)
    smap = _ShapeMap(cmap, pts[:, 0])
    starts = _screen(cmap, tip_prob, _even(scene), progress)
    best = _best_fit(prob, smap, starts, accept_tol)
    if best is None:
        out.message = ("no start currents within the limits gave a stable state from rest (the configured "
                       "currents and the screen's ramps)")
        return out
    w, pt, out.iterations, settled = best
    miss = float(np.max(np.abs(pt["tip"] - prob.target)))
    out.effort = "fit"  # what was minimised: the fit alone, unless the descent below runs
    if i0.size > prob.target.size and math.sqrt(np.mean((pt["tip"] - prob.target) ** 2) * 2) <= accept_tol:
        # more coils than the points fix, the fit accepted: the least power among the fits as good
        # (every coordinate within twice its miss, at least the tip design's tolerance: near the
        # straight rod a point's motion along it is second order, and the fit stalls ~1e-7 short of
        # exact), by the tip design's feasible descent; the currents are then one answer, not one
        # point of a family the search happened to end on
        keep = replace(prob, tip_tol=max(prob.tip_tol, 2.0 * miss))
        w, pt, out.iterations, out.least_effort = _feasible_descent(keep, smap.evaluate, w, pt, out.iterations,
                                                                    [], progress)
        out.effort = "power" if prob.power is not None else "current_squared"
    currents = w * i0
    if _even(scene) and currents[np.argmax(np.abs(currents) > 1e-6 * np.max(np.abs(currents)))] < 0:
        w = -w  # one representative of ±I (the same state of a soft rod): the first coil carrying current positive
        pt = smap.evaluate(w)
    out.currents = tuple((w * i0).tolist())
    out.state = cmap.result(w, pt["z"])
    out.tip = pt["tip_point"]
    out.fitted = np.column_stack([pt["tip"][:k], pt["tip"][k:]])
    err = np.hypot(*(out.fitted - pts[:, 1:]).T)
    out.rms_error, out.max_error = float(np.sqrt(np.mean(err ** 2))), float(np.max(err))
    out.tip_error = float(np.max(np.abs(out.fitted - pts[:, 1:])))  # as a tip design's: the largest |dx|, |dy|
    out.power = float(np.dot(prob.power, w * w)) if prob.power is not None else math.nan
    out.field_at_clamp, out.max_rod_field = _field_report(scene, w, pt["limit"])
    out.limits_active = _active(prob, w, pt)
    if verify:
        _verify(out, smap, scene_at_currents(scene, w * i0), options)
    out.box = _box(smap, w, out.state, tol, pts, pt["tip_jac"][[k - 1, 2 * k - 1]], i0)
    worst = [c["tip_error"] for c in out.box]
    out.worst_tip_error = (max(worst, default=out.tip_error) if all(math.isfinite(v) for v in worst)
                           else math.nan)  # a corner not reached: no worst miss to state
    out.holds_over_box = all(c["success"] and c["stable"] and c["same_branch"] for c in out.box)
    out.success = bool(out.verified and out.holds_over_box and out.rms_error <= accept_tol)
    # off the accepted fit: a search that stalled or ran out of steps where no limit binds and the
    # points' Jacobian is thin (as the tip design judges, current_sqp._stopped_short) stopped short,
    # and the shape may still be reachable; else it found its nearest shape
    short = not settled and _stopped_short(prob, w, pt)
    out.status = ("success" if out.success else
                  ("not_converged" if short else "unreachable") if out.rms_error > accept_tol
                  else "not_verified" if not out.verified else "not_robust")
    out.solves, out.seconds = cmap.solves, time.perf_counter() - t0
    out.message = _message(out)
    return out


def _best_fit(prob, smap: _ShapeMap, starts, accept_tol: float) -> Optional[tuple]:
    """The fit from each start (the first here, the others forked beside it), the best (least
    squared miss; ties within 1e-9 relative keep the earlier start), or None. ``smap.cmap.solves``
    counts every run's solves, wherever it ran."""
    base = smap.cmap.solves
    beside = [forked.start(lambda ws=ws: _fit(prob, smap, ws, accept_tol)) for ws in starts[1:]]
    runs = [_fit(prob, smap, starts[0], accept_tol)] + [b.result() for b in beside]
    smap.cmap.solves = base + sum(n for _, n in runs)
    best, least = None, math.inf
    for run, _ in runs:
        if run is None:
            continue
        miss = float(np.sum((run[1]["tip"] - prob.target) ** 2))
        if miss < least * (1 - 1e-9):
            best, least = run, miss
    return best


def _verify(out: CurrentShapeDesign, smap: _ShapeMap, refitted: Scene, options) -> None:
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


def _box(smap: _ShapeMap, w, state, tol: Tolerances, pts: np.ndarray, last_jac: np.ndarray, currents0) -> list:
    """Every corner of the box switched on from rest: its fit (largest miss over the points as
    ``tip_error``, and ``rms_error``), ``success`` (reached), ``stable``, ``same_branch``."""
    cmap, out = smap.cmap, []
    for signs, mount, deltas in _corners(tol, w, last_jac, 2):
        wc = w * (1 + tol.field_rel * signs)
        sc = apply_deltas(at_weights(cmap.scene, wc), deltas) if deltas else at_weights(cmap.scene, wc)
        sc = replace(sc, theta0=sc.theta0 + mount)
        c = cmap.corner(sc, state.z)
        if "z" in c:
            x, y, _, _ = smap.positions(c["z"])
            dx, dy = x - pts[:, 1], y - pts[:, 2]
        else:
            dx = dy = np.full(len(pts), math.nan)
        tip = c["tip"]
        out.append({"currents_A": list(wc * currents0), "mount_deg": math.degrees(mount), **deltas,
                    "tip": {"x": tip[0], "y": tip[1], "angle": tip[2]},
                    "tip_error": float(np.max(np.maximum(np.abs(dx), np.abs(dy)))),
                    "rms_error": float(np.sqrt(np.mean(dx ** 2 + dy ** 2))),
                    "success": c["reached"], "stable": c["stable"], "same_branch": c["same_branch"]})
    return out


def _message(out: CurrentShapeDesign) -> str:
    cur = ", ".join(f"{i:.6g} A" for i in out.currents)
    text = (f"currents {cur} fit the {len(out.points)} points with rms error {out.rms_error:.3g} (largest "
            f"{out.max_error:.3g}) rod lengths")
    if out.status == "not_converged" and out.rms_error > out.accept_tol:
        text += (f"; NOT within the accepted {out.accept_tol:g} rms, and the search stopped short there (it no "
                 "longer gained, or ran out of steps) with no limit binding: the shape may be reachable by a "
                 "setting of the currents within the limits, but none was found")
    elif out.rms_error > out.accept_tol:
        binds = f" ({', '.join(out.limits_active)} at the limit)" if out.limits_active else ""
        text += (f"; NOT within the accepted {out.accept_tol:g} rms: the nearest shape found (a local search, "
                 f"not certified the nearest){binds}")
    return out.closing_message(text, what="points")
