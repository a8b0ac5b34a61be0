"""Stage 1 of :func:`~actuator_design.inverse.design.design`, **screen**: a grid of starting designs, each forward-solved
(a stable state by construction), ranked by distance to the target; the nearest distinct ones are
the starts of the optimisation stage."""
from __future__ import annotations

import math
from dataclasses import replace
from typing import List

import numpy as np

from actuator_design.equilibrium.pipeline import solve
from actuator_design.inverse.nlp import PROFILE_VARIABLES, DesignNLP, profile_bound
from actuator_design.inverse.settings import (Candidate, DesignProblem, DesignSettings, ScreenedStart,
                                              phi_period)
from actuator_design.model.scene import Scene

__all__ = ["screen", "start_grid", "unpack", "STRONG_FIELDS"]

#: Field groups screened beyond the weak-field grid when h_max allows them (h_max > 10; the
#: default h_max = 10 screens the weak grid only). Past h ~ 10 the rod is a clamp layer of width
#: ~1/h and a straight part along the field (THEORY §5): its tip moves like 1/h, so a start within a
#: factor ~2.5 in h is near any strong-field pose (a target at h = 300 was called unreachable when
#: the screen stopped at h = 5.5).
STRONG_FIELDS = (12.0, 30.0, 80.0, 200.0, 500.0, 1300.0, 3500.0, 1e4)


def screen(problem: DesignProblem, candidate: Candidate, keep: int = 4) -> List[ScreenedStart]:
    """Forward-solve each design of :func:`start_grid`; keep the ``keep`` nearest stable ones.

    Parameters
    ----------
    problem : DesignProblem
    candidate : Candidate
        The design variables, their base scene and design NLP.
    keep : int
        Number of starts returned; starts whose shapes differ by less than 0.05 rad at every node
        from a kept one are skipped.

    Returns
    -------
    list of ScreenedStart
        Nearest first. The distance is the pose distance (units of ℓ, plus the tip angle in rad when
        targeted) plus |ln(k/k_target)| when a stiffness is asked for.
    """
    nlp, base, target, stiffness = candidate.nlp, candidate.base, problem.target, problem.stiffness
    # starts are free equilibria (the rod without its obstacles): the design NLP's clearance rows
    # move them clear of the obstacles, and no start costs a contact solve
    base = replace(base, obstacles=())
    scored: List[ScreenedStart] = []
    prev = None
    seeded = [(nlp.point_vector(seed.point), seed) for seed in problem.seeds]
    for d, seed in seeded + [(d, None) for d in start_grid(nlp, base, problem.settings)]:
        if seed is not None:  # a design found on another mesh: its own state, carried over
            r = _seeded_start(seed, nlp, nlp.scene_for(base, d), problem.options)
            if r is None:
                continue
        else:
            r = solve(nlp.scene_for(base, d), problem.options, initial=prev)
            if not (r.success and r.stable):
                r = solve(nlp.scene_for(base, d), problem.options)
            if not (r.success and r.stable):
                continue
            r = _on_design_mesh(r, nlp, nlp.scene_for(base, d), problem.options)
            if r is None:
                continue
            prev = r
        dist = 0.0
        if target:
            dist = math.hypot(r.tip["x"] - target[0], r.tip["y"] - target[1])
            if len(target) > 2:
                dist = math.hypot(dist, r.tip["angle"] - target[2])
        if stiffness is not None:
            pt = nlp.point(d, base, r.z, np.zeros(3), converged=True, status="", stage="screen")
            k = nlp.stiffness(base, pt)
            dist += abs(math.log(k / stiffness)) if (math.isfinite(k) and k > 0) else 1e3
        scored.append(ScreenedStart(dist, d, r.z))
    scored.sort(key=lambda s: s.distance)
    chosen: List[ScreenedStart] = []
    for item in scored:  # keep distinct starting shapes
        if all(np.max(np.abs(item.z - c.z)) > 0.05 for c in chosen):
            chosen.append(item)
        if len(chosen) == keep:
            break
    return chosen


