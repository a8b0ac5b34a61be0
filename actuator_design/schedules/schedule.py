"""Field schedules: fields (h, φ) whose quasi-static equilibria pass through given tip waypoints.

1. The first waypoint is a full :func:`~actuator_design.inverse.design.design` (magnitude and angle; the fibre layout is
   the scene's, fixed by fabrication), verified by a loading path from zero field.
2. Each next waypoint is a stage-B design-NLP solve warm-started from the previous state, with
   objective h² + w_rate·|(h, φ) − (h, φ)_prev|² (least field effort and rate of change) and the tip
   pinned to the waypoint; continuity comes from the warm start and the rate term. The field acts
   on its axis (φ and φ + π are one field, THEORY §5: the energy depends on cos²(θ + α − φ)), so
   each new angle is taken modulo π as the representative nearest the previous one: the field
   rotates the short way (at most 90°) between waypoints.
3. The whole schedule (zero field → first waypoint, then straight lines in (h, φ) between waypoint
   fields) is checked by one quasi-static loading path (:func:`~actuator_design.continuation.loading.follow_path`): no snap,
   every state stable, and the state at each waypoint's field on the waypoint.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Sequence

import numpy as np

from actuator_design.continuation.loading import follow_path  # verifies the whole schedule
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.inverse.design import DesignSettings, design
from actuator_design.inverse.design_map import prepare_scene, without_soft_coupling
from actuator_design.inverse.nlp import DesignRequest, get_design_nlp
from actuator_design.inverse.settings import normalise_phi, tip_error
from actuator_design.model.scene import Scene, default_scene
from actuator_design.physics import parameters as lens

__all__ = ["field_schedule", "verify_schedule", "ScheduleResult", "nearest_axis_angle", "schedule_table", "SCHEDULE_COLUMNS"]

#: Columns of a schedule table: always, for physical scenes (THEORY §5: H = h / (dh/dH), B = μ0 H),
#: and with a rate (the time at which each step is reached).
SCHEDULE_COLUMNS = {"always": ("step", "h", "phi_rad"),
                    "physical": ("field_A_per_m", "field_mT", "angle_deg"), "timed": ("time_s",),
                    "dynamics": ("relaxation_time_s", "quasi_static")}


@dataclass(repr=False)
class ScheduleResult:
    """A field schedule through tip waypoints (dimensionless; angles in rad).

    Attributes
    ----------
    rows : list of dict
        One per waypoint: target, achieved tip (from the verifying path), h, φ, error, margin.
    schedule : list of dict
        The full verified schedule from zero field, ``{"h", "phi"}`` per step (φ continuous).
    waypoint_index : list of int
        Position of each waypoint's field in ``schedule``.
    states : list of EquilibriumResult
        The loading path's state at every schedule point (for figures and animations).
    verified : bool
        The independent loading path confirms every claim (no snap, all stable, waypoints hit);
        it equals ``success``.
    """

    success: bool
    verified: bool
    snap_free: bool
    all_stable: bool
    waypoints: List[tuple]
    rows: List[Dict[str, float]]
    schedule: List[Dict[str, float]]
    waypoint_index: List[int]
    message: str
    scene: Scene
    states: List[EquilibriumResult] = field(default_factory=list)
    path: object = None
    timings: Dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        """One line: the verdict and the schedule's size."""
        return (f"ScheduleResult(success={self.success}, verified={self.verified}, snap_free={self.snap_free}, "
                f"all_stable={self.all_stable}, waypoints={len(self.waypoints)}, steps={len(self.schedule)})")

    def to_dict(self) -> Dict[str, object]:
        return {"success": bool(self.success), "verified": bool(self.verified), "snap_free": bool(self.snap_free),
                "all_stable": bool(self.all_stable),
                "waypoints": [{"x": w[0], "y": w[1]} for w in self.waypoints], "rows": self.rows,
                "schedule": self.schedule, "waypoint_index": self.waypoint_index, "message": self.message,
                "timings_s": self.timings,
                "units": {"length": "rod length", "angle": "rad", "h": "dimensionless field group"}}


