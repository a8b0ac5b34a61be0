"""The mirror symmetry of inverse design: a target below the rod's axis is designed as its mirror.

The planar rod's energy (THEORY §4–5, §9) is invariant under the reflection y → −y of the plane:
θ → −θ with φ → −φ, α → −α, β → −β, θ0 → −θ0, and the loads' y-components and the tip moment
negated. So a uniform-field scene S with target T and its mirror scene S' with target T' are one
problem. The search (screen grid, multistart, choice among optima) is not itself symmetric, so left
alone it could design T and miss T' (issue 17: (0.5, 0.5) designed, (0.5, −0.5) not). The rule here
makes the outcome a function of the problem: a target with y < 0 is searched as (S', T') and the
chosen design is mirrored back, so T and T' get mirror designs; the robust stage and the
independent verification then run on the user's own problem. The result says so in its notes.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, Optional

import numpy as np

from actuator_design.inverse.nlp import DesignPoint
from actuator_design.inverse.optimise import design_vector
from actuator_design.inverse.settings import (Candidate, Choice, DesignProblem, normalise_phi,
                                              normalise_tip_angle, phi_period)
from actuator_design.model.profiles import Profile
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import term_class
from actuator_design.robust.design_robust_stage import RobustReport, robust_stage
from actuator_design.robust.robustness import evaluate_robustness

__all__ = ["mirror_scene", "mirrored_problem", "mirror_choice", "robust_by_mirror", "MIRROR_NOTE"]

MIRROR_NOTE = ("found by symmetry: the target lies below the rod's axis, so it was designed as its mirror "
               "(x, -y) and mirrored back (phi, alpha, beta, p -> -phi, -alpha, -beta, -p)")


def _negated(profile: Optional[Profile]) -> Optional[Profile]:
    if profile is None:
        return None
    if profile.kind == "constant":
        return replace(profile, value=-float(profile.value))
    if profile.kind in ("table", "legendre"):
        return replace(profile, values=tuple(-float(v) for v in profile.values))
    if profile.kind == "expression":
        return replace(profile, expression=f"-({profile.expression})")
    return None


def mirror_scene(scene: Scene) -> Optional[Scene]:
    """The reflection of ``scene`` in the rod's axis, or None when the scene has no exact mirror
    the tool can build (a non-uniform field, a term whose parameters declare no mirror, a profile
    that cannot be negated); obstacles are reflected too. Each value is multiplied by its
    parameter's ``mirror`` factor (the lens, one parameter a slot; a profile α(s), β(s) negated)."""
    if not (scene.field is None or isinstance(scene.field, UniformField)):
        return None
    out, slots = scene, set()
    for p in lens.parameters().values():
        if p.slot in slots:
            continue
        slots.add(p.slot)
        if p.per_point and p.profile is not None:  # a profile, negated even where its term is absent
            profile = p.profile(scene)
            if profile is None or p.mirror == 1.0:
                continue
            negated = _negated(profile) if p.mirror == -1.0 else None
            if negated is None:
                return None
            out = p.with_profile(out, negated)
        elif p.term is None or term_class(p.term).present(scene):
            if p.mirror is None:
                return None
            if p.mirror != 1.0:
                out = p.write(out, p.mirror * p.get(scene))
    return replace(out, obstacles=tuple(ob.mirrored() for ob in scene.obstacles))


def mirrored_problem(problem: DesignProblem) -> Optional[DesignProblem]:
    """The mirror problem to search instead of ``problem`` (its target below the axis, y < 0), or
    None when the target is on or above the axis or the scene has no mirror."""
    t = problem.target
    if not t or not t[1] < 0.0:
        return None
    base = mirror_scene(problem.base)
    if base is None:
        return None
    target = (t[0], -t[1]) + ((normalise_tip_angle(-t[2]),) if len(t) > 2 else ())
    return replace(problem, base=base, target=target)


def _mirror_point(pt: DesignPoint) -> DesignPoint:
    out = replace(pt, phi=-pt.phi, p=-pt.p, z=-np.asarray(pt.z, float),
                  tip=np.array([pt.tip[0], -pt.tip[1], -pt.tip[2]]),
                  profiles={k: -np.asarray(c, float) for k, c in pt.profiles.items()})
    for name in ("certified", "stiffness"):  # attributes some stages attach
        if hasattr(pt, name):
            setattr(out, name, getattr(pt, name))
    return out


def _mirror_optimum(d: Dict[str, object], period: float) -> Dict[str, object]:
    out = dict(d)
    out["phi"] = normalise_phi(-float(d["phi"]), period)
    out["p"] = -float(d["p"])
    for key, coefficients in d.items():  # every profile's Legendre coefficients (α, β) change sign
        if key.endswith("_coefficients"):
            out[key] = [-float(c) for c in coefficients]
    tip = d["tip"]
    out["tip"] = {"x": tip["x"], "y": -tip["y"], "angle": -tip["angle"]}
    return out


def mirror_choice(choice: Choice, period: float) -> Choice:
    """The design of the mirror problem, reflected back onto the user's problem."""
    cand = choice.candidate
    base = mirror_scene(cand.base)
    point = _mirror_point(choice.point)
    new_cand = Candidate(vary=cand.vary, base=base, nlp=cand.nlp)
    return Choice(point=point, candidate=new_cand, scene=cand.nlp.scene_for(base, design_vector(cand.nlp, point)),
                  reachable=choice.reachable, notes=[MIRROR_NOTE] + list(choice.notes),
                  alternatives=dict(choice.alternatives),
                  optima=[_mirror_optimum(o, period) for o in choice.optima])


def robust_by_mirror(problem: DesignProblem, mirror: DesignProblem, choice: Choice, follow=None):
    """The robust stage run on the mirror problem (whose box corners are the user's, reflected), its
    design reflected back, and the robustness report made again on the user's own problem by
    branch following (:func:`~actuator_design.robust.robustness.evaluate_robustness`): the report's corners and fold
    directions are the user's, and a design that held only in the mirror would say so.

    ``follow`` (the verification, a function of the user's design) is started as
    :func:`~actuator_design.robust.design_robust_stage.robust_stage` starts it, on the reflected design.

    Returns
    -------
    (Choice, RobustReport or None, Forked or None)
    """
    period = phi_period(problem.base)
    reflected = (lambda ch: follow(mirror_choice(ch, period))) if follow is not None else None
    moved, report, ahead = robust_stage(mirror, choice, reflected)
    out = mirror_choice(moved, period)
    if report is None:
        return out, None, ahead
    tol, options = problem.settings.tolerances, problem.options
    try:
        rob = evaluate_robustness(out.scene, out.point.z, problem.target, tol, options)
        nominal = None
        if report.nominal is not None:
            before = mirror_choice(choice, period)
            nominal = evaluate_robustness(before.scene, before.point.z, problem.target, tol, options,
                                          fold_search=False)
    except BaseException:
        if ahead is not None:
            ahead.cancel()
        raise
    largest = report.largest_box if rob.holds or report.largest_box < 1.0 else 0.0
    # the vertical stiffness dp/dv1 is invariant under the reflection (p and v1 both change sign)
    # the designs the verification may fall back on (robust_stage: reachable), reflected too
    fallbacks = [(scale, mirror_choice(ch, period)) for scale, ch in report.fallbacks]
    return out, RobustReport(rob, largest, nominal, list(report.attempts), stiffness=report.stiffness,
                             pose_target=report.pose_target, fallbacks=fallbacks), ahead
