"""All equilibria of a uniform-field scene, with their stability (THEORY §5, §7, §8).

Method A (default, :func:`find_equilibria`): a complete scan of the shooting parameter
γ = θ'(0) over an a-priori window (:mod:`.shooting_scan` has the equation, the bounds and the
vectorised RK4): every sign change of the free-end residual r(γ) is refined by ``brentq`` and
confirmed by the collocation NLP (Newton from the shooting shape, no saddle escape), and
deduplicated. Completeness is ensured up to the resolution: the window is a rigorous bound, r is
smooth in γ, and the number of sign changes must be the same on the grid and on a grid of half the
step (else the step is halved again, up to :data:`MAX_REFINE` times and the result says
``complete: false``). Roots closer together than the final γ step (scenes within about that
distance of a fold) can still be missed: this is stated in the result. The scan is only run where
it can be trusted (:func:`~.shooting_scan.scan_validity`: the IVP's error amplification e^L stays
below 1e-6/(ε W), e.g. h ≲ 12 for THEORY §5's scene); elsewhere (``equilibria --h 1e4``, where the
IVP overflows) the result is ``complete: false`` with the reason, never an empty complete set.

Method B (independent, :func:`find_equilibria_deflation`): deflated Newton on the NLP's
stationarity system from many initial shapes θ = θ0 + c s + d s² and the shapes of the
transverse modes; each new root is deflated (Farrell, Birkisson & Funke 2015) so that Newton
cannot return to it.

Every term of :data:`~.shooting_scan.SHOOTING_TERMS` is supported, the hard-magnetic torque of
THEORY §9 included; a scene with any other term is refused. Non-uniform fields are not supported
(the field force depends on the rod's position).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Sequence

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq

from ..equilibrium import solve
from ..options import SolverOptions
from ..result import EquilibriumResult
from ..scene import Scene
from ..solver import get_solver
from .registry import register
from .shooting_scan import (MAX_REFINE, SAFETY, SHOOTING_TERMS, ShootingProblem, brackets,
                            curvature_bound, gamma_bound, min_gamma_points, require_uniform,
                            scan_validity, steps_for)
from ..contact_guard import no_contact

__all__ = ["ShootingProblem", "Equilibrium", "EquilibriaResult", "find_equilibria",
           "find_equilibria_deflation", "gamma_bound", "curvature_bound", "SAFETY", "MAX_REFINE",
           "SHOOTING_TERMS"]

_EPS = np.finfo(float).eps


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
        residual, :func:`~actuator_design.acceptance.residual_problem`), or None."""
        from ..acceptance import residual_problem
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
                "failures": self.failures, "groups": self.scene.describe_groups(),
                "units": {"gamma": "1/l", "length": "l", "energy": "B0/l", "angle": "rad"}}


#: most elements an equilibrium's mesh is refined to when its residual misses the promise
MAX_CONFIRM_ELEMENTS = 128
#: arc lengths where two equilibria (possibly on different meshes) are compared
_COMPARE_AT = np.linspace(0.0, 1.0, 129)


def _nlp_options(options: Optional[SolverOptions], scene: Optional[Scene] = None) -> SolverOptions:
    """Newton without saddle escape, on the mesh ``solve`` would grade for ``scene``'s layers."""
    from ..acceptance import graded_options

    opts = replace(options or SolverOptions(), ensure_stable=False, method="newton")
    return graded_options(scene, opts) if scene is not None and opts.adapt else opts


