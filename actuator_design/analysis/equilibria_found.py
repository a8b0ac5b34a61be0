"""The equilibria found so far: their records, deduplication, and each one confirmed by the
collocation NLP and refined to the accuracy promise. Shared by the shooting scan
(:func:`~actuator_design.analysis.equilibria.find_equilibria`) and deflation
(:func:`~actuator_design.analysis.equilibria_deflation.find_equilibria_deflation`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional

import numpy as np

from actuator_design.equilibrium.acceptance import graded_options, residual_problem
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.solver import get_solver
from actuator_design.model.scene import Scene
from actuator_design.physics.registry import describe_groups

__all__ = ["Equilibrium", "EquilibriaResult", "MAX_CONFIRM_ELEMENTS", "confirm", "refine_to_promise"]


@dataclass
class Equilibrium:
    """One equilibrium found by :func:`find_equilibria` (dimensionless, THEORY §5).

    Attributes
    ----------
    result : EquilibriumResult
        The collocation NLP's solution (shape, tip, energy, reduced-Hessian stability).
    gamma : float
        θ'(0) of the NLP solution (units of 1/ℓ).
    gamma_shooting : float or None
        The refined shooting root it was started from (Method A), else None.
    """

    result: EquilibriumResult
    gamma: float
    gamma_shooting: Optional[float] = None

    @property
    def tip(self) -> Dict[str, float]:
        return {k: float(v) for k, v in self.result.tip.items()}

    @property
    def energy(self) -> float:
        return float(self.result.energy)

    @property
    def morse_index(self) -> int:
        return int(self.result.morse_index)

    @property
    def stable(self) -> bool:
        return bool(self.result.stable)

    @property
    def self_intersecting(self) -> bool:
        return bool(self.result.self_intersecting)

    @property
    def accuracy_problem(self) -> Optional[str]:
        """Why the equilibrium misses the accuracy ``solve`` promises (its Euler–Lagrange
        residual, :func:`~actuator_design.equilibrium.acceptance.residual_problem`), or None."""
        return residual_problem(self.result)

    def to_dict(self) -> dict:
        problem = self.accuracy_problem
        return {"tip": self.tip, "energy": self.energy, "morse_index": self.morse_index,
                "stable": self.stable, "gamma": float(self.gamma),
                "gamma_shooting": None if self.gamma_shooting is None else float(self.gamma_shooting),
                "self_intersecting": self.self_intersecting,
                "smallest_eigenvalue": float(self.result.eigenvalues[0]),
                "stationarity": float(self.result.stationarity),
                "el_residual": float(self.result.el_residual), "accurate": problem is None,
                "accuracy_problem": problem,
                "mesh": {"elements": int(self.result.options.elements),
                         "degree": int(self.result.options.degree)}}


@dataclass
class EquilibriaResult:
    """All equilibria of a scene found in a γ window, sorted by γ.

    Attributes
    ----------
    equilibria : list of Equilibrium
    complete : bool
        The bracket count was stable under halving the γ step (Method A) — complete up to
        roots closer than ``scan['gamma_step']``.
    window : (float, float)
        The γ interval scanned (the widened a-priori bound unless given).
    scan : dict
        Bound details, grid sizes, bracket counts per resolution, RK steps, timings.
    failures : list of dict
        Brackets the NLP could not confirm (each with its γ and the solver message).
    method : str
    incomplete_reason : str or None
        Why ``complete`` is False (None when complete).
    """

    def __repr__(self) -> str:
        """One line: how many equilibria, how many stable, and whether the list is complete."""
        n_stable = sum(1 for e in self.equilibria if getattr(e, "stable", False))
        return (f"EquilibriaResult(count={len(self.equilibria)}, stable={n_stable}, complete={self.complete}, "
                f"window=({self.window[0]:.6g}, {self.window[1]:.6g}))")


    scene: Scene
    options: SolverOptions
    equilibria: List[Equilibrium]
    complete: bool
    window: tuple
    scan: dict
    failures: list = field(default_factory=list)
    method: str = "shooting"
    incomplete_reason: Optional[str] = None

    @property
    def count(self) -> int:
        return len(self.equilibria)

    @property
    def stable_count(self) -> int:
        return sum(e.stable for e in self.equilibria)

    @property
    def inaccurate(self) -> List[Equilibrium]:
        """The equilibria that miss ``solve``'s accuracy promise even on the finest mesh tried."""
        return [e for e in self.equilibria if e.accuracy_problem is not None]

    def to_dict(self) -> dict:
        """The ``equilibria --json`` contract: ``equilibria`` with tip, energy, morse_index, stable,
        gamma (θ'(0)) each; plus counts, window and how completeness was checked."""
        return {"equilibria": [e.to_dict() for e in self.equilibria], "count": self.count,
                "stable_count": self.stable_count, "complete": bool(self.complete),
                "incomplete_reason": self.incomplete_reason, "gamma_window": list(self.window), "method": self.method, "scan": self.scan,
                "accurate": not self.inaccurate, "inaccurate_count": len(self.inaccurate),
                "failures": self.failures, "groups": describe_groups(self.scene),
                "units": {"gamma": "1/l", "length": "l", "energy": "B0/l", "angle": "rad"}}


