"""Schedules over coil currents (issue 19 items 2–3): the currents (A), in time, that move the tip
of a rod in the field of coils through waypoints, within the drivers' limits, with the least energy
∫ Σ R_k I_k² dt or in the least time.

1. **Greedy schedule** (the reference and the warm start): the least-power currents of each
   waypoint (:mod:`actuator_design.hardware.current_sqp` on the forward map :class:`~actuator_design.hardware.current_map.CurrentMap`; the first
   from the screened starts of :func:`~actuator_design.hardware.current_design.design_currents`, each next from the
   previous waypoint's currents, so the schedule stays on one branch), joined by straight lines
   in the currents from zero; each step lasts as long as the slowest coil's slew allows.
2. **Optimal control** (:class:`~actuator_design.schedules.current_schedule_nlp.CurrentOCP`): the currents at every
   time node and each leg's duration as one NLP — |I_k| ≤ max_current and Σ R I² ≤ max_power at
   every node, |ΔI_k| ≤ slew Δt every step, the coils off at the start and each waypoint's node at
   the greedy schedule's least-power currents (with either sign of each, for a rod whose energy is
   even in the field) — minimising the energy (J; ∫ Σ I_k² dt in A²·s without resistances) or the
   duration (then the least energy at it). The rod's states are not unknowns of this NLP (its
   module docstring says why): they are checked on the replayed path.
3. **Verification**: each schedule is replayed as one quasi-static loading path from zero
   currents through its steps (:func:`~actuator_design.schedules.schedule.verify_schedule`: no snap, every state stable,
   each waypoint hit to 1e-6, every state where the coils' fits hold); its limits, with |μ0 H| ≤
   max_field on the rod, are checked at every step on the replayed states. The optimised schedule is reported only when it is verified
   and no worse than the greedy one (to :data:`~actuator_design.schedules.schedule_ocp.NOT_WORSE_TOL`); otherwise the
   greedy one, and the message says why.
4. **Quasi-static?** With the rod's density, each replayed state's relaxation time
   (:mod:`actuator_design.schedules.dynamics`) is compared with its step's duration (issue 19 item 4): a step shorter than
   it leaves the rod lagging the currents, and the result says so (it is still reported).

Power along a straight line in the currents is convex in time, so its largest value is at a step's
ends: checking it at the steps checks it everywhere. The field on the rod is checked at the steps.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.hardware.current_design import _better, _coils, _even, _screen, coil_problem
from actuator_design.hardware.current_map import CurrentMap, at_weights
from actuator_design.hardware.design import run_starts
from actuator_design.inverse.settings import DesignSettings
from actuator_design.model.scene import Scene
from actuator_design.model.units import MU0
from actuator_design.physics.fields import field_model
from actuator_design.schedules.current_schedule_nlp import CurrentOCP
from actuator_design.schedules.dynamics import quasi_static
from actuator_design.schedules.schedule import ScheduleResult, verify_schedule
from actuator_design.schedules.schedule_ocp import (MAX_NODES, NOT_WORSE_TOL, OBJECTIVES, control_effort,
                                                    node_grid)

__all__ = ["current_schedule", "CurrentSchedule", "LIMIT_TOL"]

#: A limit is kept when the value exceeds it by at most this (relative): IPOPT's own tolerance.
LIMIT_TOL = 1e-6
#: The replayed path's largest step, a fraction of one schedule step (each is short already: the
#: NLP's nodes; the engine's step control and the 0.5 rad bound on any angle refine further)
VERIFY_STEP = 1.0
#: Up to this many waypoints every choice of the waypoint currents' signs is tried (2^(m−1) NLPs)
MAX_SIGN_WAYPOINTS = 6


@dataclass(repr=False)
class CurrentSchedule:
    """A schedule of coil currents through tip waypoints, and the greedy one it is compared with.

    Attributes
    ----------
    success : bool
        The reported schedule is verified from rest and keeps every limit at every step.
    status : str
        ``"success"``, ``"unreachable"`` (a waypoint no currents within the limits reach),
        ``"not_converged"`` (no state from rest at the configured currents), ``"not_verified"`` (the replayed path snapped, lost stability, missed a waypoint, left a fit's
        region, or a limit was exceeded).
    optimal : bool
        The optimised schedule is the one reported.
    currents : list of list of float
        Per step, A per coil (step 0: all zero).
    times : list of float
        The time (s) of each step.
    energy : float
        ∫ Σ R_k I_k² dt, J (``effort`` = ``"energy"``), or ∫ Σ I_k² dt, A² s (``"current_squared"``).
    duration : float
        s.
    greedy_currents, greedy_times, greedy_energy, greedy_duration
        The same of the greedy schedule.
    verification : ScheduleResult
        The replayed loading path of the reported schedule (``rows``: per waypoint; ``states``).
    extremes : dict
        Over the reported schedule's steps: the largest |I_k| / max_current, power / max_power,
        |μ0 H| on the rod (mT) / max_field, |dI_k/dt| / slew; the least eigenvalue of the replayed
        states (each must be ≥ the margin).
    quasi_static : dict or None
        The rod's slowest relaxation time along the reported schedule and the steps shorter than it
        (:func:`~actuator_design.schedules.dynamics.quasi_static`; issue 19 item 4); None without the rod's density.
    step_dynamics : list of dict
        Per step, ``relaxation_time_s`` of the state it arrives at, ``quasi_static`` (the step lasts
        at least that long) and ``tip_lag`` (rod lengths); empty without the density.
    """

    success: bool
    status: str
    message: str
    objective: str
    optimal: bool
    waypoints: List[tuple]
    nodes: int
    effort: str
    slew: List[float]
    max_current: List[float]
    max_power: float
    max_field_mT: float
    currents: List[List[float]] = field(default_factory=list)
    times: List[float] = field(default_factory=list)
    energy: float = math.nan
    duration: float = math.nan
    greedy_currents: List[List[float]] = field(default_factory=list)
    greedy_times: List[float] = field(default_factory=list)
    greedy_energy: float = math.nan
    greedy_duration: float = math.nan
    greedy_waypoint_index: List[int] = field(default_factory=list)
    waypoint_index: List[int] = field(default_factory=list)
    ocp_status: str = "not_solved"
    verification: Optional[ScheduleResult] = None
    extremes: Dict[str, float] = field(default_factory=dict)
    quasi_static: Optional[dict] = None
    step_dynamics: List[dict] = field(default_factory=list)
    timings: Dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        """One line: the verdict, the objective and both schedules' duration (s) and energy."""
        return (f"CurrentSchedule(status={self.status!r}, success={self.success}, optimal={self.optimal}, "
                f"objective={self.objective!r}, nodes={self.nodes}, duration={self.duration:.6g}, "
                f"energy={self.energy:.6g}, greedy_duration={self.greedy_duration:.6g}, "
                f"greedy_energy={self.greedy_energy:.6g})")

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``schedule --json`` on a coil scene (currents in A,
        times in s, the tip in rod lengths; the energy as ``energy`` with its ``energy_unit``, and
        as ``energy_J`` — or ``energy_A2_s`` when not every coil has a resistance)."""
        unit = "J" if self.effort == "energy" else "A2_s"
        rows = self.verification.rows if self.verification is not None else []
        finite = lambda v: None if not math.isfinite(v) else v
        return {
            "success": bool(self.success), "status": self.status, "message": self.message,
            "objective": self.objective, "optimal": bool(self.optimal), "nodes": self.nodes,
            "effort": self.effort, "ocp_status": self.ocp_status,
            "waypoints": [{"x": w[0], "y": w[1]} for w in self.waypoints],
            "rows": [{k: v for k, v in r.items() if not k.startswith("source_weight_")}
                     | {"currents_A": self.currents[i]} for r, i in zip(rows, self.waypoint_index)],
            "schedule": [{"step": k, "time_s": t, "currents_A": c, **self.step_relaxation(k)}
                         for k, (t, c) in enumerate(zip(self.times, self.currents))],
            "waypoint_index": self.waypoint_index, "duration_s": finite(self.duration), f"energy_{unit}": finite(self.energy),
            "energy": finite(self.energy), "energy_unit": "J" if unit == "J" else "A^2 s",
            "greedy": {"schedule": [{"step": k, "time_s": t, "currents_A": c}
                                    for k, (t, c) in enumerate(zip(self.greedy_times, self.greedy_currents))],
                       "waypoint_index": self.greedy_waypoint_index, "duration_s": finite(self.greedy_duration),
                       f"energy_{unit}": finite(self.greedy_energy)},
            "limits": {"slew_A_per_s": self.slew, "max_current_A": self.max_current,
                       "max_power_W": finite(self.max_power), "max_field_mT": finite(self.max_field_mT)},
            "extremes": self.extremes, "quasi_static": self.quasi_static, "timings_s": self.timings,
            "verification": self.verification.message if self.verification is not None else None,
            "units": {"length": "rod length", "angle": "rad", "current": "A", "time": "s"}}

    def step_relaxation(self, k: int) -> dict:
        """Step ``k``'s relaxation time (s; None when unstable), whether it lasts at least that long,
        and the tip lag (rod lengths), when known."""
        if k >= len(self.step_dynamics):
            return {}
        row = self.step_dynamics[k]
        tau = row["relaxation_time_s"]
        return {"relaxation_time_s": tau if math.isfinite(tau) else None, "quasi_static": row["quasi_static"],
                "tip_lag": row["tip_lag"] if math.isfinite(row["tip_lag"]) else None}


def current_schedule(scene: Scene, waypoints: Sequence[Sequence[float]], slew, *, objective: str = "energy",
                     nodes: int = 40, substeps: int = 8, options: Optional[SolverOptions] = None,
                     settings: Optional[DesignSettings] = None,
                     progress: Optional[Callable[[str], None]] = None) -> CurrentSchedule:
    """The schedule of coil currents through tip ``waypoints`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene whose field comes from coils, each with its ``max_current`` (and
        ``resistance`` for the energy in J); the field's ``max_power`` and ``max_field`` are kept.
    waypoints : sequence of (x, y)
        Tip positions, rod lengths, in visiting order (at least one).
    slew : float or sequence of float
        Largest |dI/dt| of each coil's driver, A/s (one value for all, or one per coil).
    objective : {"energy", "time"}
    nodes : int
        Time nodes of the optimal-control NLP: at least one more than the waypoints, at most
        :data:`~actuator_design.schedules.schedule_ocp.MAX_NODES`.
    substeps : int
        Greedy schedule points between consecutive waypoints.
    options : SolverOptions, optional
    settings : DesignSettings, optional
        ``margin``: the stability margin required at every node.
    progress : callable, optional
        Called with one line as each stage starts.

    Returns
    -------
    CurrentSchedule

    Raises
    ------
    ValueError
        A scene without coils or a coil without ``max_current``, bad waypoints, slew, objective
        or nodes (one line naming the value and its range).
    """
    t0 = time.perf_counter()
    say = progress or (lambda line: None)
    options, settings = options or SolverOptions(), settings or DesignSettings()
    coils = _coils(scene)
    wps = [tuple(float(v) for v in w) for w in waypoints]
    if not wps or any(len(w) != 2 or not all(map(math.isfinite, w)) for w in wps):
        raise ValueError("waypoints: expected one or more finite (x, y) pairs, rod lengths")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if not (isinstance(substeps, int) and 1 <= substeps <= 200):
        raise ValueError(f"substeps: must be a whole number in [1, 200], got {substeps!r}")
    if not (isinstance(nodes, int) and len(wps) + 1 <= nodes <= MAX_NODES):
        raise ValueError(f"nodes: must be a whole number in [{len(wps) + 1}, {MAX_NODES}] (one more than the "
                         f"waypoints at least), got {nodes!r}")
    slew = np.broadcast_to(np.asarray(slew, float), (len(coils),)).copy() if np.ndim(slew) == 0 or \
        np.size(slew) == len(coils) else None
    if slew is None or not np.all(np.isfinite(slew) & (slew > 0)):
        raise ValueError(f"slew: one finite rate > 0 (A/s) for every coil, or one per coil ({len(coils)}), "
                         f"got {np.asarray(slew if slew is not None else [], float).tolist() or 'another count'}")
    i0 = np.array([c.current for c in coils])
    resist = np.array([c.resistance for c in coils])
    with_r = bool(np.all(np.isfinite(resist)))
    weight_effort = resist * i0 ** 2 if with_r else i0 ** 2  # W (or A²) per unit weight²
    f = scene.field
    out = CurrentSchedule(False, "not_verified", "", objective, False, wps, nodes,
                          "energy" if with_r else "current_squared", slew.tolist(),
                          [c.max_current for c in coils], f.max_power, f.max_field * MU0 * 1e3)
    names = [f"source_weight_{k}" for k in range(len(coils))]
    as_steps = lambda ws: [dict(zip(names, map(float, w))) for w in ws]
    step_times = lambda ws: np.concatenate([[0.0], np.cumsum(np.max(np.abs(np.diff(ws, axis=0)) * np.abs(i0) / slew,
                                                                     axis=1))])

    # 1. the greedy schedule
    say("greedy schedule: the least-power currents of each waypoint")
    ones = np.ones(len(coils))
    start = solve(at_weights(scene, ones), options)
    if not (start.success and start.stable):
        out.status = "not_converged"
        out.message = f"the state from rest at the configured currents did not converge: {start.message}"
        out.timings["total"] = time.perf_counter() - t0
        return out
    cmap = CurrentMap(scene, start, ones)
    ws, index, w_prev = [np.zeros(len(coils))], [], None
    for k, wp in enumerate(wps):
        prob = coil_problem(scene, wp)
        better = lambda a, b, prob=prob: _better(prob, a, b)
        # from the previous waypoint's currents (the first: the configured ones), else from the screen
        sqp = run_starts(cmap, prob, [w_prev if w_prev is not None else ones], better)
        if sqp is None or not sqp.reached:
            sqp = run_starts(cmap, prob, _screen(cmap, prob, _even(scene)), better)
        if sqp is None or not sqp.reached:
            out.status = "unreachable"
            near = "" if sqp is None else f" (nearest tip {float(np.max(np.abs(sqp.point['tip'][:2] - wp))):.3g} rod lengths off)"
            out.message = f"waypoint {k} {wp}: no currents within the limits put the tip there{near}"
            out.timings["total"] = time.perf_counter() - t0
            return out
        w_prev = sqp.w
        ws += list(np.linspace(ws[-1], w_prev, substeps + 1)[1:])
        index.append(len(ws) - 1)
    ws = np.array(ws)
    g_times = step_times(ws)
    out.timings["greedy"] = time.perf_counter() - t0
    out.greedy_currents, out.greedy_times = (ws * i0).tolist(), g_times.tolist()
    out.greedy_energy = control_effort(ws, g_times, weight_effort)
    out.greedy_duration, out.greedy_waypoint_index = float(g_times[-1]), list(index)

    def keep_greedy(why: str) -> None:
        """Report the greedy schedule, verified here (it is replayed only when it is reported)."""
        say("greedy schedule: verifying it by a loading path from zero currents")
        t1 = time.perf_counter()
        greedy = verify_schedule(wps, scene, options, as_steps(ws), index, max_step=VERIFY_STEP)
        out.timings["greedy_verify"] = time.perf_counter() - t1
        ok, greedy_why = _checked(greedy, scene, ws, g_times, i0, slew, out, settings.margin)
        _report(out, scene, ws, g_times, index, greedy, i0, out.greedy_energy, False,
                f"{why}: the greedy schedule is reported" + ("" if ok else f", and it was not verified: {greedy_why}"))
        out.success = out.success and ok
        out.status = "success" if out.success else "not_verified"

    # 2. optimal control over the currents, warm-started from the greedy schedule
    say(f"optimal control: the currents at {nodes} time nodes (minimum {objective})")
    t2 = time.perf_counter()
    grid = node_grid(index, g_times, nodes, ws)
    problem = CurrentOCP(nodes, grid["waypoint_nodes"], np.array(out.max_current) / np.abs(i0), slew / np.abs(i0),
                         weight_effort, resist * i0 ** 2 if with_r else None, f.max_power, objective)
    solved = _best_signs(problem, grid, ws[index], _even(scene), weight_effort, objective)
    out.ocp_status = problem.status
    out.timings["solve"] = time.perf_counter() - t2
    if solved is None:
        keep_greedy(f"the optimal-control NLP did not converge ({problem.status})")
    else:
        wo = np.array(solved["u"])
        times = np.concatenate([[0.0], np.cumsum(solved["dt"])])
        say("optimal control: verifying the schedule by a loading path from zero currents")
        t4 = time.perf_counter()
        verified = verify_schedule(wps, scene, options, as_steps(wo), grid["waypoint_nodes"], max_step=VERIFY_STEP)
        out.timings["verify"] = time.perf_counter() - t4
        ok, why = _checked(verified, scene, wo, times, i0, slew, out, settings.margin)
        value = float(times[-1]) if objective == "time" else control_effort(wo, times, weight_effort)
        reference = out.greedy_duration if objective == "time" else out.greedy_energy
        if not ok:
            keep_greedy(f"the optimised schedule was not verified ({why})")
        elif value > reference + NOT_WORSE_TOL * max(1.0, abs(reference)):
            keep_greedy(f"the optimised schedule's {objective} {value:.6g} exceeds the greedy one's {reference:.6g}")
        else:
            _report(out, scene, wo, times, grid["waypoint_nodes"], verified, i0,
                    control_effort(wo, times, weight_effort), True,
                    f"the optimised schedule's {objective} {value:.6g} against {reference:.6g} for the greedy "
                    "schedule under the same limits")
    out.timings["total"] = time.perf_counter() - t0
    return out


def _best_signs(problem: CurrentOCP, grid: dict, pinned: np.ndarray, even: bool, weight_effort: np.ndarray,
               objective: str) -> Optional[dict]:
    """The NLP solved with the waypoints' weights as the greedy schedule has them and, for a rod
    whose energy is even in the field (±I hold the same state), with every choice of their signs
    (the first's fixed: the coils start from zero) up to :data:`MAX_SIGN_WAYPOINTS` waypoints; the
    best by the objective (ties keep the earlier choice)."""
    m = len(pinned)
    choices = [np.ones(m)]
    if even and 1 < m <= MAX_SIGN_WAYPOINTS:
        choices += [np.array((1.0,) + signs) for signs in itertools.product((1.0, -1.0), repeat=m - 1)][1:]
    best, best_key, status = None, None, problem.status
    for signs in choices:
        u0 = grid["u"].copy()
        for leg, (k, sg) in enumerate(zip(grid["waypoint_nodes"], signs)):  # the start: greedy's, flipped by leg
            lo = grid["waypoint_nodes"][leg - 1] + 1 if leg else 1
            u0[lo:k + 1] *= sg
        got = problem.solve(u0, grid["dt"], pinned * signs[:, None])
        if got is None:
            status = status if best is not None else problem.status  # (why the last one failed, if none solved)
            continue
        times = np.concatenate([[0.0], np.cumsum(got["dt"])])
        energy = control_effort(got["u"], times, weight_effort)
        key = (float(times[-1]), energy) if objective == "time" else (energy, float(times[-1]))
        # lexicographic with a relative tie of 1e-9 on the first
        if best is None or key[0] < best_key[0] * (1 - 1e-9) or \
                (key[0] <= best_key[0] * (1 + 1e-9) and key[1] < best_key[1] * (1 - 1e-9)):
            best, best_key, status = got, key, problem.status
    problem.status = status
    return best


def _report(out: CurrentSchedule, scene: Scene, w: np.ndarray, times: np.ndarray, index, verified: ScheduleResult,
            i0: np.ndarray, energy: float, optimal: bool, message: str) -> None:
    """Record the reported schedule (weights ``w`` (n_steps, n_coils) at ``times``) in ``out``, with
    each replayed state's relaxation time against its step's duration (when the density is known)."""
    out.currents, out.times, out.waypoint_index = (w * i0).tolist(), [float(t) for t in times], list(index)
    out.duration, out.energy = float(times[-1]), float(energy)
    out.optimal, out.verification, out.message = optimal, verified, message
    out.success = bool(verified.success)
    out.status = "success" if out.success else "not_verified"
    table = [{"time_s": t} for t in out.times]
    out.quasi_static = quasi_static(verified.states, table, scene.scales)
    out.step_dynamics = [{k: v for k, v in row.items() if k != "time_s"} for row in table] \
        if out.quasi_static is not None else []


def _checked(verified: ScheduleResult, scene: Scene, w: np.ndarray, times: np.ndarray, i0: np.ndarray,
             slew: np.ndarray, out: CurrentSchedule, margin: float):
    """(ok, why): the replayed path verified, every state where the fits hold and stable by at least
    ``margin`` (its least eigenvalue), and every limit kept at every step; ``out.extremes`` set to the
    largest use of each limit (a fraction; 1 = at the limit) and the least eigenvalue."""
    out.extremes = {}
    if not verified.success:
        return False, verified.message
    f = scene.field
    for k, st in enumerate(verified.states):
        region = f.region_problem(st.x, st.y)
        if region is not None:
            return False, f"step {k}: the rod leaves where the coils' fits hold ({region})"
    least = min(float(st.eigenvalues[0]) for st in verified.states)
    if least < margin:
        return False, f"the stability margin: the least eigenvalue along the path is {least:.3g} < {margin:g}"
    currents = w * i0
    power = currents ** 2 @ np.array([c.resistance for c in f.sources]) if out.effort == "energy" else None
    change, dt = np.abs(np.diff(currents, axis=0)), np.diff(times)[:, None]
    if np.any(dt < 0):
        return False, "the schedule's time runs backwards"
    # use of the slew per step and coil; a step of no duration may not change a current
    use = np.where(dt > 0, change / (slew * np.where(dt > 0, dt, 1.0)),
                   np.where(change > 1e-9 * np.array(out.max_current), np.inf, 0.0))
    field_mT = [_largest_field_mT(scene, st, wk) for st, wk in zip(verified.states, w)]
    ext = {"current": float(np.max(np.abs(currents) / np.array(out.max_current))),
           "slew": float(np.max(use)) if use.size else 0.0, "least_eigenvalue": least,
           "largest_field_mT": float(max(field_mT))}
    if power is not None:
        ext["largest_power_W"] = float(np.max(power))
        if math.isfinite(out.max_power):
            ext["power"] = float(np.max(power)) / out.max_power
    if math.isfinite(out.max_field_mT):
        ext["field"] = ext["largest_field_mT"] / out.max_field_mT
    out.extremes = ext
    over = [name for name in ("current", "slew", "power", "field") if ext.get(name, 0.0) > 1 + LIMIT_TOL]
    if over:
        return False, f"the {', '.join(over)} limit{'s' if len(over) > 1 else ''} exceeded (largest use " \
                      f"{max(ext[n] for n in over):.6g} of the limit)"
    return True, ""


def _largest_field_mT(scene: Scene, state, w: np.ndarray) -> float:
    """The largest |μ0 H| (mT) at the nodes of ``state`` with the coils at weights ``w``."""
    model = field_model(scene.field)
    values = {**model.parameter_values(scene.field), **dict(zip(model.weight_params, map(float, w)))}
    hx, hy = model.evaluate(np.asarray(state.x, float), np.asarray(state.y, float), values)
    return float(np.max(np.hypot(hx, hy))) * scene.scales.field * MU0 * 1e3
