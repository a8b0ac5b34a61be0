"""Schedules over a permanent magnet's pose (issue 19 item 2): where the stage moves the magnet, in
time, so that the tip of the rod passes through waypoints, within the stage's travel and speeds.

1. **Waypoint poses.** From the configured pose (the rod loaded from rest there), each waypoint's
   pose is found by the trust-region SQP of the pose design (:mod:`actuator_design.hardware.pose_design`, exact implicit
   derivatives on the forward map), started at the previous waypoint's pose and measuring the move
   from it in time: the least Σ_i (Δ_i / rate_i)², Δ_i each coordinate's move and rate_i the stage's
   speed (x, y) or turn rate (axis angle) — the L2 proxy of the straight move's duration
   max_i |Δ_i| / rate_i. A waypoint not reached from there is searched from a screen of the travel.
2. **Moves.** The stage moves in straight lines in (x, y, angle) between the waypoint poses, each
   axis at its own rate: a move lasts max_i |Δ_i| / rate_i, the least a stage whose axes are
   limited independently can do between those poses. A travel of a whole turn is a turntable that
   turns without end (as in the pose design): each move turns the short way round.
3. **Verification.** The schedule is replayed as one quasi-static loading path from the configured
   pose through every step (:func:`~actuator_design.schedules.schedule.verify_schedule`: no snap, every state stable, each
   waypoint hit to 1e-6), every state where the magnet's fit holds (outside the sphere about it
   that holds the magnet itself).
4. **Quasi-static?** With the rod's density, each replayed state's relaxation time is compared with
   its step's duration (:func:`~actuator_design.schedules.dynamics.quasi_static`), as for every timed schedule.

Units: positions in m, angles in rad, times in s; the tip in rod lengths. The rod's clearance from
the magnet's fit region is checked at the schedule's steps (more ``substeps`` check more finely).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene
from actuator_design.schedules.dynamics import quasi_static
from actuator_design.hardware.design import run_starts
from actuator_design.hardware.map import HardwareMap
from actuator_design.hardware.pose_design import _better, _screen
from actuator_design.hardware.pose_problem import at_pose, clearance, pose_problem
from actuator_design.schedules.schedule import ScheduleResult, verify_schedule

__all__ = ["pose_schedule", "PoseSchedule"]


@dataclass(repr=False)
class PoseSchedule:
    """A schedule of a magnet's pose through tip waypoints.

    Attributes
    ----------
    success : bool
        The schedule is verified from the configured pose, every state stable and where the
        magnet's fit holds.
    status : str
        ``"success"``, ``"unreachable"`` (a waypoint no pose within the travel reaches),
        ``"not_converged"`` (no state from rest at the configured pose) or ``"not_verified"``.
    positions : list of (float, float)
        The magnet's centre at every step, m (step 0: the configured pose).
    axis_angles : list of float
        Its axis at every step, rad.
    times : list of float
        s, from 0.
    waypoint_index : list of int
        The step of each waypoint.
    speed, turn_rate : float
        The stage's speed (m/s, each of x and y) and turn rate (rad/s); NaN where not given (that
        coordinate does not move).
    verification : ScheduleResult
        The replayed loading path (``rows``: per waypoint; ``states``).
    quasi_static, step_dynamics
        As :class:`~actuator_design.schedules.current_schedule.CurrentSchedule`'s (None / empty without the rod's density).
    solves : int
        Forward solves of the waypoint search.
    """

    success: bool
    status: str
    message: str
    waypoints: List[tuple]
    speed: float
    turn_rate: float
    positions: List[tuple] = field(default_factory=list)
    axis_angles: List[float] = field(default_factory=list)
    times: List[float] = field(default_factory=list)
    waypoint_index: List[int] = field(default_factory=list)
    verification: Optional[ScheduleResult] = None
    quasi_static: Optional[dict] = None
    step_dynamics: List[dict] = field(default_factory=list)
    solves: int = 0
    timings: Dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        """One line: the verdict, the waypoints and the schedule's duration (s)."""
        return (f"PoseSchedule(status={self.status!r}, success={self.success}, waypoints={len(self.waypoints)}, "
                f"steps={len(self.times)}, duration={self.duration:.6g})")

    @property
    def duration(self) -> float:
        """s (NaN before a schedule exists)."""
        return self.times[-1] if self.times else math.nan

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``schedule --json`` on a scene with a moving magnet
        (positions in mm, angles in deg, times in s, the tip in rod lengths)."""
        rows = self.verification.rows if self.verification is not None else []
        finite = lambda v: None if not math.isfinite(v) else v
        steps = []
        for k, (p, a, t) in enumerate(zip(self.positions, self.axis_angles, self.times)):
            dyn = self.step_dynamics[k] if k < len(self.step_dynamics) else {}
            steps.append({"step": k, "time_s": t, "x_mm": p[0] * 1e3, "y_mm": p[1] * 1e3,
                          "axis_angle_deg": math.degrees(a),
                          **{key: (finite(v) if isinstance(v, float) else v) for key, v in dyn.items()}})
        return {
            "success": bool(self.success), "status": self.status, "message": self.message,
            "waypoints": [{"x": w[0], "y": w[1]} for w in self.waypoints],
            "rows": [{("tip_angle_rad" if k == "angle" else k): v for k, v in r.items()
                      if not k.startswith("source_")} | {
                "x_mm": self.positions[i][0] * 1e3, "y_mm": self.positions[i][1] * 1e3,
                "axis_angle_deg": math.degrees(self.axis_angles[i])} for r, i in zip(rows, self.waypoint_index)],
            "schedule": steps, "waypoint_index": self.waypoint_index, "duration_s": finite(self.duration),
            "limits": {"speed_mm_per_s": finite(self.speed * 1e3), "turn_rate_deg_per_s": finite(math.degrees(self.turn_rate))},
            "quasi_static": self.quasi_static, "solves": self.solves, "timings_s": self.timings,
            "verification": self.verification.message if self.verification is not None else None,
            "units": {"length": "mm (the tip: rod length)", "angle": "deg", "time": "s"}}


def pose_schedule(scene: Scene, waypoints: Sequence[Sequence[float]], speed: Optional[float],
                  turn_rate: Optional[float], *,
                  substeps: int = 8, options: Optional[SolverOptions] = None,
                  progress: Optional[Callable[[str], None]] = None) -> PoseSchedule:
    """The magnet's poses in time through tip ``waypoints`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene whose field has one magnet with a ``travel`` (its configured pose starts).
    waypoints : sequence of (x, y)
        Tip positions, rod lengths, in visiting order (at least one).
    speed : float or None
        The stage's largest speed along each of x and y, m/s (> 0; None when neither moves).
    turn_rate : float or None
        Its largest turn rate, rad/s (> 0; None when the axis does not turn).
    substeps : int
        Schedule steps per move (the replay's points and the quasi-static check's steps).
    options : SolverOptions, optional
    progress : callable, optional
        Called with one line as each waypoint is searched.

    Returns
    -------
    PoseSchedule
        Never raises for an unreachable waypoint (``status``); raises ValueError for a scene without
        a moving magnet or bad waypoints, rates or substeps (one line naming the value and its range).
    """
    t0 = time.perf_counter()
    say = progress or (lambda line: None)
    options = options or SolverOptions()
    wps = [tuple(float(v) for v in w) for w in waypoints]
    if not wps or any(len(w) != 2 or not all(map(math.isfinite, w)) for w in wps):
        raise ValueError("waypoints: expected one or more finite (x, y) pairs, rod lengths")
    if not (isinstance(substeps, int) and 1 <= substeps <= 200):
        raise ValueError(f"substeps: must be a whole number in [1, 200], got {substeps!r}")
    var, _ = pose_problem(scene, wps[0])
    for name, value, unit, needed in (("speed", speed, "m/s", any(c < 2 for c in var.coords)),
                                      ("turn rate", turn_rate, "rad/s", 2 in var.coords)):
        if (needed or value is not None) and not (
                isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: must be a finite number > 0 ({unit}), got {value!r}")
    magnet = scene.field.sources[var.source]
    rates = np.array([speed / var.length if c < 2 else turn_rate for c in var.coords])  # per unit offset
    out = PoseSchedule(False, "not_converged", "", wps, math.nan if speed is None else float(speed),
                       math.nan if turn_rate is None else float(turn_rate))
    at = at_pose(var)
    v0 = np.zeros(len(var.coords))
    start = solve(at(scene, v0), options)
    if not (start.success and start.stable):
        out.message = f"the state from rest at the configured pose did not converge: {start.message}"
        return out
    pmap = HardwareMap(scene, start, v0, var.names, at, clearance(scene, var))
    turn = _whole_turn(var)
    vs, index, v_prev = [v0], [], v0
    for k, wp in enumerate(wps):
        say(f"waypoint {k + 1} of {len(wps)}: the pose soonest reached from the last one")
        _, prob = pose_problem(scene, wp)
        here = _within_turn(var, turn, v_prev)  # the previous pose, its axis within the travel's turn
        prob = replace(prob, cost=1.0 / rates ** 2, centre=here)  # the move measured in time
        better = lambda a, b, prob=prob: _better_from(prob, a, b)
        sqp = run_starts(pmap, prob, [here], better)
        if sqp is None or not sqp.reached:
            sqp = run_starts(pmap, prob, _screen(pmap, prob, var.coords), better)
        if sqp is None or not sqp.reached:
            near = "" if sqp is None else f" (nearest tip {float(np.max(np.abs(sqp.point['tip'][:2] - wp))):.3g} rod lengths off)"
            out.status, out.solves = "unreachable", pmap.solves
            out.message = f"waypoint {k} {wp}: no pose within the travel puts the tip there{near}"
            out.timings["total"] = time.perf_counter() - t0
            return out
        v_next = _short_way(turn, np.array(sqp.w, float), v_prev)
        vs += list(np.linspace(vs[-1], v_next, substeps + 1)[1:])
        index.append(len(vs) - 1)
        v_prev = v_next
    vs = np.array(vs)
    out.solves = pmap.solves
    out.timings["waypoints"] = time.perf_counter() - t0
    step_time = np.max(np.abs(np.diff(vs, axis=0)) / rates, axis=1)
    out.times = [0.0] + np.cumsum(step_time).tolist()
    poses = [var.pose(magnet, v) for v in vs]
    out.positions, out.axis_angles = [p for p, _ in poses], [a for _, a in poses]
    out.waypoint_index = index
    say("verifying the schedule by a loading path from the configured pose")
    t1 = time.perf_counter()
    steps = [dict(zip(var.names, map(float, v))) for v in vs]
    verified = verify_schedule(wps, scene, options, steps, index, max_step=1.0)
    out.timings["verify"] = time.perf_counter() - t1
    out.verification = verified
    ok, why = verified.success, verified.message
    if ok:
        for k, (st, v) in enumerate(zip(verified.states, vs)):
            region = at(scene, v).field.region_problem(st.x, st.y)
            if region is not None:
                ok, why = False, f"step {k}: the rod leaves where the magnet's fit holds ({region})"
                break
    table = [{"time_s": t} for t in out.times]
    out.quasi_static = quasi_static(verified.states, table, scene.scales)
    out.step_dynamics = [{k: v for k, v in row.items() if k != "time_s"} for row in table] \
        if out.quasi_static is not None else []
    out.success, out.status = bool(ok), "success" if ok else "not_verified"
    out.message = (f"{len(wps)} waypoint{'s' if len(wps) > 1 else ''} in {out.duration:.4g} s, verified from the "
                   "configured pose: no snap, every state stable" if ok else f"not verified: {why}")
    out.timings["total"] = time.perf_counter() - t0
    return out


def _whole_turn(var) -> Optional[int]:
    """The index of the axis angle among the pose's offsets when its travel is a whole turn (a
    turntable: every axis once, reached the short way, as :func:`~actuator_design.hardware.pose_problem.angle_offsets`)."""
    for i, c in enumerate(var.coords):
        if c == 2 and var.upper[i] - var.lower[i] >= 2 * math.pi - 1e-9:
            return i
    return None


def _within_turn(var, turn: Optional[int], v: np.ndarray) -> np.ndarray:
    """``v`` with a whole-turn axis angle brought into the travel's turn [lower, lower + 2π)."""
    v = np.array(v, float)
    if turn is not None:
        v[turn] = var.lower[turn] + (v[turn] - var.lower[turn]) % (2 * math.pi)
    return v


def _short_way(turn: Optional[int], v: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``v`` with a whole-turn axis angle replaced by its equivalent nearest ``ref``'s (a turntable
    that turns without end turns the short way round; others move as they are)."""
    v = np.array(v, float)
    if turn is not None:
        v[turn] = ref[turn] + (v[turn] - ref[turn] + math.pi) % (2 * math.pi) - math.pi
    return v


def _better_from(prob, a, b) -> bool:
    """:func:`~actuator_design.hardware.pose_design._better` with the move measured from the problem's centre."""
    return _better(replace(prob, centre=np.zeros_like(prob.centre)), _shifted(a, prob.centre),
                   _shifted(b, prob.centre))


def _shifted(outcome, centre):
    return replace(outcome, w=np.asarray(outcome.w, float) - centre)