#: most elements an equilibrium's mesh is refined to when its residual misses the promise
MAX_CONFIRM_ELEMENTS = 128
#: arc lengths where two equilibria (possibly on different meshes) are compared
_COMPARE_AT = np.linspace(0.0, 1.0, 129)


def _nlp_options(options: Optional[SolverOptions], scene: Optional[Scene] = None) -> SolverOptions:
    """Newton without saddle escape, on the mesh ``solve`` would grade for ``scene``'s layers."""
    opts = replace(options or SolverOptions(), ensure_stable=False, method="newton")
    return graded_options(scene, opts) if scene is not None and opts.adapt else opts


def confirm(scene: Scene, opts: SolverOptions, theta_at, solver=None) -> EquilibriumResult:
    """The NLP equilibrium started from the shape ``theta_at(s)`` (a callable of arc length), held
    to the accuracy promise of ``solve`` (:func:`~actuator_design.equilibrium.acceptance.residual_problem`):
    while its Euler–Lagrange residual misses it, the mesh's elements are doubled (up to
    :data:`MAX_CONFIRM_ELEMENTS`) and the equilibrium re-solved from the coarser one. The result
    that still misses it is returned as it is; the caller flags it (``Equilibrium.accurate``)."""
    solver = solver or get_solver(scene, opts)
    res = solve(scene, opts, initial=np.asarray(theta_at(solver.transcription.nodes), float),
                solver=solver)
    return refine_to_promise(scene, opts, res)


def refine_to_promise(scene: Scene, opts: SolverOptions, res: EquilibriumResult) -> EquilibriumResult:
    """``res`` (solved with ``opts``), re-solved on meshes with twice the elements while its
    Euler–Lagrange residual misses the promise of ``solve`` (see :func:`confirm`)."""
    while res.success and residual_problem(res) is not None and opts.elements < MAX_CONFIRM_ELEMENTS:
        opts = replace(opts, elements=min(MAX_CONFIRM_ELEMENTS, 2 * opts.elements))
        finer_solver = get_solver(scene, opts)
        finer = solve(scene, opts, initial=res.evaluate(finer_solver.transcription.nodes)["theta"],
                      solver=finer_solver)
        if not finer.success:
            break
        res = finer
    return res


def _dedupe_add(found: List[Equilibrium], eq: Equilibrium, tol: float = 1e-6) -> bool:
    theta = eq.result.evaluate(_COMPARE_AT)["theta"]
    for other in found:
        if np.max(np.abs(other.result.evaluate(_COMPARE_AT)["theta"] - theta)) <= tol * max(1.0, np.max(np.abs(theta))):
            return False
    found.append(eq)
    return True
