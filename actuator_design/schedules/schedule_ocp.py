"""Field schedules as one optimal-control problem (issue 19 item 3).

The greedy schedule (:func:`~actuator_design.schedules.schedule.field_schedule`) designs one waypoint after another and
joins their fields by straight lines in (h, φ). Here the whole schedule, from zero field through
every waypoint, is one CasADi NLP over time nodes k = 0 … N−1 (a direct transcription):

* unknowns: the rod's state θ_k, the field h_k, φ_k at each node, the duration of each leg between
  waypoints (its steps Δt_k of equal length: the nodes are a time grid);
* the rod's equilibrium at every node (the design NLP's stationarity rows, THEORY §4) and a
  stability certificate at every node (the LDLᵀ pivots of the mass-scaled reduced Hessian minus the
  margin, :class:`~actuator_design.inverse.ldl.SegmentedLDL`, the design NLP's certificate);
* the waypoints at their nodes (the tip pinned), h_0 = 0 (the schedule starts from zero field);
* the actuator's limits on every step: |h_{k+1} − h_k| ≤ ḣ_max Δt_k, |φ_{k+1} − φ_k| ≤ φ̇_max Δt_k,
  0 ≤ h_k ≤ h_max; and a continuity bound |θ_{k+1} − θ_k| ≤ 0.5 rad at every node, so that
  consecutive nodes are states of one branch (the loading path's own step bound);
* objective ``"time"``: the duration T = Σ Δt_k (then, among the fastest schedules, the least
  effort); ``"energy"``: the field effort ∫ h² dt (exact for h linear in time within a step; a
  coil's power is R I² with I ∝ H ∝ h, so this is the energy up to the coil's constant) plus
  10⁻³ T to make the time of field-free steps definite.

It is warm-started from the greedy schedule resampled onto the nodes: the same field path, timed
by the same limits, so the start meets the limits; its states are the greedy path's, re-solved at
the nodes, stable, though a node's margin may fall short of the certificate's. The optimised
schedule is then verified like the greedy one: one quasi-static loading path from zero field
through its nodes (no snap, every state stable, every waypoint hit to 1e-6). The schedule
reported is the optimised one only when it is verified and does not take longer (``"time"``) or
more effort (``"energy"``) than the greedy one under the same limits (to :data:`NOT_WORSE_TOL`);
otherwise the greedy schedule is reported and the note says why.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.single import solve_on
from actuator_design.inverse.nlp import get_design_nlp
from actuator_design.inverse.settings import DesignSettings
from actuator_design.model.scene import Scene
from actuator_design.schedules.schedule import ScheduleResult, field_schedule, verify_schedule
from actuator_design.schedules.schedule_ocp_nlp import ScheduleOCP

__all__ = ["RateLimits", "OptimalSchedule", "optimal_schedule", "schedule_times", "field_effort", "control_effort",
           "resample_nodes", "node_grid",
           "OBJECTIVES", "MAX_NODES"]

#: What the optimal-control schedule minimises.
OBJECTIVES = ("time", "energy")
#: The optimised schedule is reported when its objective exceeds the greedy one's by at most this
#: (relative): between waypoints the straight line of the greedy schedule is often time-optimal
#: already, and the two durations then agree to the NLP's tolerance, in either order.
NOT_WORSE_TOL = 1e-6
#: Largest number of time nodes (each carries a rod state and its certificate: ~0.25 s of NLP build).
MAX_NODES = 200


@dataclass(frozen=True)
class RateLimits:
    """The actuator's limits on how fast the field may change.

    Parameters
    ----------
    h_rate : float
        Largest |dh/dt| of the field group h (THEORY §5), per second (> 0).
    rotation_rate : float
        Largest |dφ/dt|, rad/s (> 0).
    """

    h_rate: float
    rotation_rate: float

    def __post_init__(self):
        for name in ("h_rate", "rotation_rate"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be a finite rate > 0, got {v!r}")


def schedule_times(schedule: Sequence[Dict[str, float]], limits: RateLimits) -> np.ndarray:
    """The time (s) at which each step of ``schedule`` is reached when each step takes as long as
    the slower of its field change and its rotation allows, shape (len(schedule),); t_0 = 0."""
    h = np.array([s["h"] for s in schedule], float)
    phi = np.array([s["phi"] for s in schedule], float)
    dt = np.maximum(np.abs(np.diff(h)) / limits.h_rate, np.abs(np.diff(phi)) / limits.rotation_rate)
    return np.concatenate([[0.0], np.cumsum(dt)])


def field_effort(schedule: Sequence[Dict[str, float]], times: np.ndarray) -> float:
    """∫ h² dt over the schedule (field group² · s), exact for h linear in time within each step
    (as the schedule is followed): Δt (h_a² + h_a h_b + h_b²) / 3 per step."""
    return control_effort(np.array([[s["h"]] for s in schedule], float), times, [1.0])


def control_effort(u: np.ndarray, times: np.ndarray, weights) -> float:
    """∫ Σ_i c_i u_i² dt over a schedule of controls ``u`` (n_steps, nu) reached at ``times`` (s),
    exact for u linear in time within each step: Δt (u_a² + u_a u_b + u_b²) / 3 per step and control,
    weighted by ``weights`` c (nu,)."""
    u = np.asarray(u, float).reshape(len(times), -1)
    per = (u[:-1] ** 2 + u[:-1] * u[1:] + u[1:] ** 2) / 3.0 @ np.asarray(weights, float)
    return float(np.sum(np.diff(times) * per))


@dataclass(repr=False)
class OptimalSchedule:
    """An optimal-control schedule and the greedy one it is compared with.

    Attributes
    ----------
    result : ScheduleResult
        The schedule reported (the optimised one when ``optimal``, else the greedy one), verified
        by its loading path (``result.success``).
    optimal : bool
        The optimised schedule was verified and is no worse than the greedy one.
    objective : str
        ``"time"`` or ``"energy"``.
    times : list of float
        The time (s) of each step of ``result.schedule``.
    time_s, effort : float
        Duration (s) and field effort ∫ h² dt (h² s) of the reported schedule.
    greedy_time_s, greedy_effort : float
        The same of the greedy schedule under the same limits.
    nodes : int
        Time nodes of the optimal-control problem.
    status : str
        IPOPT's return status.
    greedy_schedule, greedy_times : list
        The greedy schedule's steps and their times (s).
    """

    result: ScheduleResult
    optimal: bool
    objective: str
    limits: RateLimits
    times: List[float]
    time_s: float
    effort: float
    greedy_time_s: float
    greedy_effort: float
    nodes: int
    status: str
    message: str
    timings: Dict[str, float] = field(default_factory=dict)
    greedy_schedule: List[Dict[str, float]] = field(default_factory=list)
    greedy_times: List[float] = field(default_factory=list)

    def __repr__(self) -> str:
        """One line: the verdict, the objective and both schedules' time and effort."""
        return (f"OptimalSchedule(status={self.status!r}, success={self.success}, optimal={self.optimal}, "
                f"objective={self.objective!r}, "
                f"nodes={self.nodes}, time_s={self.time_s:.6g}, effort={self.effort:.6g}, "
                f"greedy_time_s={self.greedy_time_s:.6g}, greedy_effort={self.greedy_effort:.6g})")

    @property
    def success(self) -> bool:
        return bool(self.result.success)

    def to_dict(self) -> Dict[str, object]:
        out = self.result.to_dict()
        out.update(optimal_control={
            "objective": self.objective, "optimal": bool(self.optimal), "nodes": self.nodes,
            "status": self.status, "message": self.message, "time_s": self.time_s, "effort_h2_s": self.effort,
            "greedy_time_s": self.greedy_time_s, "greedy_effort_h2_s": self.greedy_effort,
            "limits": {"h_rate_per_s": self.limits.h_rate, "rotation_rate_rad_per_s": self.limits.rotation_rate},
            "greedy_schedule": [dict(s, time_s=t) for s, t in zip(self.greedy_schedule, self.greedy_times)],
            "timings_s": self.timings})
        out["schedule"] = [dict(s, time_s=float(t)) for s, t in zip(out["schedule"], self.times)]
        return out