def field_schedule(waypoints: Sequence[Sequence[float]], scene: Optional[Scene] = None,
                   options: Optional[SolverOptions] = None, settings: Optional[DesignSettings] = None,
                   rate_weight: float = 1.0, substeps: int = 8) -> ScheduleResult:
    """Compute and verify a field schedule through tip ``waypoints``.

    Parameters
    ----------
    waypoints : sequence of (x, y)
        Tip positions in units of ℓ, in the order the tip should visit them.
    scene : Scene, optional
        The actuator (its fibre layout and loads stay fixed); default THEORY §5's cantilever.
    rate_weight : float
        Weight of |Δ(h, φ)|² against the field effort h² between consecutive waypoints.
    substeps : int
        Schedule points between consecutive waypoints (the path follower refines further).

    Returns
    -------
    ScheduleResult
    """
    t0 = time.perf_counter()
    wps = [tuple(float(v) for v in w) for w in waypoints]
    if len(wps) < 2 or any(len(w) != 2 or not all(math.isfinite(v) for v in w) for w in wps):
        raise ValueError("waypoints: expected at least two finite (x, y) pairs")
    if not (rate_weight >= 0 and math.isfinite(rate_weight)):
        raise ValueError(f"rate_weight: must be a finite number >= 0, got {rate_weight}")
    if int(substeps) < 1:
        raise ValueError(f"substeps: must be >= 1, got {substeps}")
    options = options or SolverOptions()
    settings = settings or DesignSettings()
    vary = ("h", "phi")
    if scene is not None and without_soft_coupling(scene):
        raise ValueError("schedule: this rod has no soft-magnetic coupling (h = 0; its field acts through "
                         f"{', '.join(p.name for p in lens.remanent_groups(scene))} alone): a schedule varies the "
                         "soft-magnetic group h and the angle phi, so a purely hard-magnetic rod cannot be scheduled yet")
    base = prepare_scene(scene or default_scene(h=0.0), vary)
    timings: Dict[str, float] = {}

    first = design(wps[0], scene=base, vary=vary, options=options, settings=settings)
    timings["first_waypoint"] = time.perf_counter() - t0
    fail = lambda msg: ScheduleResult(False, False, False, False, wps, [], [], [], msg, base, timings=timings)
    if not first.success:
        return fail(f"waypoint 0 {wps[0]}: {first.message or 'no verified design'}")

    nlp = get_design_nlp(base, vary, options, settings.alpha_terms)
    schedule = [dict(s) for s in first.schedule]
    index = [len(schedule) - 1]
    h_prev, phi_prev = schedule[-1]["h"], schedule[-1]["phi"]  # φ continuous with the path
    # the other groups the first rows name (h_r: ∝ H like h, THEORY §9) keep their ratio to h
    ratios = {g: (v / h_prev if h_prev > 0 else 0.0) for g, v in schedule[-1].items() if g not in ("h", "phi")}
    z_prev = first.path.final.z
    t1 = time.perf_counter()
    for k, wp in enumerate(wps[1:], start=1):
        d_prev = nlp.design_vector(h=h_prev, phi=phi_prev)
        req = DesignRequest(target=wp, stage="B", margin=settings.margin, bounds=settings.bounds(),
                            d_prev=d_prev, w_rate=rate_weight)
        pt = nlp.solve(base, z_prev, d_prev, req)
        if not (pt.converged and tip_error(pt.tip, wp) <= settings.reach_tol):
            a = nlp.solve(base, z_prev, d_prev, replace(req, stage="A"))
            if a.converged and tip_error(a.tip, wp) <= 10 * settings.reach_tol:
                pt = nlp.solve(base, a.z, nlp.design_vector(h=a.h, phi=a.phi), req)
            if not (pt.converged and tip_error(pt.tip, wp) <= settings.reach_tol):
                return fail(f"waypoint {k} {wp}: not reachable continuously from waypoint {k - 1} with a stable "
                            f"state (nearest {tip_error(pt.tip, wp):.3g} rod lengths)")
        phi_next = nearest_axis_angle(pt.phi, phi_prev)
        for t in np.linspace(0, 1, substeps + 1)[1:]:
            h_t = float(h_prev + t * (pt.h - h_prev))
            schedule.append({"h": h_t, **{g: r * h_t for g, r in ratios.items()},
                             "phi": float(phi_prev + t * (phi_next - phi_prev))})
        index.append(len(schedule) - 1)
        h_prev, phi_prev, z_prev = pt.h, phi_next, pt.z
    timings["waypoints"] = time.perf_counter() - t1

    t2 = time.perf_counter()
    result = verify_schedule(wps, base, options, schedule, index)
    timings["verify"] = time.perf_counter() - t2
    timings["total"] = time.perf_counter() - t0
    result.timings = timings
    return result


