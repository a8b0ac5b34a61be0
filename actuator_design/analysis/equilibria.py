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

Every term that declares its part of the equation (``EnergyTerm.shooting_part``,
:func:`~.shooting_scan.shooting_terms`) is supported, the hard-magnetic torque of
THEORY §9 included; a scene with any other term is refused. Non-uniform fields are not supported
(the field force depends on the rod's position).
"""
from __future__ import annotations

import time
from typing import List, Optional, Sequence

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq

from actuator_design.analysis.equilibria_deflation import find_equilibria_deflation
from actuator_design.analysis.equilibria_found import (EquilibriaResult, Equilibrium, _dedupe_add,
                                                       _nlp_options, confirm)
from actuator_design.analysis.registration import register
from actuator_design.analysis.shooting_scan import (MAX_REFINE, SAFETY, ShootingProblem, brackets,
                                                    curvature_bound, gamma_bound, min_gamma_points,
                                                    require_uniform, scan_validity, shooting_terms, steps_for)
from actuator_design.contact.guard import no_contact
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import get_solver
from actuator_design.model.scene import Scene

__all__ = ["ShootingProblem", "Equilibrium", "EquilibriaResult", "find_equilibria",
           "find_equilibria_deflation", "gamma_bound", "curvature_bound", "SAFETY", "MAX_REFINE",
           "SHOOTING_TERMS", "shooting_terms"]

#: The terms the shooting scan integrates, as registered at import (a term registered later that
#: declares its part is supported too: :func:`shooting_terms`).
SHOOTING_TERMS = shooting_terms()

_EPS = np.finfo(float).eps


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

