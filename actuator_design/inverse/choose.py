"""Stage 3 of :func:`~actuator_design.inverse.design.design`, **choose**: the best optimum over the variable sets tried
(reaching the target first, then least effort), made a stable state when the target is not
reachable, with the notes that explain the choice (variables added, why a target is missed)."""
from __future__ import annotations

import math
from typing import Dict, List, Optional

from actuator_design.config.limits import GROUP_RANGES
from actuator_design.inverse.nlp import PROFILE_VARIABLES, DesignPoint, DesignRequest
from actuator_design.inverse.optimise import candidate, design_vector, optimise
from actuator_design.inverse.screen import screen
from actuator_design.inverse.settings import (Choice, DesignProblem, Optimised, normalise_phi, phi_period,
                                              target_error, tip_error)
from actuator_design.physics import parameters as lens

__all__ = ["choose", "optimum_dict"]


def choose(problem: DesignProblem, searched: List[Optimised], hints: bool = True) -> Optional[Choice]:
    """Pick the design to verify.

    Parameters
    ----------
    problem : DesignProblem
    searched : list of Optimised
        One per variable set tried, in the order tried.
    hints : bool
        For an unreachable target with the fibre layout fixed, search with the layout too to say
        whether varying it would reach the target (``alternatives``; a whole search: off where
        only the design point is used, e.g. a multi-pose design's other poses).

    Returns
    -------
    Choice or None
        None when no variable set produced any optimum (nothing stable was found).
    """
    best, best_opt = None, None
    for opt in searched:
        if opt.optima and (best is None or problem.rank(opt.optima[0]) < problem.rank(best)):
            best, best_opt = opt.optima[0], opt
    if best is None:
        return None
    cand, target, stiffness = best_opt.candidate, problem.target, problem.stiffness
    notes: List[str] = []
    reachable = problem.rank(best)[0] == 0
    if reachable and not problem.user_vary and cand.vary != problem.variable_sets[0]:
        extra = [v for v in cand.vary if v not in problem.variable_sets[0]]
        remanent = [v for v in extra if v in lens.remanent_profiles(problem.base)]
        added = (f"the {remanent[0]} profile {lens.parameter(remanent[0]).slot}(s): a remanent rod"
                 if remanent
                 else "the fibre layout: the scene leaves it free" if "alpha" in extra
                 else "the field angle too")
        first = {("h", "phi"): "field magnitude and angle", ("phi",): "the field angle",
                 ("h",): "the field magnitude"}.get(tuple(problem.variable_sets[0]),
                                                    ", ".join(problem.variable_sets[0]))
        notes.append(f"{first} alone cannot reach the target; "
                     f"used {', '.join(cand.vary)} ({added})")
    if problem.fibres_fixed and not problem.user_vary and "alpha" not in cand.vary:
        notes.append("the scene's fibre layout is kept as given (add alpha to --vary to design it)")
    if not problem.base.fibres_physical and not problem.user_vary:
        notes.append("no fibre layout designed: it has no effect on this actuator (isotropic particles, "
                     "THEORY §10)")
    if any(opt.out_of_time for opt in searched):
        notes.append(f"time limit of {problem.settings.time_limit:g} s reached: not every starting design "
                     "was optimised")
    if not reachable and not getattr(best, "certified", True):
        # the nearest pose reported for an unreachable target must itself be a stable state
        z0, d0 = best.start
        s = problem.settings
        stable = cand.nlp.solve(cand.base, z0, d0, DesignRequest(target=target, stage="A", margin=s.margin,
                                                                 bounds=s.bounds(), stiffness=None))
        if stable.converged:
            if stiffness is not None:
                stable.stiffness = cand.nlp.stiffness(cand.base, stable)
            best = stable
        else:  # e.g. the certificate was refused (CertificateTooLarge): say what is reported
            notes.append(f"no stable nearest design was found ({stable.status}); the design reported is "
                         "NOT stable")
    alternatives: Dict[str, bool] = {}
    if not reachable:
        what = "target" if stiffness is None else ("stiffness" if not target else "target pose and stiffness")
        nearest = "nearest stable design" if getattr(best, "certified", True) else "nearest design"
        notes.append(f"the {what} is not reachable with {', '.join(cand.vary)}: the {nearest} "
                     f"misses by {target_error(best, target, stiffness):.3g}"
                     + (" rod lengths" if stiffness is None else "") + " (reported as 'achieved')")
        h_max = problem.settings.h_max
        if "h" in cand.vary and best.h >= h_max * (1.0 - 1e-4):  # (an interior point stops short of it)
            notes.append(f"the nearest design sits at the field bound h = {h_max:g} (--h-max"
                         + (f"; h <= {GROUP_RANGES['h'].hi:g} is the valid range" if h_max >= GROUP_RANGES["h"].hi
                            else "") + "): in a strong field the tip nears the field's axis like 1/h")
        if target and math.hypot(target[0], target[1]) > 1.0:
            notes.append("the target lies beyond the rod's length from the clamp (|r| > 1)")
        elif (hints and (problem.user_vary or problem.fibres_fixed) and problem.base.fibres_physical
              and "alpha" not in cand.vary and target and stiffness is None):
            alternatives = _try_alternative(problem, cand.vary)
            if alternatives.get("with_fibre_layout"):
                notes.append(f"adding the fibre layout would reach it: --vary {','.join(cand.vary)},alpha")
    optima = [optimum_dict(opt.candidate.vary, pt, target, phi_period(opt.candidate.base))
              for opt in searched for pt in opt.optima]
    return Choice(point=best, candidate=cand, scene=cand.nlp.scene_for(cand.base, design_vector(cand.nlp, best)),
                  reachable=reachable, notes=notes, alternatives=alternatives, optima=optima)


def _try_alternative(problem: DesignProblem, vary) -> Dict[str, bool]:
    """Would adding the fibre layout reach an unreachable target? (No verification: a hint.)"""
    cand = candidate(problem, tuple(vary) + ("alpha",))
    opt = optimise(problem, cand, screen(problem, cand, keep=2))
    return {"with_fibre_layout": opt.reaches(problem)}


def optimum_dict(vary, pt: DesignPoint, target, period: float = math.pi) -> Dict[str, object]:
    """One entry of the ``optima`` list of the JSON contract (φ reported in (−period/2, period/2];
    ``magnetization_coefficients`` only when the magnetisation profile is designed)."""
    out = {"vary": list(vary), "h": pt.h, "phi": normalise_phi(pt.phi, period), "p": pt.p,
           # α's always (empty when not designed), every other profile's when it is designed
           **{f"{v}_coefficients": [float(c) for c in pt.profile(v)] for v in PROFILE_VARIABLES
              if v == "alpha" or v in vary},
           "tip": {"x": float(pt.tip[0]), "y": float(pt.tip[1]), "angle": float(pt.tip[2])},
           "error": tip_error(pt.tip, target) if target else 0.0, "stage": pt.stage}
    if getattr(pt, "stiffness", None) is not None:
        out["stiffness"] = pt.stiffness
    return out