def optimal_schedule(waypoints: Sequence[Sequence[float]], limits: RateLimits, scene: Optional[Scene] = None,
                     options: Optional[SolverOptions] = None, settings: Optional[DesignSettings] = None,
                     objective: str = "time", nodes: int = 40, greedy: Optional[ScheduleResult] = None,
                     progress: Optional[Callable[[str], None]] = None) -> OptimalSchedule:
    """The schedule through tip ``waypoints`` that minimises ``objective`` under ``limits``.

    Parameters
    ----------
    waypoints : sequence of (x, y)
        Tip positions, units of ℓ, in visiting order.
    limits : RateLimits
    scene, options, settings
        As for :func:`~actuator_design.schedules.schedule.field_schedule` (the fibre layout and loads stay the scene's;
        ``settings.margin`` is the stability margin required at every node, ``settings.h_max`` the
        field bound).
    objective : {"time", "energy"}
    nodes : int
        Time nodes, at least one per step between waypoints plus one, at most :data:`MAX_NODES`.
    greedy : ScheduleResult, optional
        The greedy schedule (computed when not given): the warm start and the reference.
    progress : callable, optional
        Called with one line as each stage starts (the NLP takes ~0.2 s per node to build).

    Returns
    -------
    OptimalSchedule
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if not (isinstance(nodes, int) and len(waypoints) + 1 <= nodes <= MAX_NODES):
        raise ValueError(f"nodes: must be a whole number in [{len(waypoints) + 1}, {MAX_NODES}] (one more than "
                         f"the waypoints at least), got {nodes!r}")
    t0 = time.perf_counter()
    say = progress or (lambda line: None)
    options, settings = options or SolverOptions(), settings or DesignSettings()
    greedy_given = greedy is not None  # (its own time is then added to the total)
    given_greedy_time = float(greedy.timings.get("total", 0.0)) if greedy_given else 0.0
    if greedy is None:
        say("optimal control: the greedy schedule (warm start and reference)")
        greedy = field_schedule(waypoints, scene=scene, options=options, settings=settings)
    timings = {"greedy": time.perf_counter() - t0}
    g_times = schedule_times(greedy.schedule, limits) if greedy.schedule else np.zeros(0)
    g_time = float(g_times[-1]) if g_times.size else math.nan
    g_effort = field_effort(greedy.schedule, g_times) if g_times.size else math.nan

    def report(result, times, optimal, status, message):
        timings["total"] = time.perf_counter() - t0
        # the reported schedule's timings: its own, the optimal-control stages', the whole call's
        total = timings["total"] + (given_greedy_time if greedy_given else 0.0)
        result = replace(result, timings={**result.timings, **{f"optimal_control_{k}": v for k, v in timings.items()},
                                          "total": total})
        return OptimalSchedule(result, optimal, objective, limits, [float(t) for t in times],
                               float(times[-1]) if len(times) else math.nan,
                               field_effort(result.schedule, np.asarray(times)) if len(times) else math.nan,
                               g_time, g_effort, nodes, status, message, timings,
                               [dict(s) for s in greedy.schedule], [float(t) for t in g_times])

    if not greedy.success:
        return report(greedy, g_times, False, "not_solved",
                      f"no greedy schedule to start from: {greedy.message}")
    base = greedy.scene
    nlp = get_design_nlp(base, ("h", "phi"), options, settings.alpha_terms)
    steps = np.array([nlp.design_vector(h=s["h"], phi=s["phi"]) for s in greedy.schedule])
    start = resample_nodes(greedy, g_times, nodes, steps, lambda d: nlp.scene_for(base, d), nlp.solver, options)
    say(f"optimal control: building the NLP over {nodes} time nodes")
    t1 = time.perf_counter()
    ih, iphi = nlp.dmap["h"].start, nlp.dmap["phi"].start
    start.update(h=[u[ih] for u in start["u"]], phi=[u[iphi] for u in start["u"]])
    problem = ScheduleOCP(nlp, base, len(start["h"]), start["waypoint_nodes"], greedy.waypoints, limits,
                          settings.margin, settings.h_max, objective)
    timings["build"] = time.perf_counter() - t1
    say(f"optimal control: solving (minimum {objective})")
    t2 = time.perf_counter()
    solved = problem.solve(start)
    timings["solve"] = time.perf_counter() - t2
    if solved is None:
        return report(greedy, g_times, False, problem.status,
                      f"the optimal-control NLP did not converge ({problem.status}): the greedy schedule is reported")
    schedule = [{"h": float(h), "phi": float(p)} for h, p in zip(solved["h"], solved["phi"])]
    times = np.concatenate([[0.0], np.cumsum(solved["dt"])])
    say("optimal control: verifying the schedule by a loading path from zero field")
    t3 = time.perf_counter()
    verified = verify_schedule(greedy.waypoints, base, options, schedule, start["waypoint_nodes"])
    timings["verify"] = time.perf_counter() - t3
    value = float(times[-1]) if objective == "time" else field_effort(schedule, times)
    reference = g_time if objective == "time" else g_effort
    if not verified.success:
        return report(greedy, g_times, False, problem.status,
                      f"the optimised schedule was not verified ({verified.message}): the greedy schedule is reported")
    if value > reference + NOT_WORSE_TOL * max(1.0, abs(reference)):
        return report(greedy, g_times, False, problem.status,
                      f"the optimised schedule's {objective} {value:.6g} exceeds the greedy one's {reference:.6g}: "
                      "the greedy schedule is reported")
    return report(verified, times, True, problem.status,
                  f"the optimised schedule's {objective} {value:.6g} against {reference:.6g} for the greedy "
                  "schedule under the same limits")


def node_grid(waypoint_index: Sequence[int], times: np.ndarray, nodes: int, controls: np.ndarray) -> Dict[str, object]:
    """A schedule's controls (``controls``: its steps', (n_steps, nu), each step a straight line in
    them, reached at ``times``) on ``nodes`` time nodes: each leg (the start to the first waypoint,
    then waypoint to waypoint) given steps in proportion to its duration, at least one, each
    waypoint's own controls exactly. Returns ``u`` (nodes, nu), ``dt`` (nodes − 1,), ``t`` (nodes,)
    and ``waypoint_nodes``."""
    ends = [0] + list(waypoint_index)
    span = np.diff(times[ends])
    steps = np.ones(len(span), int)
    for _ in range(nodes - 1 - len(span)):  # one more step to the leg whose steps are longest
        steps[int(np.argmax(span / steps))] += 1
    t_nodes, wp_nodes = [0.0], []
    for a, b, n in zip(ends[:-1], ends[1:], steps):
        t_nodes += list(np.linspace(times[a], times[b], n + 1)[1:])
        wp_nodes.append(len(t_nodes) - 1)
    t_nodes = np.array(t_nodes)
    controls = np.asarray(controls, float)
    u = np.column_stack([np.interp(t_nodes, times, c) for c in controls.T])
    for k, i in zip(wp_nodes, waypoint_index):
        u[k] = controls[i]
    return {"u": u, "dt": np.diff(t_nodes), "t": t_nodes, "waypoint_nodes": wp_nodes}


def resample_nodes(greedy: ScheduleResult, times: np.ndarray, nodes: int, controls: np.ndarray,
                   scene_at: Callable[[np.ndarray], Scene], solver, options) -> Dict[str, object]:
    """The greedy schedule on ``nodes`` nodes (:func:`node_grid`), the optimal-control NLP's start,
    with each node's state ``theta`` solved on ``solver``'s mesh (``scene_at(u)``: the scene at
    controls u) from the greedy path's state at the greedy step before it (that path's own warm
    start)."""
    grid = node_grid(greedy.waypoint_index, times, nodes, controls)
    before = np.clip(np.searchsorted(times, grid["t"], side="right") - 1, 0, len(times) - 1)
    theta = []
    for k, u in enumerate(grid["u"]):
        r = solve_on(scene_at(u), options, greedy.states[before[k]].z, solver)
        theta.append(r.z if r.success and r.stable else greedy.states[before[k]].z)
    return {**grid, "u": list(grid["u"]), "theta": theta}
