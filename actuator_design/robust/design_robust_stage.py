"""Stage 3b of :func:`~actuator_design.inverse.design.design`, **robustify**, between choose and verify: move the chosen
design to one that holds over the lab's tolerance box (:mod:`actuator_design.robust.design_robust`) and say how it holds
(:mod:`actuator_design.robust.robustness`: the branch followed to the box's corners and edges and to the nearest snap).

A design that reaches the target exactly at the nominal field but sits next to a fold is not a
design: the real coil is a few per cent off. This stage keeps the target exact at the nominal
point and minimises the worst-case tip error over the corners, every corner a stable state; the
claims it reports come from following the branch, not from the NLP.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any, Callable, List, Optional, Tuple

import numpy as np

from actuator_design import forked
from actuator_design.inverse.optimise import design_vector
from actuator_design.inverse.settings import Choice, DesignProblem, tip_error
from actuator_design.robust.design_robust import robustify
from actuator_design.robust.design_stiffness_box import StiffnessOverBox, stiffness_over_box
from actuator_design.robust.robustness import Robustness, evaluate_robustness, fold_search_builds

__all__ = ["RobustReport", "robust_stage"]


@dataclass
class RobustReport:
    """How the chosen design holds over the tolerance box.

    robustness : the final design's :class:`~actuator_design.robust.robustness.Robustness` over the full box.
    largest_box : the fraction of the box the design holds over (1.0: all of it): the fraction it was
        made for, or 1.0 when branch following finds it holds over the whole box.
    nominal : the robustness of the design before this stage (None when it was not evaluated).
    attempts : one line per robust NLP solve.
    stiffness : the stiffness over the box (:mod:`actuator_design.robust.design_stiffness_box`) of a stiffness target.
    pose_target : the design has a tip target (else the tip spread is around the nominal tip).
    """

    robustness: Robustness
    largest_box: float
    nominal: Optional[Robustness] = None
    attempts: List[str] = field(default_factory=list)
    stiffness: Optional[StiffnessOverBox] = None
    pose_target: bool = True
    #: the designs the verification may fall back on when it reaches no robust design, in order:
    #: (box fraction it was made for, Choice), None for the least-effort design (:func:`reachable`)
    fallbacks: List[Tuple[Optional[float], Choice]] = field(default_factory=list, repr=False)
    #: the box fraction of a robust design found but not reached from zero field (0: none)
    unreached: float = 0.0

    @property
    def bounded(self) -> bool:
        """The worst tip error over the box is finite (a state that does not converge on twice the
        elements gives an unbounded discretisation error: the mesh does not resolve it)."""
        return math.isfinite(self.robustness.worst_tip_error)

    @property
    def holds(self) -> bool:
        """Stable over the box, no snap inside it, a bounded tip error and (for a stiffness target)
        the stiffness evaluated at every grid point of the box."""
        return bool(self.robustness.holds and self.bounded
                    and (self.stiffness is None or self.stiffness.complete))

    def to_dict(self) -> dict:
        out = self.robustness.to_dict()
        out["holds"] = self.holds
        if self.stiffness is not None:
            out["stiffness_over_box"] = self.stiffness.to_dict()
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
        tip = (f"worst tip error {r.worst_tip_error:.3g} rod lengths" if self.pose_target else
               f"the tip moves by at most {r.worst_tip_error:.3g} rod lengths")
        if not self.bounded:
            tip = ("the tip error over the box is not bounded: the states do not converge on a mesh with "
                   "twice the elements (the mesh does not resolve them)")
        stiff = "" if self.stiffness is None else f"{self.stiffness.sentence()}; "
        if self.holds:
            return f"holds over the box ({box}): {stiff}{tip}; {r.fold_distance.sentence()}"
        if r.holds:  # stable and snap-free over the box, but the error or stiffness is not bounded
            return f"does NOT hold over the box ({box}): {stiff}{tip}; {r.fold_distance.sentence()}"
        part = (f"the most robust design found holds over {100 * self.largest_box:.3g} % of the box "
                f"({r.tolerances.scaled(self.largest_box).describe()})" if self.largest_box > 0
                else f"no design reached from zero field without a snap holds over any part of it (one made "
                     f"for {100 * self.unreached:.3g} % of it was found)" if self.unreached > 0
                else "no design found holds over any part of it")
        why = f" ({r.failures[0]})" if r.failures else ""
        return f"does NOT hold over the box ({box}){why}: {part}; {r.fold_distance.sentence()}"


def _holds(rob: Robustness) -> bool:
    """Holds by branch following, with a bounded tip error (see :attr:`RobustReport.holds`)."""
    return bool(rob.holds and math.isfinite(rob.worst_tip_error))


def robust_stage(problem: DesignProblem, choice: Choice,
                 follow: Optional[Callable[[Choice], object]] = None) -> Tuple[Choice, Optional[RobustReport], Any]:
    """Make the chosen design hold over ``problem.settings.tolerances`` and report how it holds.

    Skipped (returns ``(choice, None, None)``) when the box is empty or the target is not
    reachable. A design with a stiffness target is not moved: its branch is followed over the box
    and its stiffness taken there (:func:`~actuator_design.robust.design_stiffness_box.stiffness_over_box`).

    Parameters
    ----------
    follow : callable, optional
        The stage after this one (the verification, a function of the design): started beside
        the branch following of the moved design (:mod:`actuator_design.forked`) as soon as it is proposed.

    Returns
    -------
    (Choice, RobustReport or None, Forked or None)
        The (possibly moved) design and its report, whose notes say what happened, and ``follow``
        of that design when it was started (None: call ``follow`` on it).
    """
    tol = problem.settings.tolerances
    if not tol.active or not choice.reachable or not (problem.target or problem.stiffness is not None):
        return choice, None, None
    cand, pt, target, s = choice.candidate, choice.point, problem.target, problem.settings
    nlp, options = cand.nlp, problem.options
    if problem.stiffness is not None:
        # the robust NLP pins the pose only: a design that must also meet a stiffness is evaluated
        # over the box as it is, not moved: the branch over the box, and the stiffness on it
        rob = evaluate_robustness(choice.scene, pt.z, target or None, tol, options)
        box = stiffness_over_box(choice.scene, pt.z, tol, options, problem.stiffness)
        report = RobustReport(rob, 0.0, None, ["stiffness target: evaluated, not moved"], stiffness=box,
                              pose_target=bool(target))
        report.largest_box = 1.0 if report.holds else 0.0
        if not report.holds:
            choice.notes.append(report.sentence())
        return choice, report, None
    # the robust design is sought beside (forked) while this process says how the nominal design
    # holds and then builds what the fold search of the design's branch will need: the verification
    # forked later inherits those builds, and this process follows the branch without building
    beside = forked.start(partial(_robust_design, nlp, cand.base, design_vector(nlp, pt), pt.z, target, tol,
                                  s.margin, s.bounds()),
                          while_waiting=fold_search_builds(choice.scene, options))
    try:
        nominal = evaluate_robustness(choice.scene, pt.z, target, tol, options, fold_search=False)
        out, d = beside.result()
    finally:
        beside.cancel()  # (nothing left to end once its result is in)
    best_choice, best_rob, largest, ahead = _moved(problem, choice, out, d, nominal, follow)
    try:
        best_choice, report = _report(problem, choice, best_choice, best_rob, largest, nominal, out.attempts)
        if best_choice is not choice:  # what the verification may fall back on (:func:`reachable`)
            rungs = [(scale, _moved_choice(problem, choice, dr, zr, "robust"))
                     for scale, dr, zr in sorted(out.ladder, key=lambda rung: -rung[0]) if scale < largest]
            rungs = [(scale, rung) for scale, rung in rungs if rung is not None]
            least = [(None, choice)]
            report.fallbacks = least + rungs if _holds(nominal) else rungs + least
        return best_choice, report, ahead
    except BaseException:
        if ahead is not None:
            ahead.cancel()
        raise


def _report(problem, choice, best_choice, best_rob, largest, nominal, attempts, unreached: float = 0.0):
    """The report of the robust stage's outcome: ``(choice, RobustReport)`` (``unreached``: the box
    fraction of a robust design found but not reached from zero field)."""
    tol, options, target, pt = problem.settings.tolerances, problem.options, problem.target, choice.point
    nlp = choice.candidate.nlp
    if best_rob is None:  # keep the nominal design; report how it holds (with its nearest snap)
        best_rob = evaluate_robustness(choice.scene, pt.z, target, tol, options)
        largest = 1.0 if _holds(best_rob) else 0.0
    if not _holds(best_rob) and largest > 0:
        # the largest box claimed must itself hold by branch following
        sc, zz = best_choice.scene, best_choice.point.z
        if not _holds(evaluate_robustness(sc, zz, target, tol.scaled(largest), options, fold_search=False)):
            largest = 0.0
    report = RobustReport(best_rob, largest, nominal, attempts, unreached=unreached)
    if not report.holds:
        best_choice.notes.append(report.sentence())
    elif best_choice is not choice and np.max(np.abs(design_vector(nlp, best_choice.point)
                                                     - design_vector(nlp, pt)), initial=0.0) > 1e-9:
        # (a determined design, e.g. as many design values as pinned tip values, cannot move)
        best_choice.notes.append(f"moved off the least-effort design to one that holds over the tolerance "
                                 f"box ({tol.describe()}; see robustness)")
    return best_choice, report


def _robust_design(nlp, base, d0: np.ndarray, z0: np.ndarray, target, tol, margin: float, bounds):
    """:func:`~actuator_design.robust.design_robust.robustify` of one pose, and its design vector (None without a
    point), shape (nlp.nd,): ``(RobustOutcome without its NLP, d)``, which pickles (a forked task)."""
    out = robustify(nlp, base, [d0], [z0], [target], tol, margin=margin, bounds=bounds)
    d = out.nlp.pose_vector(out.point.d, 0) if out.point is not None else None
    ladder = [(scale, out.nlp.pose_vector(pt.d, 0), pt.z[0][0]) for scale, pt in out.ladder]
    return replace(out, nlp=None, ladder=ladder), d


def _moved(problem: DesignProblem, choice: Choice, out, d, nominal: Robustness, follow):
    """The robust NLP's design (``out``, design vector ``d``) when it reaches the target and holds
    over the box by branch following (or the nominal design does not hold either), with ``follow``
    of it started beside that check: ``(choice, robustness, largest box, Forked)``, or
    ``(choice, None, 0, None)`` when the nominal design is kept."""
    if out.point is None:
        return choice, None, 0.0, None
    target, tol, options = problem.target, problem.settings.tolerances, problem.options
    z = out.point.z[0][0]
    moved_choice = _moved_choice(problem, choice, d, z, out.point.status)
    if moved_choice is None:
        return choice, None, 0.0, None
    scene = moved_choice.scene
    ahead = forked.start(partial(follow, moved_choice)) if follow is not None else None
    try:
        rob = evaluate_robustness(scene, z, target, tol, options)
    except BaseException:
        if ahead is not None:
            ahead.cancel()
        raise
    if _holds(rob) or not _holds(nominal):
        return moved_choice, rob, out.scale, ahead
    if ahead is not None:
        ahead.cancel()
    return choice, None, 0.0, None


def _moved_choice(problem: DesignProblem, choice: Choice, d: np.ndarray, z: np.ndarray, status: str):
    """The choice of a design vector ``d`` (shape (nlp.nd,)) with its state ``z`` (θ at the nodes),
    values not designed as ``choice``'s; None when its tip misses the target by more than reach_tol."""
    cand, pt = choice.candidate, choice.point
    nlp = cand.nlp
    scene = nlp.scene_for(cand.base, d)
    sv = nlp.solver
    _, th, x, y = sv.summary(z, sv.parameter_vector(scene))
    moved = replace(nlp.point(d, cand.base, z, np.array([x, y, th]), converged=True, status=status, stage="robust"),
                    h=pt.h if "h" not in nlp.vary else float(d[nlp.dmap["h"]][0]),
                    phi=pt.phi if "phi" not in nlp.vary else float(d[nlp.dmap["phi"]][0]),
                    p=pt.p if "p" not in nlp.vary else float(d[nlp.dmap["p"]][0]))
    if tip_error(moved.tip, problem.target) > problem.settings.reach_tol:
        return None
    return replace(choice, point=moved, scene=scene, notes=list(choice.notes))


