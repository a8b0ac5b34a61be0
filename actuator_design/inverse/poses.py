"""One actuator, several poses: one fibre layout α(s) and one field (h, φ[, p]) per pose.

The central question of programmable soft actuators: a rod is built once (its fibre layout is
fixed by fabrication) and driven to several poses by the field alone. :func:`design_poses` finds

1. a first design of pose 1 (the single-pose pipeline: screen, optimise, choose), whose layout is
   the start of the shared one; where the joint design from it fails its checks, the next of pose
   1's reachable single-pose optima is the start (up to :data:`MAX_LAYOUT_STARTS`, best first), so
   one start's failure is not reported as "no design";
2. for every other pose, the field that brings the same rod nearest it (layout fixed);
3. the joint design: one layout and one field per pose, every pose exact (the multi-scenario NLP of
   :mod:`actuator_design.robust.design_robust` with an empty box), then made robust over the tolerance box (worst-case tip
   error of each pose over the box's corners, every corner stable);
4. per pose, the independent checks of the single-pose design: robustness by branch following
   (:mod:`actuator_design.robust.robustness`) and a snap-free loading path from zero field (:mod:`actuator_design.inverse.verify`);
5. a schedule that visits the poses in order: from rest to pose 1, then from each pose straight to
   the next field (the short way modulo π), checked by a loading path that must land on the next
   pose's state; where it does not, the field is ramped down to zero and the next pose's verified
   schedule from rest is used.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Dict, List, Optional, Sequence

import numpy as np

from actuator_design import forked
from actuator_design.contact.guard import no_contact
from actuator_design.continuation.loading import follow_path
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.inverse.choose import choose
from actuator_design.inverse.design import design_problem, search
from actuator_design.inverse.design_map import profile_report
from actuator_design.inverse.mesh import check_mesh, check_state
from actuator_design.inverse.nlp import PROFILE_VARIABLES
from actuator_design.inverse.optimise import candidate, design_vector, search_set
from actuator_design.inverse.settings import (Choice, DesignSettings, Optimised, normalise_phi, phi_period,
                                              tip_error)
from actuator_design.inverse.verify import ramped_groups, schedule_rows
from actuator_design.inverse.verify import verify as verify_stage
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.robust.design_robust import get_scenario_nlp, pose_designs, robustify
from actuator_design.robust.robustness import Robustness, evaluate_robustness
from actuator_design.robust.tolerances import Tolerances

__all__ = ["PoseResult", "MultiPoseResult", "design_poses", "MAX_POSES"]

#: the work of a multi-pose design grows with the number of poses: a bound on it
MAX_POSES = 8


@dataclass
class PoseResult:
    """One pose of a multi-pose design (dimensionless; angles in rad)."""

    target: tuple
    achieved: Dict[str, float]
    error: float
    design: Dict[str, float]
    robustness: Optional[Robustness]
    verified: bool
    stable: bool
    snap_free: bool
    schedule: List[Dict[str, float]]
    label: str
    z: Optional[np.ndarray] = field(default=None, repr=False)  # the pose's state (θ at the nodes)
    state: object = field(default=None, repr=False)  # the verified EquilibriumResult (figures)
    at_bound: str = ""  # the design bound the pose's field sits on ("" when none)

    def to_dict(self) -> dict:
        tgt = {"x": self.target[0], "y": self.target[1], **({"angle": self.target[2]} if len(self.target) > 2 else {})}
        return {"target": tgt, "achieved": {k: float(v) for k, v in self.achieved.items()},
                "error": float(self.error), "design": {k: float(v) for k, v in self.design.items()},
                "robustness": None if self.robustness is None else self.robustness.to_dict(),
                "verified": bool(self.verified), "stable": bool(self.stable), "snap_free": bool(self.snap_free),
                "verification": self.label, "at_bound": self.at_bound}


@dataclass
class MultiPoseResult:
    """Outcome of :func:`design_poses`; :meth:`to_dict` is the ``design --json`` contract for several
    poses: ``poses`` (each with ``target``, ``achieved``, ``design`` {h, phi, p}, ``robustness``) and
    the shared ``design.alpha`` (and ``design.magnetization`` when the magnetisation profile β(s)
    is designed: one remanent profile shared by every pose, THEORY §9)."""

    success: bool
    poses: List[PoseResult]
    alpha: Dict[str, object]
    vary: tuple
    schedule: List[Dict[str, float]]
    transitions: List[str]
    message: str
    scene: Scene
    tolerances: Optional[Tolerances]
    scenes: List[Scene] = field(default_factory=list)
    timings: Dict[str, float] = field(default_factory=dict)
    #: the designed profiles besides α(s) by lens name (a magnetisation β(s), THEORY §9), each as
    #: ``alpha``: {"s", "value", "legendre_coefficients"}; empty when none is designed
    profiles: Dict[str, Dict[str, object]] = field(default_factory=dict)
    #: "inaccurate" when the mesh does not resolve a pose's designed state (then nothing is said
    #: about reachability); "" otherwise (the status follows from ``success``/``reachable``)
    status: str = ""

    @property
    def reachable(self) -> bool:
        return bool(self.poses) and all(p.error <= 1e-3 for p in self.poses)

    @property
    def robust(self) -> bool:
        return all(p.robustness is None or p.robustness.holds for p in self.poses)

    def to_dict(self) -> dict:
        return {"success": bool(self.success), "reachable": self.reachable, "robust": self.robust,
                "poses": [p.to_dict() for p in self.poses], "design": {"alpha": self.alpha, **self.profiles},
                "vary": list(self.vary), "schedule": self.schedule, "transitions": self.transitions,
                "message": self.message, "status": self.status or ("success" if self.success else "failed"),
                "tolerances": None if self.tolerances is None else self.tolerances.to_dict(),
                "timings_s": self.timings,
                "units": {"length": "rod length", "angle": "rad", "h": "dimensionless field group",
                          "p": "B0/l^2"}}


def _fail(message, scene, vary, tol, timings, t0=None) -> MultiPoseResult:
    if t0 is not None:
        timings["total"] = time.perf_counter() - t0
    return MultiPoseResult(False, [], {}, tuple(vary), [], [], message, scene, tol, timings=timings)


def _best_attempt_check(problem, searched):
    """The mesh check (:mod:`actuator_design.inverse.mesh`) of the best-ranked optimum found when none reaches the
    target: "unreachable" is a claim only when the mesh resolves what the search found; None when
    nothing was found."""
    found = [(problem.rank(pt), i, opt, pt) for i, opt in enumerate(searched) for pt in opt.optima]
    if not found:
        return None
    _, _, opt, pt = min(found, key=lambda f: (f[0], f[1]))
    c = opt.candidate
    return check_state(c.nlp.scene_for(c.base, design_vector(c.nlp, pt)), c.nlp.solver, pt.z, problem.options)


@no_contact("design")
def design_poses(targets: Sequence[Sequence[float]], scene: Optional[Scene] = None,
                 vary: Optional[Sequence[str]] = None, options: Optional[SolverOptions] = None,
                 settings: Optional[DesignSettings] = None, verify: bool = True) -> MultiPoseResult:
    """Design one fibre layout and one field per pose so that the rod reaches every target.

    Parameters
    ----------
    targets : sequence of (x, y) or (x, y, angle)
        Two to :data:`MAX_POSES` tip poses, units of ℓ (angles in rad), visited in this order.
    scene : Scene, optional
        Base scene (default: THEORY §5's cantilever). A fibre layout given in it is kept unless
        ``vary`` includes ``alpha``.
    vary : sequence of {"h", "phi", "alpha", "p", "magnetization"}, optional
        Default (h, φ, α) — (h, φ) when the scene's fibres are fixed; α is shared by all poses, the
        others are one per pose.
    options, settings : as for :func:`~actuator_design.inverse.design.design` (``settings.tolerances``: the box every pose
        must hold over).
    verify : bool
        Run the independent checks (loading paths from zero field, transitions).

    Returns
    -------
    MultiPoseResult
    """
    t0 = time.perf_counter()
    timings: Dict[str, float] = {}
    targets = [tuple(float(v) for v in t) for t in targets]
    if not 2 <= len(targets) <= MAX_POSES:
        raise ValueError(f"--target-tip: a multi-pose design takes 2 to {MAX_POSES} poses, got {len(targets)}")
    settings = settings or DesignSettings()
    no_box = Tolerances(field_rel=0.0, angle=0.0)
    first = design_problem(targets[0], scene, vary, options, replace(settings, tolerances=no_box), None, t0)
    vset = first.variable_sets[-1] if vary is None else tuple(vary)
    if "stiffness" in vset:
        raise ValueError("--vary: a multi-pose design varies h, phi, alpha, p")
    first = replace(first, variable_sets=(vset,))
    targets = [first.target] + [design_problem(t, scene, vset, options, settings, None, t0).target
                                for t in targets[1:]]
    tol = settings.tolerances
    # pose 1's search runs beside; meanwhile the joint design's NLPs are built here
    ahead = forked.start(partial(search_set, first, vset),
                         while_waiting=[partial(_warm_joint_nlp, first, vset, len(targets), c)
                                        for c in sorted({0, len(tol.corners()) if tol.active else 0})])
    try:
        optima, out_of_time, times = ahead.result()
    finally:
        ahead.cancel()
    timings.update(times)
    searched = [Optimised(candidate(first, vset), optima, out_of_time)]
    ch1 = choose(first, searched)
    check = check_mesh(ch1, first.options) if ch1 is not None else _best_attempt_check(first, searched)
    o = first.options
    mesh = f"{o.elements} element(s) of degree {o.degree}, {o.transcription}"
    undetermined = None
    if check is not None and not check.ok:
        # the state pose 1 was designed on is no state of the rod on this mesh (design_mesh): neither
        # a design nor "unreachable" can be claimed
        undetermined = ("inaccurate", f"the mesh ({mesh}) does not resolve pose 1's designed state: "
                                      f"{check.problem}")
    elif ch1 is None and not any(opt.optima for opt in searched):
        undetermined = ("failed", f"the search found no optimum at all for pose 1 {targets[0]} on "
                                  f"this mesh ({mesh})")
    if undetermined is not None:
        res = _fail(f"{undetermined[1]}; whether the poses are reachable is not established: give "
                    "more --elements or a higher --degree", first.base, vset, tol, timings, t0)
        res.status = undetermined[0]
        return res
    if ch1 is None or not ch1.reachable:
        return _fail(f"pose 1 {targets[0]} is not reachable with {', '.join(vset)}", first.base, vset,
                     tol, timings, t0)
    # Every reachable single-pose optimum of pose 1 is a start for the shared layout, best first:
    # a joint design that fails its checks from one start is not "no design" while others are left.
    opt = next(o for o in searched if o.candidate is ch1.candidate)
    starts = [ch1] + [replace(ch1, point=pt, scene=opt.candidate.nlp.scene_for(
        opt.candidate.base, design_vector(opt.candidate.nlp, pt)))
        for pt in opt.optima if pt is not ch1.point and first.rank(pt)[0] == 0][:MAX_LAYOUT_STARTS - 1]
    first_failure = None
    for i, start in enumerate(starts):
        if i > 0 and time.perf_counter() > first.deadline:
            break
        out = _from_start(start, first, targets, vset, options, settings, verify, timings, t0)
        if out.success:
            if i > 0:
                out.message += (f"; found from pose 1's single-pose optimum no. {i + 1} (the joint design "
                                f"from the best one{'' if i == 1 else ' and the next'} did not pass its checks)")
            return out
        first_failure = first_failure or out
    return first_failure


def _warm_joint_nlp(problem, vset, n_poses: int, n_corners: int) -> None:
    """Build the joint design's scenario NLP for ``n_poses`` poses and ``n_corners`` box corners
    (:mod:`actuator_design.robust.design_robust`; with no corners also its certified variant, which the homotopy to the
    targets needs), e.g. while pose 1's search runs beside."""
    snlp = get_scenario_nlp(candidate(problem, vset).nlp, n_poses, n_corners)
    snlp.nlpsol(False)
    if n_corners == 0:
        snlp.nlpsol(True)


def _from_start(ch1, first, targets, vset, options, settings, verify, timings, t0) -> MultiPoseResult:
    """The joint design (shared profiles, one field per pose) from pose 1's single-pose design
    ``ch1``: pose k > 1 designed with its layout, the homotopy to every target, the box, checks."""
    tol = settings.tolerances
    no_box = Tolerances(field_rel=0.0, angle=0.0)
    nlp, base = ch1.candidate.nlp, ch1.candidate.base
    d_list, z_list = [design_vector(nlp, ch1.point)], [ch1.point.z]
    fixed = base  # pose 1's profiles, shared by every pose
    for v in PROFILE_VARIABLES:
        par = lens.parameter(v)
        fixed = par.with_profile(fixed, par.profile(ch1.scene))
    per_pose = tuple(v for v in vset if v not in PROFILE_VARIABLES)  # the profiles are shared
    for k, tgt in enumerate(targets[1:], start=2):
        pk = design_problem(tgt, fixed, per_pose, options, replace(settings, tolerances=no_box), None, t0)
        ck = choose(pk, search(pk, timings), hints=False)  # (its point only: no hint is reported)
        if ck is None:
            return _fail(f"pose {k}: no stable state of the rod near {tgt}", base, vset, tol, timings, t0)
        pt = ck.point
        # the field axis's representative nearest pose 1's (φ and φ + period are one field): which
        # one the search lands on is round-off, and the joint NLP's φ bounds (±2π) are not periodic
        # (on another BLAS kernel pose 2 started at φ + π and the joint design changed, issue 17)
        period = phi_period(base)
        phi = pt.phi + period * round((ch1.point.phi - pt.phi) / period)
        phi -= period * math.ceil((abs(phi) - 2 * math.pi) / period) * math.copysign(1.0, phi) \
            if abs(phi) > 2 * math.pi else 0.0  # (and within the NLP's bounds, ±2π)
        d_list.append(nlp.design_vector(h=pt.h, phi=phi, p=pt.p, profiles=ch1.point.profiles))
        z_list.append(pt.z)
    timings["single_poses"] = time.perf_counter() - t0
    s = settings
    tj = time.perf_counter()
    joint = _joint_nominal(nlp, base, d_list, z_list, targets, s)
    if joint.point is None:
        return _fail("no shared fibre layout with stable states at every pose was found "
                     f"({'; '.join(joint.attempts)})", base, vset, tol, timings, t0)
    snlp, point, scale = joint.nlp, joint.point, 1.0
    notes = []
    if tol.active:
        d_list = [snlp.pose_vector(point.d, k) for k in range(len(targets))]
        z_list = [point.z[k][0] for k in range(len(targets))]
        rob = robustify(nlp, base, d_list, z_list, targets, tol, margin=s.margin, bounds=s.bounds())
        if rob.point is not None:
            snlp, point, scale = rob.nlp, rob.point, rob.scale
        else:
            scale = 0.0
        if scale < 1.0:
            notes.append(f"no shared design found holds over the whole tolerance box; the most robust one "
                         f"holds over {100 * scale:.3g} % of it")
    timings["joint"] = time.perf_counter() - tj
    scenes = pose_designs(snlp, base, point.d)
    poses = _check_poses(snlp, nlp, scenes, point, targets, tol, first, ch1, verify, timings)
    for k, p in enumerate(poses, start=1):
        p.at_bound = _at_bound(p.design, s.bounds())
        if p.at_bound:
            notes.append(f"pose {k} is on a design bound ({p.at_bound})")
    schedule, transitions = (_visit_in_order(poses, scenes, first, timings) if verify and all(p.verified for p in poses)
                             else ([], []))
    ok = (all(p.verified and p.stable and p.snap_free and p.error <= s.accept_tol for p in poses)
          and all(p.robustness is None or p.robustness.holds for p in poses) and bool(schedule))
    for k, p in enumerate(poses, start=1):
        if not p.verified:
            notes.append(f"pose {k} not verified: {p.label}")
        elif p.robustness is not None and not p.robustness.holds:
            notes.append(f"pose {k} does not hold over the box")
    if verify and all(p.verified for p in poses) and not schedule:
        notes.append("no snap-free schedule visits the poses in order")
    report = profile_report(scenes[0], {**ch1.point.profiles, **snlp.dmap.shared_values(point.d)}, vset)
    alpha = report.pop("alpha")
    timings["total"] = time.perf_counter() - t0
    head = (f"one layout, {len(poses)} poses, each verified from rest and holding over the box" if ok
            else "NOT a success")
    return MultiPoseResult(ok, poses, alpha, vset, schedule, transitions, "; ".join([head] + notes), first.base,
                           tol if tol.active else None, scenes=scenes,
                           timings=timings, profiles=report)


#: Most single-pose optima of pose 1 tried as starts of the shared layout.
MAX_LAYOUT_STARTS = 3


def _at_bound(design: Dict[str, float], bounds: Dict[str, float], rel: float = 1e-6) -> str:
    """Which bound a pose's field sits on: h at h_max or |p| at p_max (within ``rel``), or ""."""
    out = []
    if design.get("h", 0.0) >= bounds["h_max"] * (1 - rel):
        out.append(f"h = h_max = {bounds['h_max']:g}")
    p_max = bounds.get("p_max", math.inf)
    if math.isfinite(p_max) and abs(design.get("p", 0.0)) >= p_max * (1 - rel):
        out.append(f"|p| = p_max = {p_max:g}")
    return ", ".join(out)


def _joint_nominal(nlp, base, d_list, z_list, targets, settings, first_step=0.25, min_step=1.0 / 128):
    """Every pose exact with one shared layout, by homotopy in the targets: each pose's target moves
    from the tip its start reaches to the real target, each solve warm-started from the last (a
    direct solve from starts far from the targets is often declared locally infeasible).

    The step is adaptive: a step that fails (no convergence, or a pose left without a stable state)
    is halved and retried from the last point that worked, down to ``min_step``; a step that works
    grows by half. So the outcome does not hang on one solve's iteration limit (a start on the
    stability margin, which the least-effort single-pose design sits on, needs short first steps
    on some BLAS kernels and not on others); "no design" means the homotopy stalled at a fraction
    below ``min_step`` of the way, which the message states."""
    sv = nlp.solver
    no_box = Tolerances(field_rel=0.0, angle=0.0)
    start_tips = []
    for d, z in zip(d_list, z_list):
        _, th, x, y = sv.summary(z, sv.parameter_vector(nlp.scene_for(base, d)))
        start_tips.append(np.array([x, y, th]))
    done, step, out = 0.0, first_step, None
    while done < 1.0:
        frac = min(1.0, done + step)
        tg = [tuple(t0[:len(t)] + frac * (np.asarray(t) - t0[:len(t)])) for t0, t in zip(start_tips, targets)]
        trial = robustify(nlp, base, d_list, z_list, tg, no_box, margin=settings.margin, bounds=settings.bounds())
        if trial.point is None:
            step *= 0.5
            if step < min_step:
                trial.attempts.insert(0, f"the homotopy from the single-pose designs stalled "
                                         f"{100 * done:.3g} % of the way to the targets")
                return trial
            continue
        out, done, step = trial, frac, min(1.0, 1.5 * step)
        d_list = [out.nlp.pose_vector(out.point.d, k) for k in range(len(targets))]
        z_list = [out.point.z[k][0] for k in range(len(targets))]
    return out


def _check_poses(snlp, nlp, scenes, point, targets, tol, problem, ch1, verify, timings) -> List[PoseResult]:
    """Per pose: robustness by branch following and, with ``verify``, a loading path from rest;
    the poses after the first are checked beside it (:mod:`actuator_design.forked`)."""
    check = partial(_check_pose, snlp, nlp, scenes, point, targets, tol, problem, ch1, verify)
    beside = []
    try:
        for k in range(1, len(targets)):
            beside.append(forked.start(partial(check, k)))
        checked = [check(0)] + [job.result() for job in beside]
    finally:
        for job in beside:
            job.cancel()
    for _, times in checked:
        timings.update(times)
    return [pose for pose, _ in checked]


def _check_pose(snlp, nlp, scenes, point, targets, tol, problem, ch1, verify, k):
    """Pose k's check (see :func:`_check_poses`): ``(PoseResult, timings)``."""
    sv, sc, tgt, timings = nlp.solver, scenes[k], targets[k], {}
    z = point.z[k][0]
    _, th, x, y = sv.summary(z, sv.parameter_vector(sc))
    dv = snlp.pose_vector(point.d, k)
    dp = nlp.point(dv, sc, z, np.array([x, y, th]), converged=True, status="joint", stage="poses")
    rob = evaluate_robustness(sc, z, tgt, tol, problem.options) if tol.active else None
    verified, stable, snap_free, label, sched, ach = False, False, False, "not verified (skipped)", [], \
        {"x": x, "y": y, "angle": th}
    state = None
    if verify:
        tv = time.perf_counter()
        v = verify_stage(problem, Choice(point=dp, candidate=ch1.candidate, scene=sc, reachable=True,
                                         notes=[], alternatives={}, optima=[]))
        timings[f"verify_pose_{k + 1}"] = time.perf_counter() - tv
        label = v.label
        if v.path is not None:
            final = v.path.final
            state = final
            verified, stable, snap_free = True, bool(final.stable), bool(v.path.snap_free)
            ach = {"x": final.tip["x"], "y": final.tip["y"], "angle": final.tip["angle"]}
            sched = schedule_rows(v.schedule)
    return PoseResult(tgt, ach, tip_error((ach["x"], ach["y"], ach["angle"]), tgt),
                      {"h": dp.h, "phi": normalise_phi(dp.phi, phi_period(sc)), "p": dp.p}, rob, verified, stable,
                      snap_free, sched, label, z, state), timings


def _visit_in_order(poses: List[PoseResult], scenes: List[Scene], problem, timings):
    """The schedule from rest through every pose in order, each transition checked by a loading path
    that lands on the next pose's state; falls back to ramping the field down and the next pose's
    verified schedule from rest."""
    tv = time.perf_counter()
    sched = [dict(q, pose=1) for q in poses[0].schedule]
    labels = [f"pose 1: {poses[0].label}"]
    for k in range(1, len(poses)):
        prev, nxt = sched[-1], poses[k]
        # the rod at pose k, as the previous leg left it, in pose k's scene (same rod, its field)
        # the same field modulo the energy's period in φ (π; 2π with a hard-magnetic term) nearest
        # the previous angle; the remanent groups (h_r ∝ H, THEORY §9) move with the field like h
        phi_next = prev["phi"] + normalise_phi(nxt.design["phi"] - prev["phi"], phi_period(scenes[k]))
        groups = {g: f for g, (_, f) in ramped_groups(scenes[k]).items() if g != "h" and g in prev}
        leg = [{"h": prev["h"], "phi": prev["phi"], **{g: prev[g] for g in groups}},
               {"h": nxt.design["h"], "phi": phi_next, **{g: lens.parameter(g).get(scenes[k]) for g in groups}}]
        start_scene = scenes[k - 1].with_values(h=prev["h"], phi=prev["phi"])
        for g in groups:
            start_scene = lens.parameter(g).write(start_scene, prev[g])
        path = follow_path(start_scene, problem.options, leg, initial=poses[k - 1].z, max_dtheta=0.3)
        tip = path.final.tip if path.final is not None and path.final.success else None
        first = path.points[0].tip if path.points else None
        start_ok = first is not None and tip_error((first["x"], first["y"]), (poses[k - 1].achieved["x"],
                                                                            poses[k - 1].achieved["y"])) <= 1e-6
        if (tip is not None and path.snap_free and start_ok and path.final.stable
                and tip_error((tip["x"], tip["y"]), (nxt.achieved["x"], nxt.achieved["y"])) <= 1e-6):
            sched += [dict(q, pose=k + 1) for q in leg[1:]]
            labels.append(f"pose {k + 1}: straight from pose {k}'s field, rotating "
                          f"{math.degrees(phi_next - prev['phi']):+.3g} deg")
            continue
        down = [{"h": prev["h"] * t, "phi": prev["phi"], **{g: prev[g] * t ** f for g, f in groups.items()}, "pose": k}
                for t in np.linspace(1, 0, 6)[1:]]
        sched += down + [dict(q, pose=k + 1) for q in nxt.schedule]
        labels.append(f"pose {k + 1}: field down to zero, then its own schedule from rest ({nxt.label})")
    timings["transitions"] = time.perf_counter() - tv
    return sched, labels
