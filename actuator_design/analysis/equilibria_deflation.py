"""Method B of :mod:`.equilibria`: deflated Newton from many starts (independent of the scan).

Deflated Newton on the NLP's stationarity system from many initial shapes θ = θ0 + c s + d s² and the shapes of the
transverse modes; each new root is deflated (Farrell, Birkisson & Funke 2015) so that Newton
cannot return to it.
"""
from __future__ import annotations

import time
from typing import List, Optional

import numpy as np

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reduced.newton import newton
from actuator_design.model.scene import Scene
from actuator_design.equilibrium.solver import get_solver
from actuator_design.analysis.equilibria_found import (EquilibriaResult, Equilibrium, _dedupe_add,
                                                       _nlp_options, refine_to_promise)
from actuator_design.analysis.shooting_scan import gamma_bound, require_uniform

__all__ = ["find_equilibria_deflation"]


def find_equilibria_deflation(scene: Scene, options: Optional[SolverOptions] = None, *,
                              n_c: int = 13, n_d: int = 7, modes: int = 4, max_iter: int = 60,
                              shift: float = 1.0) -> EquilibriaResult:
    """Equilibria by deflated Newton on the NLP's stationarity system (Method B, independent).

    Starts: θ = θ0 + c s + d s² for c on ``n_c`` values in [−W, W] (W the a-priori γ window) and
    d on ``n_d`` values in [−W/2, W/2], and θ = θ0 ± A sin((2k−1)πs/2) for k ≤ ``modes``. From
    each start, Newton is applied to the deflated residual μ(u) ∇Ê(u), μ = Π_i (‖u − u_i‖⁻²_M +
    ``shift``) over the roots u_i found so far (Farrell, Birkisson & Funke, SIAM J. Sci. Comput.
    2015): the deflated step is τ δ_N with δ_N the Newton step of ∇Ê and
    τ = 1/(1 − ∇log μ · δ_N). Without a bound on the unknowns this is a multistart heuristic:
    it has no completeness guarantee (Method A has one).

    Returns
    -------
    EquilibriaResult
        ``complete`` is False (no guarantee); ``scan`` lists the starts and timings.
    """
    t0 = time.perf_counter()
    require_uniform(scene)
    opts = _nlp_options(options, scene)
    solver = get_solver(scene, opts)
    params = solver.parameter_vector(scene)
    mass = solver.transcription.mass[1:]
    s = solver.transcription.nodes[1:]
    th0 = float(scene.theta0)
    W = gamma_bound(scene)["window"]
    starts = [c * s + d * s * s for c in np.linspace(-W, W, n_c) for d in np.linspace(-W / 2, W / 2, n_d)]
    for k in range(1, modes + 1):
        for A in (0.5, 1.0, 1.5, 2.5):
            for sgn in (1, -1):
                starts.append(sgn * A * np.sin((2 * k - 1) * np.pi * s / 2))
    roots: List[np.ndarray] = []
    tol = opts.tol

    def grad_hess(u):
        _, g, H = solver.f_grad_hess(u, params)
        return np.asarray(g).ravel(), np.asarray(H)

    def deflated_step(H, minus_g):
        """τ δ_N: the Newton step of ∇Ê scaled by τ = 1/(1 − ∇log μ · δ_N)."""
        dN = np.linalg.solve(H, minus_g)
        u = current["u"]
        grad_log_mu = np.zeros_like(u)
        for r in roots:
            e = u - r
            n2 = float(np.dot(mass * e, e))
            grad_log_mu += (-2.0 * mass * e / n2**2) / (1.0 / n2 + shift)
        denom = 1.0 - float(grad_log_mu @ dN)
        return (1.0 / denom if abs(denom) > 1e-12 else 1.0) * dN

    current = {}

    def stationary(u, g):
        current["u"] = u
        return np.max(np.abs(g / mass)) <= tol

    for u0 in starts:
        # damping: at most 2 rad per iteration at any node
        u, ok, _ = newton(grad_hess, th0 + u0, stationary, max_iter - 1, clip_at=2.0, solve=deflated_step)
        if not ok:
            continue
        g, _ = grad_hess(u)
        if not (np.all(np.isfinite(u)) and np.max(np.abs(g / mass)) <= tol):
            continue
        if any(np.max(np.abs(u - r)) <= 1e-6 * max(1.0, np.max(np.abs(u))) for r in roots):
            continue
        roots.append(u.copy())
    found: List[Equilibrium] = []
    for u in roots:
        res = refine_to_promise(scene, opts, solve(scene, opts, initial=np.concatenate(([th0], u)),
                                                   solver=solver))
        if res.success:
            _dedupe_add(found, Equilibrium(res, res.gamma, None))
    found.sort(key=lambda e: e.gamma)
    scan = {"starts": len(starts), "time_total_s": time.perf_counter() - t0,
            "note": "multistart deflated Newton: no completeness guarantee"}
    return EquilibriaResult(scene, opts, found, False, (-W, W), scan, [], "deflation",
                            incomplete_reason="multistart deflated Newton finds equilibria but does not certify that "
                                              "it found them all (the shooting scan does, where it can be trusted)")


