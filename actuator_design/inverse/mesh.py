"""Stage 2b of :func:`~actuator_design.inverse.design.design`, **resolve**: the design mesh must resolve the designed state.

The design NLP (:mod:`actuator_design.inverse.nlp`) satisfies the discrete equilibrium equations of one fixed
mesh exactly, so on a mesh too coarse for the state it designs (a clamp layer of width ~1/h in a
strong field, THEORY §5; a degree too low for the curvature) it can return a discrete state that
is no state of the rod: ``--elements 1 --degree 3`` "reaches" (0.3, 0.5) with the field alone at
h = 3.65, a pose the rod reaches only with a fibre layout, and a re-solve of that state on twice
the elements does not converge. So the chosen design is held to the promise of ``solve``
(:mod:`actuator_design.equilibrium.acceptance`): its Euler–Lagrange residual, evaluated on the dense solution
between the nodes, at most ``residual_tol`` × the moment scale. A design that misses it is
searched again on the mesh graded towards the clamp for its own field (``graded_options``, as
``solve`` grades; never with ``--no-adapt``), starting from the design found; what still misses it
is reported as ``status: "inaccurate"`` with the residual, never as a design.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Dict, List, Optional, Tuple

import numpy as np

from actuator_design.equilibrium.acceptance import (graded_options, moment_scale, residual_limit,
                                                    residual_problem)
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.single import solve_on
from actuator_design.inverse.optimise import design_vector
from actuator_design.inverse.settings import Choice, DesignProblem

__all__ = ["MeshCheck", "check_mesh", "check_state", "unresolved", "refined_options", "regrade", "mesh_dict",
           "grading", "Seed", "seed_of", "MAX_REGRADES"]

#: Searches repeated on a regraded mesh at most (the design's field, and with it the grading, may
#: move between searches).
MAX_REGRADES = 3


@dataclass
class MeshCheck:
    """The accuracy of a chosen design's state on the design mesh.

    problem : why the mesh does not resolve it (None: it does).
    el_residual : the Euler–Lagrange residual (units of B0/ℓ; inf when the state does not converge).
    limit : the residual accepted (``residual_tol`` × the moment scale, B0/ℓ).
    """

    problem: Optional[str]
    el_residual: float
    limit: float

    @property
    def ok(self) -> bool:
        return self.problem is None


@dataclass(frozen=True)
class Seed:
    """A design carried to a new mesh: its values (a DesignPoint) and its state as a function of s."""

    point: object
    transcription: object  # the transcription the state z lives on (its ``theta_dense``)

    def theta_at(self, nodes: np.ndarray) -> np.ndarray:
        """θ of the seed's state at ``nodes`` (rad)."""
        return self.transcription.theta_dense(np.asarray(self.point.z, float), nodes)[0]


def seed_of(choice: Choice) -> Seed:
    """The chosen design as a starting design for a search on another mesh."""
    return Seed(choice.point, choice.candidate.nlp.solver.transcription)


def check_mesh(choice: Choice, options: SolverOptions) -> MeshCheck:
    """The Euler–Lagrange residual of the chosen state on its design mesh, against the promise of
    ``solve`` (:func:`check_state`)."""
    return check_state(choice.scene, choice.candidate.nlp.solver, choice.point.z, options)


def unresolved(candidate, point, options: SolverOptions) -> bool:
    """Whether a candidate's optimum misses the accuracy of ``solve`` on a mesh that grading would
    change (then adding design variables on this mesh is pointless: the mesh is regraded first)."""
    scene = candidate.nlp.scene_for(candidate.base, design_vector(candidate.nlp, point))
    if not options.adapt or graded_options(scene, options) == options:
        return False
    return not check_state(scene, candidate.nlp.solver, point.z, options).ok


def check_state(scene, solver, z: np.ndarray, options: SolverOptions) -> MeshCheck:
    """The Euler–Lagrange residual of the state ``z`` (θ at the nodes of ``solver``) of ``scene``
    (a Newton re-solve from it on that solver, then
    :func:`~actuator_design.equilibrium.acceptance.residual_problem`)."""
    opts = replace(options, method="newton", ensure_stable=False, accuracy=None)
    r = solve_on(scene, opts, np.asarray(z, float), solver)
    if not r.success or not np.all(np.isfinite(r.theta)):
        return MeshCheck("the designed state does not converge as an equilibrium of the design mesh",
                         float("inf"), float("nan"))
    return MeshCheck(residual_problem(r), float(r.el_residual), residual_limit(r.options) * moment_scale(r))


def refined_options(choice: Choice, options: SolverOptions) -> SolverOptions:
    """The design mesh graded towards the clamp (and the tip) for the chosen design's field
    (``options`` itself when it is already graded so, with ``adapt`` off, or for the midpoint rule)."""
    return graded_options(choice.scene, options) if options.adapt else options


def grading(options: SolverOptions) -> str:
    """How an LGL mesh is graded, in words: '3 levels towards the clamp and 3 levels towards the tip'."""
    parts = [f"{n} level{'s' if n != 1 else ''} towards the {end}"
             for n, end in ((int(options.clamp_levels), "clamp"), (int(options.tip_levels), "tip")) if n]
    return " and ".join(parts) or "not graded"


def mesh_dict(options: SolverOptions, check: Optional[MeshCheck], graded: bool) -> Dict[str, object]:
    """The ``mesh`` object of ``design --json``: the mesh the design was made on and its accuracy."""
    out: Dict[str, object] = {"transcription": options.transcription, "elements": int(options.elements),
                              "degree": int(options.degree), "clamp_levels": int(options.clamp_levels),
                              "tip_levels": int(options.tip_levels), "graded_for_design": bool(graded)}
    if check is not None:
        out.update(el_residual=check.el_residual if np.isfinite(check.el_residual) else None,
                   el_residual_limit=check.limit if np.isfinite(check.limit) else None,
                   resolved=check.ok)
    return out


def regrade(problem: DesignProblem, mirror: Optional[DesignProblem], choice: Choice,
            options: SolverOptions) -> Tuple[Optional[DesignProblem], Optional[DesignProblem]]:
    """The problem (and its mirror) on the refined mesh of ``choice``, seeded with it; (None, None)
    when the mesh cannot be refined further."""
    finer = refined_options(choice, options)
    if finer == options:
        return None, None
    seeds: List[Seed] = [seed_of(choice)]
    new = replace(problem, options=finer, seeds=tuple(seeds) if mirror is None else ())
    new_mirror = None if mirror is None else replace(mirror, options=finer, seeds=tuple(seeds))
    return new, new_mirror