def confirm(scene: Scene, opts: SolverOptions, theta_at, solver=None) -> EquilibriumResult:
    """The NLP equilibrium started from the shape ``theta_at(s)`` (a callable of arc length), held
    to the accuracy promise of ``solve`` (:func:`~actuator_design.acceptance.residual_problem`):
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
    from ..acceptance import residual_problem

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


@no_contact("equilibria")
def find_equilibria(scene: Scene, options: Optional[SolverOptions] = None, *,
                    n_gamma: int = 401, gamma_window: Optional[Sequence[float]] = None,
                    n_steps: Optional[int] = None) -> EquilibriaResult:
    """Every equilibrium of a uniform-field scene with θ'(0) in the a-priori window (Method A).

    Parameters
    ----------
    scene : Scene
        Uniform field or none; any φ, tip force, tip moment, α(s), b(s), distributed load, θ0,
        hard-magnetic h_r with β(s) (THEORY §9).
    options : SolverOptions, optional
        Collocation used to confirm each root (``method`` and ``ensure_stable`` are overridden by
        Newton without saddle escape).
    n_gamma : int
        Initial number of γ grid points (doubled until the bracket count is stable).
    gamma_window : (float, float), optional
        Scan this γ interval instead of the a-priori window (then ``complete`` refers to it).
    n_steps : int, optional
        RK4 steps of the scan (default from the curvature bound, ~0.1 rad per step).

    Returns
    -------
    EquilibriaResult
    """
    t0 = time.perf_counter()
    require_uniform(scene)
    opts = _nlp_options(options, scene)
    gb = gamma_bound(scene)
    lo, hi = (-gb["window"], gb["window"]) if gamma_window is None else map(float, gamma_window)
    if not hi > lo:
        raise ValueError(f"gamma_window must be increasing, got ({lo}, {hi})")
    validity = scan_validity(scene, max(abs(lo), abs(hi)))
    if not validity["valid"]:
        scan = {"gamma_bound": gb, "validity": validity, "time_total_s": time.perf_counter() - t0,
                "note": "not scanned: " + validity["reason"]}
        return EquilibriaResult(scene, opts, [], False, (lo, hi), scan, [], "shooting",
                                validity["reason"])
    N = n_steps or steps_for(scene, max(abs(lo), abs(hi)))
    prob = ShootingProblem(scene, N)
    n0 = max(int(n_gamma), 11, min_gamma_points(scene, max(abs(lo), abs(hi))))
    g, r, br, counts, complete = _scan(prob, lo, hi, n0)
    reason = None
    if not np.all(np.isfinite(r)):
        complete, reason = False, "the shooting residual overflowed on part of the gamma window"
    elif not complete:
        reason = (f"the number of sign changes did not stabilise after halving the gamma step "
                  f"{MAX_REFINE} times (raise n_gamma)")
    t_scan = time.perf_counter() - t0

    fine = ShootingProblem(scene, min(2 * N, 8000))
    shot = fine.scalar(0)
    solver = get_solver(scene, opts)
    found: List[Equilibrium] = []
    failures = []
    for a, b in br:
        if a == b:
            gam = a
        else:
            ra, rb = shot(a), shot(b)
            if ra == 0.0:
                gam = a
            elif rb == 0.0:
                gam = b
            elif ra * rb > 0:  # the finer integration moved the sign change: search nearby
                gam = a if abs(ra) < abs(rb) else b
            else:
                gam = brentq(shot, a, b, xtol=1e-14, rtol=4 * _EPS, maxiter=200)
        _, s, th, dth = shot(gam, record=True)
        res = confirm(scene, opts, CubicHermiteSpline(s, th, dth), solver)
        if not res.success:
            failures.append({"gamma_shooting": float(gam), "message": res.message})
            continue
        eq = Equilibrium(res, res.gamma, float(gam))
        if abs(eq.gamma - gam) > 1e-3 * max(1.0, abs(gam)):
            failures.append({"gamma_shooting": float(gam), "gamma_nlp": eq.gamma,
                             "message": "the NLP converged to an equilibrium away from the shooting "
                                        "root (resolution too low?)"})
        _dedupe_add(found, eq)
    found.sort(key=lambda e: e.gamma)
    scan = {"gamma_bound": gb, "n_gamma": int(g.size), "gamma_step": float(g[1] - g[0]),
            "bracket_counts": counts, "rk4_steps": N, "time_scan_s": t_scan,
            "time_total_s": time.perf_counter() - t0,
            "validity": validity,
            "note": "complete up to roots closer together than gamma_step (near folds)"}
    return EquilibriaResult(scene, opts, found, complete, (lo, hi), scan, failures, "shooting", reason)


def _scan(prob: ShootingProblem, lo: float, hi: float, n: int):
    """Sign changes of r(γ) on a uniform grid of [lo, hi], the step halved until their number is
    stable (at most :data:`MAX_REFINE` times). Returns (γ grid, r, brackets, counts, stable)."""
    g = np.linspace(lo, hi, n)
    with np.errstate(over="ignore", invalid="ignore"):
        r = prob.residual(g)
        br = brackets(g, r)
        counts, complete = [len(br)], False
        for _ in range(MAX_REFINE):
            g2 = np.linspace(lo, hi, 2 * len(g) - 1)
            r2 = np.empty(g2.size)
            r2[::2] = r
            r2[1::2] = prob.residual(g2[1::2])
            br2 = brackets(g2, r2)
            counts.append(len(br2))
            g, r, same = g2, r2, len(br2) == len(br)
            br = br2
            if same:
                complete = True
                break
    return g, r, br, counts, complete


from .equilibria_deflation import find_equilibria_deflation  # noqa: E402  (it builds on the above)


@register("equilibria")
def run_equilibria(scene, options, **settings) -> dict:
    """All equilibria (Method A); settings: ``n_gamma``, ``gamma_window``, ``method``
    (``"shooting"`` or ``"deflation"``)."""
    method = settings.pop("method", "shooting")
    if method == "shooting":
        out = find_equilibria(scene, options, **settings)
    elif method == "deflation":
        out = find_equilibria_deflation(scene, options, **settings)
    else:
        raise ValueError(f"equilibria.method must be 'shooting' or 'deflation', got {method!r}")
    return out.to_dict()