def _on_design_mesh(r, nlp: DesignNLP, scene: Scene, options):
    """The start ``r`` on the design NLP's mesh: a forward solve may refine its mesh (boundary
    layers at strong fields), the design NLP has one; the state is carried over by interpolation
    and re-converged there (None if it is not a stable equilibrium on that mesh)."""
    nodes = nlp.solver.transcription.nodes
    if r.z is not None and r.z.size == nodes.size:
        return r
    again = solve(scene, options, initial=np.interp(nodes, r.s, r.theta), solver=nlp.solver)
    return again if again.success and again.stable else None


def _seeded_start(seed, nlp: DesignNLP, scene: Scene, options):
    """A seed's state (:class:`~actuator_design.inverse.mesh.Seed`) re-converged on the design NLP's mesh (None if
    it is not a stable equilibrium there)."""
    r = solve(scene, options, initial=seed.theta_at(nlp.solver.transcription.nodes), solver=nlp.solver)
    return r if r.success and r.stable else None


def start_grid(nlp: DesignNLP, base: Scene, settings: DesignSettings) -> List[np.ndarray]:
    """Starting design vectors: field magnitudes × angles over one period of φ (× fibre slopes ×
    loads × magnetisation profiles), each of shape (nlp.nd,).

    The period of φ is π for the soft-magnetic energy alone and 2π with a hard-magnetic term (its
    energy −h_r cos(θ + β − φ) is not symmetric under H → −H, THEORY §9); with h_max > 10 the field
    magnitudes of :data:`STRONG_FIELDS` up to h_max (every other one with a fibre layout) are
    added. A designed magnetisation starts from constant angles β = 0, ±90°, 180° and two linear
    profiles β = ±(1 rad)·P_1(2s − 1).
    """
    with_alpha = "alpha" in nlp.vary
    hs = (1.5, 3.0, 5.0) if with_alpha else (0.8, 1.4, 2.2, 3.5, 5.5)
    hs = [h for h in hs if h <= settings.h_max] or [settings.h_max]
    hs += [h for h in (STRONG_FIELDS[1::2] if with_alpha else STRONG_FIELDS) if h <= settings.h_max]
    n_phi = 8 if with_alpha else 12
    period = phi_period(base)
    phis = np.linspace(-period / 2, period / 2, n_phi + 1)[1:] if "phi" in nlp.vary else [base.phi]
    slopes = [0.0]
    if with_alpha:
        slopes = [s for s in (-1.2, -0.6, 0.6, 1.2) if abs(s) <= settings.alpha_max]
    ps = [base.p] if "p" not in nlp.vary else [-2.0, 0.0, 2.0]
    others = [n for n in PROFILE_VARIABLES if n != "alpha" and n in nlp.vary]  # a magnetisation β(s)
    starts = [{}]
    for name in others:
        b_max = settings.profile_max(profile_bound(name))
        betas = [[b, 0.0] for b in (0.0, math.pi / 2, -math.pi / 2, math.pi) if abs(b) <= b_max]
        betas += [[0.0, s] for s in (-1.0, 1.0) if abs(s) <= b_max]
        starts = [{**start, name: beta} for start in starts for beta in betas]
    out = []
    for profiles in starts:
        for slope in slopes:
            for p in ps:
                for h in (hs if "h" in nlp.vary else [base.h]):
                    for phi in phis:
                        c = [base.fibres.value if base.fibres.kind == "constant" else 0.0, slope]
                        out.append(nlp.design_vector(h=h, phi=phi, coefficients=c, p=p, profiles=profiles))
    return out


def unpack(nlp: DesignNLP, d: np.ndarray, base: Scene):
    """(h, φ, p) of a design vector; the base scene's values for variables not designed."""
    get = lambda name, default: float(d[nlp.dmap[name]][0]) if name in nlp.vary else default
    return get("h", base.h), get("phi", base.phi), get("p", base.p)
