"""Stage 3b of :func:`~.design.design`, **robustify**, between choose and verify: move the chosen
design to one that holds over the lab's tolerance box (:mod:`.design_robust`) and say how it holds
(:mod:`.robustness`: the branch followed to the box's corners and edges and to the nearest snap).

A design that reaches the target exactly at the nominal field but sits next to a fold is not a
design: the real coil is a few per cent off. This stage keeps the target exact at the nominal
point and minimises the worst-case tip error over the corners, every corner a stable state; the
claims it reports come from following the branch, not from the NLP.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import List, Optional, Tuple

import numpy as np

from .design_nlp import DesignPoint
from .design_optimise import design_vector
from .design_robust import robustify
from .design_types import Choice, DesignProblem, tip_error
from .robustness import Robustness, evaluate_robustness

__all__ = ["RobustReport", "robust_stage"]


@dataclass
class RobustReport:
    """How the chosen design holds over the tolerance box.

    robustness : the final design's :class:`~.robustness.Robustness` over the full box.
    largest_box : the fraction of the box the design was made to hold (1.0: all of it).
    nominal : the robustness of the design before this stage (None when it was not evaluated).
    attempts : one line per robust NLP solve.
    """

    robustness: Robustness
    largest_box: float
    nominal: Optional[Robustness] = None
    attempts: List[str] = field(default_factory=list)

    @property
    def holds(self) -> bool:
        return self.robustness.holds

    def to_dict(self) -> dict:
        out = self.robustness.to_dict()
        out["largest_box_fraction"] = float(self.largest_box)
        out["largest_box"] = self.robustness.tolerances.scaled(self.largest_box).to_dict()
        if self.nominal is not None:
            out["before_robust_design"] = {"worst_tip_error": self.nominal.worst_tip_error,
                                           "stable_over_box": self.nominal.stable_over_box,
                                           "holds": self.nominal.holds}
        return out

    def sentence(self) -> str:
        r = self.robustness
        box = r.tolerances.describe()
        if r.holds:
            return (f"holds over the box ({box}): worst tip error {r.worst_tip_error:.3g} rod lengths; "
                    f"{r.fold_distance.sentence()}")
        part = (f"the most robust design found holds over {100 * self.largest_box:.3g} % of the box "
                f"({r.tolerances.scaled(self.largest_box).describe()})" if self.largest_box > 0
                else "no design found holds over any part of it")
        why = f" ({r.failures[0]})" if r.failures else ""
        return f"does NOT hold over the box ({box}){why}: {part}; {r.fold_distance.sentence()}"


def robust_stage(problem: DesignProblem, choice: Choice) -> Tuple[Choice, Optional[RobustReport]]:
    """Make the chosen design hold over ``problem.settings.tolerances`` and report how it holds.

    Skipped (returns ``(choice, None)``) when the box is empty, the target is not reachable or the
    design has no pose target (a stiffness alone).

    Returns
    -------
    (Choice, RobustReport or None)
        The (possibly moved) design and its report; its notes say what happened.
    """
    tol = problem.settings.tolerances
    if not tol.active or not choice.reachable or not problem.target:
        return choice, None
    cand, pt, target, s = choice.candidate, choice.point, problem.target, problem.settings
    nlp, options = cand.nlp, problem.options
    if problem.stiffness is not None:
        # the robust NLP pins the pose only: a design that must also meet a stiffness is evaluated
        # over the box as it is, not moved
        rob = evaluate_robustness(choice.scene, pt.z, target, tol, options)
        report = RobustReport(rob, 1.0 if rob.holds else 0.0, None, ["stiffness target: evaluated, not moved"])
        if not report.holds:
            choice.notes.append(report.sentence())
        return choice, report
    nominal = evaluate_robustness(choice.scene, pt.z, target, tol, options, fold_search=False)
    out = robustify(nlp, cand.base, [design_vector(nlp, pt)], [pt.z], [target], tol, margin=s.margin,
                    bounds=s.bounds())
    best_choice, best_rob, largest = choice, None, 0.0
    if out.point is not None:
        d = out.nlp.pose_vector(out.point.d, 0)
        z = out.point.z[0][0]
        scene = nlp.scene_for(cand.base, d)
        sv = nlp.solver
        _, th, x, y = sv.summary(z, sv.parameter_vector(scene))
        moved = DesignPoint(h=float(d[nlp.dslices["h"]][0]) if "h" in nlp.vary else pt.h,
                            phi=float(d[nlp.dslices["phi"]][0]) if "phi" in nlp.vary else pt.phi,
                            coefficients=(np.asarray(d[nlp.dslices["alpha"]]) if "alpha" in nlp.vary
                                          else pt.coefficients),
                            p=float(d[nlp.dslices["p"]][0]) if "p" in nlp.vary else pt.p,
                            z=z, tip=np.array([x, y, th]), converged=True, status=out.point.status,
                            stage="robust",
                            magnetization=(np.asarray(d[nlp.dslices["magnetization"]])
                                           if "magnetization" in nlp.vary else pt.magnetization))
        if tip_error(moved.tip, target) <= s.reach_tol:
            rob = evaluate_robustness(scene, z, target, tol, options)
            if rob.holds or not nominal.holds:
                best_choice = replace(choice, point=moved, scene=scene, notes=list(choice.notes))
                best_rob, largest = rob, out.scale
    if best_rob is None:  # keep the nominal design; report how it holds (with its nearest snap)
        best_rob = evaluate_robustness(choice.scene, pt.z, target, tol, options)
        largest = 1.0 if best_rob.holds else 0.0
    if not best_rob.holds and largest > 0:
        # the largest box claimed must itself hold by branch following
        sc, zz = best_choice.scene, best_choice.point.z
        if not evaluate_robustness(sc, zz, target, tol.scaled(largest), options, fold_search=False).holds:
            largest = 0.0
    report = RobustReport(best_rob, largest, nominal, out.attempts)
    if not report.holds:
        best_choice.notes.append(report.sentence())
    elif best_choice is not choice and np.max(np.abs(design_vector(nlp, best_choice.point)
                                                     - design_vector(nlp, pt)), initial=0.0) > 1e-9:
        # (a determined design, e.g. as many design values as pinned tip values, cannot move)
        best_choice.notes.append(f"moved off the least-effort design to one that holds over the tolerance "
                                 f"box ({tol.describe()}; see robustness)")
    return best_choice, report