def verify_schedule(waypoints: Sequence[Sequence[float]], base: Scene, options: SolverOptions,
                    schedule: Sequence[Dict[str, float]], index: Sequence[int], max_step: float = 0.25) -> ScheduleResult:
    """Check a schedule by one quasi-static loading path from zero field through its points
    (:func:`~actuator_design.continuation.loading.follow_path`; the points name lens parameters: ``h``, ``phi``, or the coils'
    ``source_weight_k``): no snap, every state stable, the state at each waypoint's
    field (``schedule[index[k]]``) on waypoint k to 1e-6. ``max_step``: the path's largest step, a
    fraction of a schedule segment (the engine's step control and the angle bound refine further).

    Returns
    -------
    ScheduleResult
        ``success`` (= ``verified``) when every check passes; the message says which failed.
    """
    wps = [tuple(float(v) for v in w) for w in waypoints]
    schedule, index = [dict(s) for s in schedule], list(index)
    start = replace(base, h=0.0) if "h" in schedule[0] else base  # (a schedule over coils starts them at 0)
    path = follow_path(start, options, schedule, max_step=max_step, max_dtheta=0.5)
    states = list(path.states)
    ok_path = bool(path.success and len(states) == len(schedule))
    all_stable = ok_path and all(s.stable for s in states)
    rows = []
    on_target = ok_path
    for k, (wp, i) in enumerate(zip(wps, index)):
        st = states[i] if ok_path else None
        err = tip_error((st.tip["x"], st.tip["y"]), wp) if st is not None else float("inf")
        on_target = on_target and err <= 1e-6
        nan = float("nan")
        rows.append({"waypoint": k, "target_x": wp[0], "target_y": wp[1],
                     "x": float(st.tip["x"]) if st else nan, "y": float(st.tip["y"]) if st else nan,
                     "angle": float(st.tip["angle"]) if st else nan,
                     **{name: float(v) for name, v in schedule[i].items()}, "error": float(err),
                     "margin": float(st.eigenvalues[0]) if st else nan})
    # verified = the independent path confirms every claim of the schedule, so it equals success
    success = bool(ok_path and path.snap_free and all_stable and on_target)
    msg = ("every waypoint reached, continuously, without a snap, every state stable" if success else
           f"verification failed: path {'ok' if ok_path else 'did not converge'}, snap-free {path.snap_free}, "
           f"all stable {all_stable}, waypoints on target {on_target}; {path.message}")
    return ScheduleResult(success=success, verified=success, snap_free=bool(path.snap_free),
                          all_stable=all_stable, waypoints=wps, rows=rows, schedule=schedule, waypoint_index=index,
                          message=msg, scene=base, states=states, path=path)


def nearest_axis_angle(phi: float, reference: float) -> float:
    """The angle equivalent to ``phi`` modulo π (the same field axis) nearest ``reference`` (rad):
    ``reference + d`` with d ≡ phi − reference (mod π), d in (−π/2, π/2]."""
    return float(reference + normalise_phi(phi - reference))


def schedule_table(schedule: Sequence[Dict[str, float]], units=None, field_rate: Optional[float] = None,
                   rotation_rate: Optional[float] = None) -> List[Dict[str, float]]:
    """One row per schedule step, in the user's units where the scene has them.

    Parameters
    ----------
    schedule : sequence of {"h", "phi"}
        The schedule (dimensionless h, φ in rad, continuous along the schedule).
    units : actuator_design.io.user_units.UserUnits, optional
        A physical scene's conversions: adds ``field_A_per_m`` (H = h / (dh/dH)), ``field_mT``
        (μ0 H) and ``angle_deg``.
    field_rate : float, optional
        Largest rate of change of the field strength, A/m/s (needs ``units`` with a field).
    rotation_rate : float, optional
        Largest rotation rate of the field, rad/s.

    Returns
    -------
    list of dict
        ``step``, ``h``, ``phi_rad`` [, ``field_A_per_m``, ``field_mT``, ``angle_deg``]
        [, ``time_s``]. With a rate, step k is reached at t_k = t_{k−1} + max(|ΔH| / field_rate,
        |Δφ| / rotation_rate) (the slower of the two changes governs); t_0 = 0. A change whose
        rate is not given is never taken as instantaneous: it is an error (below).

    Raises
    ------
    ValueError
        A rate that is not a finite number > 0, a field rate without a physical field scale, or a
        timed schedule with a step that rotates the field without a rotation rate or changes its
        magnitude without a field rate (one line naming the missing flag).
    """
    for name, rate in (("--rate", field_rate), ("--rotation-rate", rotation_rate)):
        if rate is not None and not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"{name}: must be a finite rate > 0, got {rate!r}")
    physical = units is not None and units.has_field
    if field_rate is not None and not physical:
        raise ValueError("--rate: a field rate needs a physical scene (`type: physical` CONFIG with a "
                         "magnetic group); give --rotation-rate only, or a physical CONFIG")
    timed = field_rate is not None or rotation_rate is not None
    rows: List[Dict[str, float]] = []
    t = 0.0
    for k, s in enumerate(schedule):
        h, phi = float(s["h"]), float(s["phi"])
        row = {"step": k, "h": h, "phi_rad": phi}
        if physical:
            row.update(field_A_per_m=units.field_A_per_m(h), field_mT=units.field_mT(h),
                       angle_deg=math.degrees(phi))
        if timed:
            if k > 0:
                prev = rows[-1]
                dt = 0.0
                turn, ramp = abs(phi - prev["phi_rad"]), h != prev["h"]
                if turn > 0.0 and rotation_rate is None:
                    raise ValueError(f"--rotation-rate: the schedule rotates the field (step {k}, by "
                                     f"{math.degrees(turn):.3g} deg) and no rotation rate was given; give "
                                     "--rotation-rate (e.g. 30deg/s) with --rate")
                if ramp and field_rate is None:
                    raise ValueError("--rate: the schedule changes the field magnitude (step "
                                     f"{k}) and no field rate was given; give --rate (e.g. 5mT/s, "
                                     "a physical scene) with --rotation-rate")
                if field_rate is not None:
                    dt = max(dt, abs(units.field_A_per_m(h) - units.field_A_per_m(prev["h"])) / field_rate)
                if rotation_rate is not None:
                    dt = max(dt, turn / rotation_rate)
                t += dt
            row["time_s"] = t
        rows.append(row)
    return rows
