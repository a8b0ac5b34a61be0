"""Inverse design: the field (and fibre layout, tip load) that puts the tip where the user wants it,
as a stable state the real actuator reaches from rest.

:func:`design` runs named stages, each a function of its own module, passing small dataclasses
(:mod:`actuator_design.inverse.settings`):

1. **Screen** (:mod:`actuator_design.inverse.screen`) a grid of starting designs with forward solves (stable
   states by construction) and keep the few whose tip is nearest the target.
2. **Optimise** (:mod:`actuator_design.inverse.optimise`) from each with the design NLP (:mod:`actuator_design.inverse.nlp`):
   stage A finds the nearest reachable pose, stage B the least-effort design that reaches the
   target exactly. Distinct local optima are kept. Screen and optimise run once per variable set:
   when the user does not choose, field magnitude and angle first; when they cannot reach the
   target, the fibre layout α(s) is added (and the report says so).
3. **Choose** (:mod:`actuator_design.inverse.choose`) the best optimum over the sets tried, with the notes that
   explain it.
3a. **Resolve** (:mod:`actuator_design.inverse.mesh`): the chosen state must meet the accuracy promise of ``solve``
   (Euler–Lagrange residual) on the design mesh; if it does not, the search is run again on the
   mesh graded towards the clamp for the design's field, and a design the mesh cannot resolve is
   reported as ``status: "inaccurate"``, never as a design.
3b. **Robustify** (:mod:`actuator_design.robust.design_robust_stage`): move the design to one that holds over the lab's
   tolerance box (worst-case tip error over the box's corners, every corner stable; the target
   exact at the nominal field) and report how it holds by following its branch over the box and
   to the nearest snap. A design that does not hold over the box is not a success.
4. **Verify independently** (:mod:`actuator_design.inverse.verify`), never with the design NLP's own state: a fresh
   forward solve, and a quasi-static loading path from zero field to the design. A design counts
   only if such a path reaches it without a snap and it is stable.

:func:`result_of` turns the stages' outputs into the :class:`DesignResult`. The request is validated
before any stage runs (:func:`design_problem`); a numerical error inside a stage is a result with
``status: "failed"`` naming the stage, not an exception.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace
from functools import partial
from typing import Dict, List, Optional, Sequence

import numpy as np

from actuator_design import forked
from actuator_design.analysis.registration import register
from actuator_design.contact.clearance import clearances, entered_at_rest
from actuator_design.contact.guard import refuse_contact
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.inverse.choose import choose
from actuator_design.inverse.design_map import (driven_values, fibres_fixed, field_bound, prepare_scene,
                                                profile_report, without_soft_coupling)
from actuator_design.inverse.mesh import (MAX_REGRADES, check_mesh, check_state, grading, mesh_dict, regrade,
                                          unresolved)
from actuator_design.inverse.mirror import mirror_choice, mirrored_problem, robust_by_mirror
from actuator_design.inverse.nlp import DESIGN_VARIABLES, PROFILE_VARIABLES, profile_bound, refuse_idle
from actuator_design.inverse.optimise import candidate, design_vector, search_set, warm_robust_nlp
from actuator_design.inverse.settings import (Choice, DesignProblem, DesignResult,  # noqa: F401
                                              DesignSettings, Optimised, Verification, canonical_target,
                                              normalise_phi, normalise_tip_angle, phi_period,
                                              tip_error)
from actuator_design.inverse.verify import schedule_rows, stiffness_by_differences
from actuator_design.inverse.verify import verify as verify_stage
from actuator_design.model.scene import Scene, UniformField, default_scene
from actuator_design.physics import parameters as lens
from actuator_design.robust.design_robust_stage import RobustReport, reachable, robust_stage
from actuator_design.robust.tolerances import parse_tolerances

__all__ = ["design", "DesignResult", "DesignSettings", "AUTO_VARIABLE_SETS", "design_problem", "search",
           "result_of", "fibres_fixed"]

#: Variable sets tried in order when the user does not choose (``--vary`` omitted).
AUTO_VARIABLE_SETS = (("h", "phi"), ("h", "phi", "alpha"))

# names kept for existing importers (schedule, tests)
_normalise_phi = normalise_phi
_tip_error = tip_error


def design(target: Optional[Sequence[float]] = None, scene: Optional[Scene] = None,
           vary: Optional[Sequence[str]] = None, options: Optional[SolverOptions] = None,
           settings: Optional[DesignSettings] = None, verify: bool = True,
           stiffness: Optional[float] = None) -> DesignResult:
    """Find a stable, reachable design that puts the tip at ``target`` (and/or gives the tip the
    vertical stiffness ``stiffness``).

    Parameters
    ----------
    target : (x, y) or (x, y, angle), optional
        Tip position in units of ℓ (clamp at the origin, rod initially along +x), optional tip
        angle in rad (taken modulo 2π).
    scene : Scene, optional
        Base scene (default: THEORY §5's cantilever with zero field, p = 0, α = 0).
    vary : sequence of {"h", "phi", "alpha", "p", "magnetization"}, optional
        Design variables; default: (h, φ), adding α(s) if needed (see :data:`AUTO_VARIABLE_SETS`);
        for a stiffness target alone, h. ``magnetization`` designs the remanent magnetisation
        angle β(s) of a hard-magnetic rod (THEORY §9; the scene must give h_r > 0), reported as
        ``design["magnetization"]`` like ``design["alpha"]``.
    options : SolverOptions, optional
        Forward transcription the design satisfies.
    settings : DesignSettings, optional
    verify : bool
        Run the independent verification (forward solve + loading path).
    stiffness : float, optional
        Target tip stiffness dp/dv1 (units of B0/ℓ³; K = s·B0/ℓ³ in N/m, THEORY §6).

    Returns
    -------
    DesignResult
    """
    t0 = time.perf_counter()
    problem = design_problem(target, scene, vary, options, settings, stiffness, t0)
    timings: Dict[str, float] = {}
    stage = ["search"]
    try:
        result = _stages(problem, verify, timings, stage)
    except NUMERICAL_ERRORS as exc:  # a numerical failure inside a stage is a result, not bad input
        result = _failed(problem, stage[0], exc, timings)
    timings["total"] = time.perf_counter() - t0
    return result


#: What a stage may raise on a numerical failure (a singular matrix, an overflow, a CasADi
#: evaluation error): reported as ``status: "failed"`` naming the stage. The request itself is
#: validated before any stage runs (:func:`design_problem`), so none of these is bad input.
NUMERICAL_ERRORS = (ValueError, ArithmeticError, RuntimeError, np.linalg.LinAlgError)


def _stages(problem: DesignProblem, verify: bool, timings: Dict[str, float], stage: List[str]) -> DesignResult:
    """search → choose → resolve the mesh → robustify → verify → result (``stage[0]``: the running one)."""
    mirror = mirrored_problem(problem)  # a target below the axis is searched as its mirror
    searched = search(mirror or problem, timings)
    stage[0] = "choose"
    choice = choose(mirror or problem, searched)
    stage[0] = "mesh check"
    problem, mirror, choice, check, graded = _resolved(problem, mirror, choice, searched, timings)
    if choice is None:
        return _no_design(problem, timings)
    mesh = mesh_dict((mirror or problem).options, check, graded)
    if not check.ok:
        return _inaccurate(problem, mirror, choice, check, mesh, timings)
    if graded:
        choice.notes.append(f"designed on the mesh graded for the design's field ({grading(problem.options)}, "
                            "as solve grades it): on the given mesh the design did not meet the accuracy of solve")
    stage[0] = "robustness"
    tr = time.perf_counter()
    # the verification of a moved design starts beside the robust stage's own branch following
    follow = partial(verify_stage, problem) if verify else None
    if mirror is None:
        choice, robust, verifying = robust_stage(problem, choice, follow)
    else:  # the robust design of the mirror problem, reflected; its report made on the user's problem
        choice, robust, verifying = robust_by_mirror(problem, mirror, choice, follow)
    timings["robustness"] = time.perf_counter() - tr
    verification = None
    if verify:
        stage[0] = "verification"
        tv = time.perf_counter()
        try:
            verification = verifying.result() if verifying is not None else verify_stage(problem, choice)
        finally:
            if verifying is not None:
                verifying.cancel()
        if verification.path is None and robust is not None and robust.fallbacks:  # a design the user can reach
            choice, robust, verification = reachable(problem, choice, robust, verification, follow)
        timings["verify"] = time.perf_counter() - tv
    result = result_of(problem, choice, verification, timings, robust)
    result.mesh = mesh
    return result


def _resolved(problem: DesignProblem, mirror: Optional[DesignProblem], choice: Optional[Choice],
              searched: List[Optimised], timings: Dict[str, float]):
    """Hold the chosen design to the accuracy of ``solve`` on its mesh (:mod:`actuator_design.inverse.mesh`):
    search again on the mesh graded for its field while that changes the mesh; where it cannot be
    refined further, take the best optimum found whose state the mesh does resolve.

    Returns
    -------
    (problem, mirror, choice, MeshCheck or None, graded)
        The problem (and mirror) whose mesh the choice was made on.
    """
    check, graded = None, False
    for k in range(MAX_REGRADES + 1):
        if choice is None:
            return problem, mirror, None, None, graded
        check = check_mesh(choice, (mirror or problem).options)
        if check.ok:
            break
        finer, finer_mirror = (regrade(problem, mirror, choice, (mirror or problem).options)
                               if k < MAX_REGRADES else (None, None))
        if finer is None:
            choice, check = _resolved_alternative(mirror or problem, searched, choice, check)
            break
        again: Dict[str, float] = {}
        found_in = search(finer_mirror or finer, again)
        timings.update({f"{key}_regraded{k + 1}": v for key, v in again.items()})
        found = choose(finer_mirror or finer, found_in)
        if found is None:
            break
        problem, mirror, choice, searched, graded = finer, finer_mirror, found, found_in, True
    return problem, mirror, choice, check, graded


def _resolved_alternative(problem: DesignProblem, searched: List[Optimised], choice: Choice, check):
    """The best of the optima whose states the mesh resolves that reaches the target, chosen as
    :func:`choose` does, or ``(choice, check)`` unchanged when there is none (a resolved pose that
    misses the target says nothing of whether an unresolved one that reaches it is real)."""
    opts = problem.options
    kept = [replace(opt, optima=[pt for pt in opt.optima if check_state(
        opt.candidate.nlp.scene_for(opt.candidate.base, design_vector(opt.candidate.nlp, pt)),
        opt.candidate.nlp.solver, pt.z, opts).ok]) for opt in searched]
    alt = choose(problem, kept) if any(opt.optima for opt in kept) else None
    alt_check = check_mesh(alt, opts) if alt is not None and alt.reachable else None
    if alt_check is None or not alt_check.ok:
        return choice, check
    alt.notes.append(f"the best design found is not resolved by the mesh ({check.problem}); the best "
                     "one whose state it resolves is reported")
    return alt, alt_check


def _inaccurate(problem: DesignProblem, mirror, choice: Choice, check, mesh, timings) -> DesignResult:
    """The result when the mesh does not resolve the chosen design's state: not verified, not
    checked over the box, ``status: "inaccurate"``."""
    if mirror is not None:
        choice = mirror_choice(choice, phi_period(problem.base))
    o = problem.options
    where = (f"{o.elements} element{'s' if o.elements != 1 else ''} of degree {o.degree}"
             + (f", graded {grading(o)}" if o.clamp_levels or o.tip_levels else "")
             if o.transcription == "lgl" else f"midpoint rule, {o.elements} intervals")
    result = result_of(problem, replace(choice, notes=[]), None, timings, None)
    # the state is no state of the rod: whether the target is reachable is not established
    result.status, result.success, result.reachable, result.mesh = "inaccurate", False, False, mesh
    result.message = "; ".join(
        list(problem.notes)
        + [f"the design mesh ({where}) does not resolve the designed state: {check.problem}; so whether "
           "the target is reachable is not known, and the design was neither checked over the tolerance "
           "box nor verified: give more --elements or a higher --degree (solver.elements, solver.degree)"]
        + list(choice.notes))
    return result


def _failed(problem: DesignProblem, stage: str, exc: Exception, timings: Dict[str, float]) -> DesignResult:
    """The result when a stage stopped on a numerical error (``status: "failed"``)."""
    result = _no_design(problem, timings)
    o = problem.options
    result.status = "failed"
    result.message = "; ".join(list(problem.notes) + [
        f"the design's {stage} stage failed: {type(exc).__name__}: {' '.join(str(exc).split())} (mesh: "
        f"{o.transcription}, {o.elements} elements, degree {o.degree}); no design is reported"])
    return result


def design_problem(target, scene, vary, options, settings, stiffness, t0: float) -> DesignProblem:
    """Validate a request (one clear ``ValueError`` per bad field) into a :class:`DesignProblem`."""
    target = () if target is None else tuple(float(v) for v in target)
    if target and (len(target) not in (2, 3) or not all(math.isfinite(v) for v in target)):
        raise ValueError(f"target: expected finite x,y[,angle], got {target}")
    if len(target) == 3:
        target = (target[0], target[1], normalise_tip_angle(target[2]))
    target = canonical_target(target)  # one problem however the target was written
    if stiffness is not None and not (math.isfinite(stiffness) and stiffness > 0):
        raise ValueError(f"stiffness target: must be a finite number > 0, got {stiffness}")
    if not target and stiffness is None:
        raise ValueError("design needs a target tip pose, a stiffness target, or both")
    settings = settings or DesignSettings()
    if not isinstance(settings, DesignSettings):
        raise ValueError(f"settings: expected DesignSettings, got {type(settings).__name__}")
    base = scene or default_scene(h=0.0)
    h_max, notes = field_bound(settings.h_max, base, vary)
    settings = replace(settings, h_max=h_max) if h_max != settings.h_max else settings
    tol = settings.tolerances
    if tol.angle > 0 and base.field is not None and not isinstance(base.field, UniformField):
        settings = replace(settings, tolerances=replace(tol, angle=0.0))  # no angle to be off by
        notes.append(f"the tolerance box has no field angle: this scene's field is not uniform "
                     f"(box: {settings.tolerances.describe()})")
    if stiffness is not None:
        base = lens.parameter("p").require(base)  # the stiffness is dp/dv1: p must be a term
    if vary is not None:
        unknown = [v for v in vary if v not in DESIGN_VARIABLES]
        if unknown or not vary:
            raise ValueError(f"--vary: unknown design variable(s) {unknown} (allowed: {', '.join(DESIGN_VARIABLES)})")
        if "alpha" in vary and not base.fibres_physical:
            raise ValueError("--vary alpha: the fibre layout has no effect on this actuator (isotropic "
                             "particles: the easy axis is the rod's tangent, THEORY §10); vary h, phi, p")
        sets = (tuple(vary),)
        if any(lens.parameter(v).design_check is not None for v in vary):
            prepare_scene(base, vary)  # one clear error up front when a profile would do nothing (no remanence)
    elif lens.remanent_groups(base) and target:  # a hard-magnetic rod designs with its own physics: the field,
        # then the magnetisation profile β(s) (THEORY §9), never a fibre layout; without soft
        # coupling (h = 0) the field magnitude is the scene's and only its angle is designed
        field = ("phi",) if without_soft_coupling(base) else ("h", "phi")
        sets = (field, field + lens.remanent_profiles(base))
    elif not target:  # a stiffness alone: the field magnitude, then its angle too (a transverse
        # field softens the straight rod below the axial field's s(0) = 3, THEORY §6)
        sets = (("phi",),) if without_soft_coupling(base) else (("h",), ("h", "phi"))
    else:  # the fibre layout is designed only when the scene leaves it free (issue 9: the user's
        # actuator is the user's)
        sets = ((AUTO_VARIABLE_SETS[0],) if fibres_fixed(base) or not base.fibres_physical
                else AUTO_VARIABLE_SETS)
    if without_soft_coupling(base) and not lens.remanent_group(base, stored=True) > np.finfo(float).tiny:  # zero field
        names = ", ".join(p.name for p in lens.remanent_groups(base))
        raise ValueError(f"the scene's field is 0 and this rod has no soft-magnetic coupling: the field acts on it "
                         f"through {names} alone, at the scene's magnitude; give the field's magnitude in the "
                         "scene (the design varies its angle and profiles)")
    if base.obstacles and (stiffness is not None or not target):
        refuse_contact(base, "design --target-stiffness")  # a pose with obstacles: the rod kept clear of them
    rest = entered_at_rest(base)
    if rest is not None:  # the design keeps the rod clear from rest on (a curved lumen holds it in contact)
        raise ValueError(f"design --target-tip: {rest}; a design keeps the rod clear of the obstacles from rest "
                         "on, so it needs a free rest state (solve and path model a rod held in contact)")
    if getattr(base.field, "kind", "") == "sources":
        raise ValueError("design: in a field of magnets and coils only the coils' currents (`field: {type: coils}`) "
                         "or one magnet's pose (a magnet with a `travel`) can be designed, for one tip target "
                         "(`design CONFIG --target-tip X,Y`), a shape (`--target-shape FILE.csv`) or a stiffness "
                         "(`--target-stiffness K`, with or without a tip target); several poses are a schedule "
                         "(`schedule CONFIG --waypoints 'X1,Y1;X2,Y2'`: the currents or the pose at each)")
    if vary is None and base.field is not None and not base.field.is_uniform:
        # a magnet, coil or dipole field has no angle to turn: its strength h (every source scaled
        # together) is designed, with the fibre layout or magnetisation where the scene leaves it free
        sets = tuple(dict.fromkeys(tuple(v for v in vs if v != "phi") for vs in sets if vs != ("phi",)))
        sets = tuple(vs for vs in sets if vs)
        notes.append(f"the field is not uniform ({base.field.kind}): its angle is not a design variable; "
                     "h scales the whole field (every source together)")
        if not sets:
            raise ValueError(f"nothing to design: a {base.field.kind} field has no angle and this rod's "
                             f"field acts through {', '.join(p.name for p in lens.remanent_groups(base))} alone; "
                             f"give --vary {','.join(lens.remanent_profiles(base))}")
    for vset in sets:  # every set's terms, up front: a stage's error is then never bad input
        ready = prepare_scene(base, vset)
        if vary is not None:  # and every variable the user names acts on the actuator
            refuse_idle(ready, vset, options or SolverOptions(), settings.alpha_terms, settings.clearance)
    return DesignProblem(target=target, stiffness=stiffness, base=base, options=options or SolverOptions(),
                         settings=settings, variable_sets=tuple(sets), user_vary=vary is not None,
                         deadline=t0 + settings.time_limit,
                         fibres_fixed=fibres_fixed(base) and base.fibres_physical, notes=tuple(notes))


def search(problem: DesignProblem, timings: Dict[str, float]) -> List[Optimised]:
    """Screen and optimise each variable set in turn until one reaches the target.

    The search stops before adding variables when the best design of a set is not resolved by
    the mesh (:func:`~actuator_design.inverse.mesh.unresolved`): the mesh is regraded first (:func:`design`).

    Returns
    -------
    list of Optimised
        One per variable set tried; ``timings`` gets ``build_<set>`` and ``optimise_<set>`` (s).
    """
    sets = problem.variable_sets
    searched: List[Optimised] = []
    ahead = current = None  # the next set's search, computed beside this one (:mod:`actuator_design.forked`)
    try:
        for k, vset in enumerate(sets):
            current = ahead
            ahead = (forked.start(partial(search_set, problem, sets[k + 1]),
                                  while_waiting=[partial(warm_robust_nlp, problem, sets[k + 1])])
                     if k + 1 < len(sets) else None)
            optima, out_of_time, times = current.result() if current is not None else search_set(problem, vset)
            searched.append(Optimised(candidate(problem, vset), optima, out_of_time))
            timings.update(times)
            if any(opt.reaches(problem) for opt in searched):
                break
            # the best stable optimum (an uncertified probe is not what the choice reports)
            best = [pt for pt in searched[-1].optima if getattr(pt, "certified", True)][:1]
            if best and vset != sets[-1] and unresolved(searched[-1].candidate, best[0], problem.options):
                break  # more variables on a mesh that does not resolve this set's best: regrade first
    finally:
        for job in (current, ahead):
            if job is not None:
                job.cancel()
    return searched


def result_of(problem: DesignProblem, choice: Choice, verification: Optional[Verification],
              timings: Dict[str, float], robust: Optional[RobustReport] = None) -> DesignResult:
    """The :class:`DesignResult` of a chosen design, its robustness and its verification (None: not
    run).

    ``success`` needs reachable, verified, stable, snap-free, the verified tip within
    ``accept_tol``, (if asked) the stiffness within ``accept_tol`` relative, and (with a tolerance
    box and a pose target) the design holding over the box; the message gives the reason whenever
    it is False.
    """
    best, vary, target, stiffness = choice.point, choice.candidate.vary, problem.target, problem.stiffness
    notes = list(problem.notes) + list(choice.notes)
    result = DesignResult(
        success=False, reachable=choice.reachable, verified=False, stable=False, snap_free=False, target=target,
        achieved={"x": best.tip[0], "y": best.tip[1], "angle": best.tip[2]},
        error=tip_error(best.tip, target) if target else 0.0,
        design={"h": best.h, "phi": normalise_phi(best.phi, phi_period(choice.scene)) if "phi" in vary
                else best.phi, "p": best.p,
                # the fibre layout α(s), and the remanent magnetisation angle β(s) when it is designed
                **profile_report(choice.scene, best.profiles, vary),
                # the other groups at the design field (h_pos, h_r ∝ H like h: THEORY §5, §9)
                **driven_values(choice.scene)},
        vary=vary, schedule=[], message="", scene=problem.base, design_scene=choice.scene, optima=choice.optima,
        alternatives=choice.alternatives, timings=timings, stiffness_target=stiffness,
        achieved_stiffness=getattr(best, "stiffness", None),
        tolerances=problem.settings.tolerances if problem.settings.tolerances.active else None,
        robustness=robust)
    stiffness_ok = True
    if verification is None:
        notes.append("not verified (the independent verification was skipped)")
    elif verification.path is None:
        result.forward = verification.forward
        notes.append(verification.label)
    else:
        stiffness_ok = _take_verified(result, problem, verification, notes)
    state = result.path.final if result.path is not None else result.forward
    if problem.base.obstacles and state is not None and state.success:
        result.clearance = clearances(problem.base.obstacles, problem.base.contact_gap, state)
    if choice.reachable and "h" in vary and best.h >= problem.settings.h_max * (1.0 - 1e-4):
        notes.append(f"the design's field sits at its bound h = {problem.settings.h_max:g} (--h-max): "
                     "a stronger field was not allowed")
    # a design beyond the field its magnetisation model holds to, on the rod's verified shape
    shape = state.evaluate(np.linspace(0.0, 1.0, 201)) if state is not None and state.success else {}
    beyond = lens.beyond_model(choice.scene, shape.get("x"), shape.get("y"))
    if beyond is not None:
        notes.append(f"not a success: {beyond}" + ("; lower --h-max" if "h" in vary else ""))
    accept = problem.settings.accept_tol
    # a tolerance box asked for and not checked is no success (issue: a stiffness target claimed it)
    robust_ok = robust.holds if robust is not None else not problem.settings.tolerances.active
    result.success = bool(result.reachable and result.verified and result.stable and result.snap_free
                          and result.error <= accept and stiffness_ok and robust_ok and beyond is None)
    if result.verified and result.reachable and robust is None and not robust_ok:
        notes.append(f"not a success: the design was not checked over the tolerance box "
                     f"({problem.settings.tolerances.describe()})")
    elif result.verified and robust is not None and not robust_ok:
        notes.append("not a success: the design does not hold over the tolerance box")
    if result.verified and result.reachable and result.error > accept:
        notes.append(f"not a success: the verified tip misses the target by {result.error:.3g} (> {accept:g})")
    if result.verified and not stiffness_ok:
        notes.append(f"not a success: the verified stiffness {result.achieved_stiffness:.6g} differs from the "
                     f"target {stiffness:.6g} by more than {accept:g} relative")
    result.message = "; ".join(notes) or ("design found" if result.success else "")
    return result


def _take_verified(result: DesignResult, problem: DesignProblem, v: Verification, notes: List[str]) -> bool:
    """Copy a verified path's final state into ``result``; return whether the stiffness (if asked)
    is met."""
    final, target = v.path.final, problem.target
    result.forward, result.path = v.forward, v.path
    result.achieved = {"x": final.tip["x"], "y": final.tip["y"], "angle": final.tip["angle"]}
    result.error = tip_error((final.tip["x"], final.tip["y"], final.tip["angle"]), target) if target else 0.0
    result.stable = bool(final.stable)
    result.snap_free = bool(v.path.snap_free)
    result.stability_margin = float(final.eigenvalues[0])
    # one shift by a multiple of the period for the whole schedule keeps a rotating field continuous
    # (the energy is π-periodic in φ, 2π with a hard-magnetic term: the end angle is equivalent)
    phi0 = float(v.schedule[0]["phi"])
    shift = normalise_phi(phi0, phi_period(result.design_scene)) - phi0
    result.schedule = schedule_rows(v.schedule, shift)
    result.verified = True
    notes.append(f"verified by a loading path from zero field: {v.label}")
    fwd = v.forward
    if fwd.success and max(abs(fwd.tip["x"] - final.tip["x"]), abs(fwd.tip["y"] - final.tip["y"])) > 1e-6:
        notes.append("a forward solve from the straight rod at the designed field lands on "
                     "another equilibrium; the design is reached only along the reported schedule")
    if problem.stiffness is None:
        return True
    result.achieved_stiffness = stiffness_by_differences(result.design_scene, problem.options, final)
    result.achieved["stiffness"] = result.achieved_stiffness
    return abs(result.achieved_stiffness / problem.stiffness - 1.0) <= problem.settings.accept_tol


def _no_design(problem: DesignProblem, timings: Dict[str, float]) -> DesignResult:
    """The result when no variable set produced a stable optimum within the bounds."""
    b, last = problem.settings.bounds(), problem.variable_sets[-1]
    limits = ", ".join([f"h <= {b['h_max']:g}"] + ([f"|p| <= {b['p_max']:g}"] if "p" in last else [])
                       + [f"|{name}| <= {math.degrees(b[profile_bound(name)]):g} deg"
                          for name in PROFILE_VARIABLES if name in last])
    hint = (" (in an axial field the straight rod only stiffens: its stiffness is at least s(0) = 3 "
            "B0/l^3, THEORY §6)" if problem.stiffness is not None and not problem.target else "")
    return DesignResult(success=False, reachable=False, verified=False, stable=False, snap_free=False,
                        target=problem.target, achieved={}, error=float("inf"),
                        design={"h": float("nan"), "phi": float("nan"), "p": float("nan")}, vary=last,
                        schedule=[], message="; ".join(list(problem.notes) + [
                            f"no stable design of {', '.join(last)} reaches the target within the bounds "
                            f"({limits}){hint}"]),
                        scene=problem.base, timings=timings, stiffness_target=problem.stiffness,
                        tolerances=problem.settings.tolerances if problem.settings.tolerances.active else None)


@register("design")
def run_design(scene, options, target=None, vary=None, stiffness=None, **settings) -> dict:
    """Study entry: ``design`` with ``target: [x, y(, angle)]`` and/or ``stiffness``, optional ``vary``
    and settings."""
    if target is None and stiffness is None:
        raise ValueError("design: give 'target' (e.g. target: [0.3, 0.5]) and/or 'stiffness'")
    if "tolerances" in settings:
        settings = {**settings, "tolerances": parse_tolerances(settings["tolerances"])}
    res = design(target, scene=scene, vary=vary, options=options, settings=DesignSettings(**settings),
                 stiffness=stiffness)
    out = res.to_dict()
    out["design"] = {k: v for k, v in out["design"].items() if k not in PROFILE_VARIABLES}
    return out