#: What a fallback's verification may raise on a numerical failure: that design is then not reached.
_NUMERICAL_ERRORS = (ValueError, ArithmeticError, RuntimeError, np.linalg.LinAlgError)


def reachable(problem: DesignProblem, choice: Choice, report: RobustReport, verification, follow):
    """A design the user can reach, when the verification reached no robust design ``choice``
    (``verification.path`` None): the first of ``report.fallbacks`` that ``follow`` (the
    verification) reaches from zero field without a snap — the least-effort design first when it
    holds over the box, then the designs the box homotopy made for smaller boxes, largest first
    (each judged over the whole box by branch following), then the least-effort design. A robust
    design no schedule reaches holds over the box only on a branch the field, ramped from zero, does
    not lead to: it is no design to build. When none is reached, ``choice`` stays.

    Returns
    -------
    (Choice, RobustReport, Verification)
    """
    tol, options, target = problem.settings.tolerances, problem.options, problem.target
    least = next(ch for scale, ch in report.fallbacks if scale is None)
    unreachable = (f"the design made for {100 * report.largest_box:.3g} % of the tolerance box could not be "
                   "reached from zero field without a snap")
    for scale, cand in report.fallbacks:
        cand = replace(cand, notes=list(cand.notes))
        try:
            v = follow(cand)
        except _NUMERICAL_ERRORS:
            continue
        if v.path is None:
            continue
        if scale is None:
            cand.notes.append(f"{unreachable}; the least-effort design, reached without one, is kept")
            rob, largest = None, 0.0
        else:
            rob = evaluate_robustness(cand.scene, cand.point.z, target, tol, options)
            whole = _holds(rob)  # (by branch following it may hold over more than it was made for)
            cand.notes.append(f"{unreachable}; this one, made for {100 * scale:.3g} % of it, is reached without one"
                              + (" and holds over the whole box" if whole else ""))
            largest = 1.0 if whole else scale
        chosen, new = _report(problem, least, cand, rob, largest, report.nominal, report.attempts, report.largest_box)
        return chosen, new, v
    choice.notes.append(f"{unreachable}, nor could one made for a smaller box, nor the least-effort design")
    return choice, report, verification
