"""Stage 2 of :func:`~actuator_design.inverse.design.design`, **optimise**: from each screened start, the design NLP
(:mod:`actuator_design.inverse.nlp`) finds the nearest reachable pose (stage A), then the least-effort design that
reaches the target exactly (stage B); distinct local optima are kept, best first."""
from __future__ import annotations

import time
from dataclasses import replace
from functools import partial
from typing import List

import numpy as np

from actuator_design import forked
from actuator_design.inverse.design_map import prepare_scene
from actuator_design.inverse.nlp import STRONG_FIELD, DesignNLP, DesignPoint, DesignRequest, get_design_nlp
from actuator_design.inverse.screen import screen
from actuator_design.inverse.settings import (Candidate, DesignProblem, Optimised, ScreenedStart,
                                              normalise_phi, phi_period, tip_error)
from actuator_design.robust.design_robust import get_scenario_nlp

__all__ = ["candidate", "optimise", "search_set", "warm_robust_nlp", "design_vector", "STRONG_REACH_PROBE"]

#: In a strong field (h > STRONG_FIELD) stage A's least squares is ill-conditioned in h: the tip
#: moves like 1/h (the clamp layer, THEORY §5), so ∂f/∂h ~ miss/h² falls below IPOPT's acceptable
#: tolerance while the tip still misses (target of h = 100, φ = 20°: stage A stopped at h = 35 and
#: 80, 4e-4 and 5e-5 short). Stage B, whose pinned tip is solved by Newton steps on the constraint
#: (invariant to that scaling), is then tried from stage A's point when it misses by at most this.
STRONG_REACH_PROBE = 1e-2


def candidate(problem: DesignProblem, vary) -> Candidate:
    """The base scene prepared for the variables ``vary`` and its (cached) design NLP."""
    base = prepare_scene(problem.base, vary)
    return Candidate(tuple(vary), base, get_design_nlp(base, vary, problem.options, problem.settings.alpha_terms,
                                                       clearance=problem.settings.clearance))


def optimise(problem: DesignProblem, cand: Candidate, starts: List[ScreenedStart]) -> Optimised:
    """Multi-start: stage A (nearest pose) then stage B (least effort, pose and stiffness pinned);
    with a stiffness target and no pose, stage B alone.

    Parameters
    ----------
    problem : DesignProblem
    cand : Candidate
    starts : list of ScreenedStart
        From :func:`~actuator_design.inverse.screen.screen`, nearest first.

    Returns
    -------
    Optimised
        Distinct optima sorted by :meth:`DesignProblem.rank`; ``out_of_time`` when the time limit
        stopped the loop before every start was optimised (at least one always is).
    """
    # the second half of the starts is optimised beside the first (:mod:`actuator_design.forked`); the optima
    # are then those of the starts in order, as one process would find them
    half = (len(starts) + 1) // 2
    beside = forked.start(partial(_from_starts, problem, cand, starts[half:], half)) if half < len(starts) else None
    try:
        optima, out_of_time = _from_starts(problem, cand, starts[:half], 0)
        if beside is not None and not out_of_time:
            rest, out_of_time = beside.result()
            optima += rest
        elif beside is not None:
            out_of_time = True  # (the first half already ran out of time: the second is not waited for)
    finally:
        if beside is not None:
            beside.cancel()
    return Optimised(cand, sorted(_distinct(cand.nlp, cand.base, optima), key=problem.rank), out_of_time)


