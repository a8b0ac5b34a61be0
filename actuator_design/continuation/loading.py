"""Quasi-static loading paths: follow the stable equilibrium along a schedule, snap at folds.

A *schedule* is a list of parameter settings, e.g. ``[{"h": 0}, {"h": 2}, {"h": 0}]`` (ramp the
field up and back down) or ``[{"h": 0, "phi": 1.2}, {"h": 1.5, "phi": 1.2}, {"h": 1.5, "phi": 1.6}]``
(a magnitude-and-angle field schedule). Between consecutive settings every named value changes
linearly in a segment coordinate λ ∈ [0, 1]. The rod follows its stable equilibrium
(THEORY §8) on the continuation engine (:mod:`actuator_design.continuation`): each segment is one
continuation problem in λ — every scheduled NLP slot moves at once, values the lens ties to them
follow (h_pos with h), G_λ is exact — continued by pseudo-arclength steps no longer than a segment
fraction ``max_step`` nor moving any nodal angle more than ``max_dtheta``; the engine's fold and
branch-point events stop the run where the branch loses stability (the smallest reduced-Hessian
eigenvalue μ, THEORY §7, reaches zero):

* at a **fold** (saddle-node: the branch ends) the critical point is located by the one fold
  locator (Moore–Spence, :func:`actuator_design.reduced.fold.locate_fold`, along the segment),
  the rod is pushed just past it along the null eigenvector in the direction in which the energy
  decreases (the sign of the cubic term) and relaxed with IPOPT + ``ensure_stable``: a *jump*
  (snap-through) to the state it lands on;
* at a **bifurcation** (μ crosses zero while the branch continues, e.g. the pitchfork of the
  symmetric transverse scene) the crossing is the engine's located branch point and the
  unstable state is left along ± its eigenvector; if the landing state joins continuously
  (supercritical: the energy released vanishes) the event is recorded in ``bifurcations``, not as a
  jump; otherwise (subcritical) it is a jump.

Parameters a schedule may name (dimensionless, THEORY §5; angles in rad)::

    h, h2 (= h²), phi, p (= fy), fx, fy, m_tip, alpha (constant fibre angle), theta0, qx, qy, h_pos

Public API: :func:`follow_path`, :func:`ramp`, :class:`LoadingPath`, :class:`PathPoint`,
:class:`Jump`, :func:`apply_values` (names: :mod:`actuator_design.physics.parameters`).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Optional, Sequence, Union

import numpy as np

from actuator_design.analysis.registration import register
from actuator_design.contact.path import follow_contact_path
from actuator_design.contact.self_contact import self_penetration
from actuator_design.continuation.loading_results import Bifurcation, Jump, LoadingPath, PathPoint
from actuator_design.continuation.loading_schedule import (Schedule, apply_values, checked_schedule,
                                                           normalise_schedule, prepare_scene, ramp,
                                                           scene_values)
from actuator_design.continuation.loading_tracker import Tracker as _Tracker
from actuator_design.continuation.segment import LensSegment, followers
from actuator_design.equilibrium.acceptance import graded_for_scenes, warm_values
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve, solve_from_rest
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.model.scene import Scene

__all__ = ["apply_values", "scene_values", "ramp", "follow_path", "LoadingPath",
           "PathPoint", "Jump", "Bifurcation", "Schedule", "normalise_schedule", "prepare_scene"]


# -- results -----------------------------------------------------------------------------------
def follow_path(scene: Scene, options: Optional[SolverOptions] = None, schedule: Schedule = (), *,
                initial: Union[None, np.ndarray, EquilibriumResult] = None,
                max_step: Optional[float] = None, max_dtheta: float = 0.3) -> LoadingPath:
    """Follow the stable equilibrium of ``scene`` quasi-statically along ``schedule``.

    Parameters
    ----------
    scene : Scene
        The scene; its values not named in the schedule stay fixed. Terms a scheduled parameter
        needs (a tip force for ``p``, a uniform field for ``h``/``phi``, …) are added at value zero.
    options : SolverOptions, optional
        Transcription and resolution (default ``SolverOptions()``); with ``adapt`` the mesh is
        graded for the strongest scene of the schedule (one mesh for the whole path). The branch
        is continued by the engine's Newton corrector (to ``tol`` × the solver's residual scale)
        and the states at schedule points, folds and landings are solved with Newton without
        ``ensure_stable``; the start and the snaps use IPOPT with ``ensure_stable``.
    schedule : list of dict, or dict of lists
        Parameter settings in order (names of the parameter lens, dimensionless, angles in rad),
        e.g. ``[{"h": 0, "phi": 1.2}, {"h": 1.5, "phi": 1.2}]`` or ``{"p": [0.5, -2, 0.5]}``;
        :func:`ramp` builds up/down ramps. At least two points.
    initial : ndarray of shape (n_nodes,) or EquilibriumResult, optional
        Warm start of the first state (default: the state reached from rest,
        :func:`~actuator_design.equilibrium.pipeline.solve`); the first state is made stable.
        Node values (an ndarray) are those of the mesh ``options`` describe: the path then stays
        on that mesh, not graded for its schedule.
    max_step : float, optional
        Largest step, as a fraction of a schedule segment (0 < max_step ≤ 1). Default
        min(1, n_segments/20): about 20 steps over the whole path at least, and one per segment
        for fine schedules (steps are further limited by ``max_dtheta`` and the engine's step control).
    max_dtheta : float
        Largest change of any nodal angle per step, rad (smaller steps draw smoother curves).

    Returns
    -------
    LoadingPath
        ``points``, ``jumps``, ``bifurcations``, ``snap_free``, ``hysteresis``, ``states``,
        ``final`` (the state at the last schedule point), ``success``/``message``. A scene with
        obstacles is followed by contact equilibria (:func:`actuator_design.contact.path.follow_contact_path`):
        touch-down and lift-off in ``contact_events``.

    Raises
    ------
    ValueError
        Invalid schedule (unknown name, fewer than 2 points, non-finite or out-of-range values) or
        step settings.
    """
    options = options or SolverOptions()
    if scene.obstacles:
        return follow_contact_path(scene, options, schedule, max_step=max_step, max_dtheta=max_dtheta)
    base, names, vals, max_step = checked_schedule(scene, schedule, max_step, max_dtheta)
    if not isinstance(initial, np.ndarray):  # (node values hold on the mesh they were made on)
        options = _graded_for_schedule(base, options, names, vals)
    tr = _Tracker(base, options, names, vals, max_step, max_dtheta)

    prob0 = tr.problem(0)
    first = solve(prob0.segment.scene(0.0), replace(options, ensure_stable=True),
                  initial=_start_values(prob0.segment.scene(0.0), options, initial, tr.solver), solver=tr.solver)
    tr.record(prob0, 0, 0.0, first, "start")
    tr.states.append(first)
    cur, msg, ok = first, "", bool(first.success and first.stable)
    if not ok:
        msg = f"no stable starting state: {first.message}"
    else:
        for k in range(len(vals) - 1):
            nxt, msg = tr.run_segment(k, cur)
            if nxt is None:
                ok = False
                break
            cur = nxt
            tr.states.append(cur)
    if ok:
        msg = (f"followed {len(vals) - 1} segment(s): {len(tr.jumps)} jump(s), "
               f"{len(tr.bifs)} continuous bifurcation(s)")
        through = None if options.keep_self_intersecting else _through_itself(tr.states, names, vals)
        if through is not None and options.self_contact and scene.contact_gap > 0:
            # the rod meets itself on the way: followed again by contact equilibria with self-contact
            return follow_contact_path(scene, options, schedule, max_step=max_step, max_dtheta=max_dtheta)
        if through is not None:
            ok, msg = False, through
    hyst = _hysteresis(tr) if tr.param is not None else {
        "width": 0.0, "area": 0.0, "loops": [],
        "note": "hysteresis is defined for one-parameter schedules only"}
    return LoadingPath(names=names, schedule=vals, param=tr.param, points=tr.points, jumps=tr.jumps,
                       bifurcations=tr.bifs, snap_free=bool(ok and not tr.jumps), hysteresis=hyst,
                       states=tr.states, final=cur, success=ok, message=msg)


def _start_values(scene: Scene, options: SolverOptions, initial, solver):
    """The first state's warm start on the path's mesh: node values as given, a result interpolated
    onto the mesh, or (none given) the state ``solve`` reaches from rest in ``scene`` (a state that
    misses solve's accuracy on its own mesh included: re-solved on the path's). None (the straight
    rod) when no state is reached from rest."""
    if initial is None:
        rest, converged = solve_from_rest(scene, options)
        initial = rest if converged else None
    return None if initial is None else warm_values(initial, solver.transcription.nodes)


def _graded_for_schedule(base: Scene, options: SolverOptions, names, vals) -> SolverOptions:
    """``options`` graded towards the clamp and the tip for the strongest scene of the schedule
    (:func:`~actuator_design.equilibrium.acceptance.graded_for_scenes`): the whole path is followed
    on one mesh, which must resolve the layers at its strongest field or load."""
    follow = followers(base, names, vals)
    return graded_for_scenes([LensSegment(base, names, v, v, follow).scene(0.0) for v in vals], options)


def _through_itself(states, names, vals) -> Optional[str]:
    """Where the first of the path's schedule ``states`` crosses itself, or (a rod with a thickness,
    ``contact_gap`` > 0) passes through its own thickness, in words; None when none does. A path
    does not follow self-contact: such a state is not physical (THEORY's rod cannot pass through
    itself), and the path says so instead of reporting it."""
    for k, r in enumerate(states):
        gap = r.scene.contact_gap
        inside = self_penetration(r, gap) if gap > 0 and r.success else None
        if r.self_intersecting or inside is not None:
            at = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, vals[k]))
            how = ("crosses itself" if r.self_intersecting else
                   f"passes through its own thickness (s = {inside[0]:.4g} against s = {inside[1]:.4g})")
            return (f"at schedule point {k} ({at}) the rod {how}: a path follows self-contact only with the "
                    "rod's thickness (contact_gap > 0) and self_contact on; keep_self_intersecting accepts it")
    return None


def _hysteresis(tr: _Tracker) -> dict:
    """Loops of a one-parameter path: each jump followed by the next jump in the opposite ramp
    direction. Width = distance between the two jump values; area = ∫ |angle_B − angle_A| dparam
    between them, A the branch before the first jump (and after the second), B the branch between,
    each interpolated (PCHIP) through the path's states: its accuracy is set by the step
    (``max_dtheta``), typically 1e-3 relative."""
    pts, jumps = tr.points, tr.jumps
    loops = []
    for i in range(len(jumps) - 1):
        j1, j2 = jumps[i], jumps[i + 1]
        if j1.direction == 0 or j1.direction != -j2.direction:
            continue
        lo, hi = sorted((j1.param, j2.param))
        before = jumps[i - 1].t if i > 0 else -np.inf
        after = jumps[i + 2].t if i + 2 < len(jumps) else np.inf
        A = [(p.param, p.tip["angle"]) for p in pts
             if (before <= p.t <= j1.t and not (p.t == j1.t and p.kind == "landing"))
             or (j2.t <= p.t <= after and not (p.t == j2.t and p.kind == "critical"))]
        A = [a for a in A if a is not None]
        B = [(p.param, p.tip["angle"]) for p in pts
             if j1.t <= p.t <= j2.t and not (p.t == j1.t and p.kind == "critical")
             and not (p.t == j2.t and p.kind == "landing")]
        grid = np.linspace(lo, hi, 2001)
        fa, ca_ = _branch_interp(A, grid)
        fb, cb = _branch_interp(B, grid)
        area = float(_trapezoid(np.abs(fb - fa), grid)) if hi > lo else 0.0
        inside = lambda pts_: [[float(a), float(b)] for a, b in sorted(pts_) if lo <= a <= hi]
        loops.append({"jumps": [j1.param, j2.param], "width": hi - lo, "area": area,
                      "complete": bool(ca_ and cb), "branch_before": inside(A),
                      "branch_between": inside(B)})
    first = loops[0] if loops else {"width": 0.0, "area": 0.0}
    return {"width": float(first["width"]), "area": float(first["area"]), "loops": loops}


def _branch_interp(points, grid):
    """Tip angle of one branch on ``grid`` (sorted, duplicates averaged); covers the grid?"""
    if not points:
        return np.full(grid.shape, np.nan), False
    arr = np.array(sorted(points))
    x, idx = np.unique(arr[:, 0], return_inverse=True)
    y = np.bincount(idx, weights=arr[:, 1]) / np.bincount(idx)
    covered = x[0] <= grid[0] + 1e-9 * (1 + abs(grid[0])) and x[-1] >= grid[-1] - 1e-9 * (1 + abs(grid[-1]))
    if x.size >= 3:  # shape-preserving cubic through the branch points
        from scipy.interpolate import PchipInterpolator

        return PchipInterpolator(x, y, extrapolate=False)(np.clip(grid, x[0], x[-1])), bool(covered)
    return np.interp(grid, x, y), bool(covered)


@register("path")
def run_path(scene, options, param: str = "h", schedule: Sequence[float] = (), **settings) -> dict:
    """Registered analysis: a one-parameter loading path (flat summary)."""
    path = follow_path(scene, options, {param: list(schedule)}, **settings)
    out = {"success": path.success, "snap_free": path.snap_free, "n_jumps": len(path.jumps),
           "jump_params": [j.param for j in path.jumps],
           "energy_released": [j.energy_released for j in path.jumps],
           "hysteresis_width": path.hysteresis["width"], "hysteresis_area": path.hysteresis["area"],
           "final_tip_angle": path.final.tip["angle"]}
    return out


def _trapezoid(y: np.ndarray, x: np.ndarray) -> float:
    """scipy's trapezoid rule (numpy's is ``trapz`` before 2.0, ``trapezoid`` after); scipy.integrate
    is imported here, not with this module: it loads scipy.optimize (0.1 s) into every design."""
    from scipy.integrate import trapezoid

    return trapezoid(y, x)