def _from_starts(problem: DesignProblem, cand: Candidate, starts: List[ScreenedStart], first: int):
    """The optima from ``starts`` (the multi-start's starts ``first``, ``first`` + 1, …) in order,
    and whether the time limit stopped the loop (never before the multi-start's first start)."""
    nlp, base, target, settings, stiffness = cand.nlp, cand.base, problem.target, problem.settings, problem.stiffness
    reach_probe = 10 * settings.reach_tol + 1e-7
    optima: List[DesignPoint] = []
    req_a = DesignRequest(target=target or None, stage="A", margin=settings.margin, bounds=settings.bounds())
    req_b = replace(req_a, stage="B", stiffness=stiffness)
    for k, start in enumerate(starts, start=first):
        if k > 0 and time.perf_counter() > problem.deadline:
            return optima, True
        d0, z0 = start.d, start.z
        best, strong = None, False
        if target:
            a = nlp.solve(base, z0, d0, req_a, certify=False)  # a probe: certified only if it reaches
            if not a.converged:
                continue
            if not getattr(a, "certified", True) and tip_error(a.tip, target) <= reach_probe:
                # reached only by an unstable state: ask for the nearest stable one, certified
                a = nlp._solve(base, z0, d0, req_a, certified=True)
                if not a.converged:  # not an optimum: its point is where the iteration cap hit
                    continue
            best, z0, d0 = a, a.z, design_vector(nlp, a)
            miss = tip_error(a.tip, target)
            strong = miss > reach_probe and a.h > STRONG_FIELD and miss <= STRONG_REACH_PROBE
            if miss > reach_probe and not strong:
                if stiffness is not None:
                    a.stiffness = nlp.stiffness(base, a)
                optima.append(a)
                continue
        if target and strong:  # a probe: the certified NLP only when the probe reaches unstably
            b = nlp.solve(base, z0, d0, req_b, certify=False)
            if b.converged and not getattr(b, "certified", True):
                b = nlp._solve(base, z0, d0, req_b, certified=True)
        else:
            b = nlp.solve(base, z0, d0, req_b)
        if b.converged and (not target or tip_error(b.tip, target) <= settings.reach_tol):
            best = b
        if best is not None:
            if stiffness is not None:
                best.stiffness = nlp.stiffness(base, best)
            optima.append(best)
    return optima, False


def search_set(problem: DesignProblem, vset) -> tuple:
    """Screen and optimise one variable set: its optima (best first), whether the time limit cut
    the optimisation short, and the timings ``build_<set>``, ``optimise_<set>`` (s). Picklable, so
    that it can run in a forked process (:func:`~actuator_design.inverse.design.search`)."""
    name = "+".join(vset)
    tb = time.perf_counter()
    cand = candidate(problem, vset)
    times = {f"build_{name}": time.perf_counter() - tb}
    to = time.perf_counter()
    opt = optimise(problem, cand, screen(problem, cand))
    times[f"optimise_{name}"] = time.perf_counter() - to
    return opt.optima, opt.out_of_time, times


def warm_robust_nlp(problem: DesignProblem, vset) -> None:
    """Build the robust stage's NLP of the variable set ``vset`` (:mod:`actuator_design.robust.design_robust`), e.g. while
    that set's search runs beside (:func:`~actuator_design.inverse.design.search`): the earlier sets did not reach the
    target, so its design is the one likely to be made robust."""
    tol = problem.settings.tolerances
    if problem.target and tol.active:
        get_scenario_nlp(candidate(problem, vset).nlp, 1, len(tol.corners())).nlpsol(False)


def design_vector(nlp: DesignNLP, pt: DesignPoint) -> np.ndarray:
    """The design vector, shape (nlp.nd,), of a design point."""
    return nlp.point_vector(pt)


def _distinct(nlp: DesignNLP, base, optima: List[DesignPoint]) -> List[DesignPoint]:
    """Drop repeats: same shape and same design, with φ compared modulo the energy's period (π, or
    2π with a hard-magnetic term)."""
    def key(pt):
        phi = normalise_phi(pt.phi, period)  # φ compared modulo the energy's period
        return nlp.point_vector(pt, phi=phi)

    period = phi_period(base)
    out: List[DesignPoint] = []
    for pt in optima:
        if all(np.max(np.abs(key(pt) - key(q))) > 1e-4 or np.max(np.abs(pt.z - q.z)) > 1e-4 for q in out):
            out.append(pt)
    return out
