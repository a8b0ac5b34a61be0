"""One solve on one mesh: from a start, with the stability verdict and saddle escapes, and the
result it makes (no mesh choice and no acceptance checks: those are the pipeline's,
:func:`actuator_design.equilibrium.pipeline.solve`). Used by the pipeline, its acceptance checks,
the contact solves and the analyses' warm re-solves.
"""
from __future__ import annotations

import time
from functools import partial
from typing import Optional

import numpy as np

from actuator_design.equilibrium.dense_shape import (Balance, DenseShape, clamp_curvature, nan_balance,
                                                     nan_shape, never_intersects, self_intersecting)
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.solver import EquilibriumSolver, RawSolution, get_solver
from actuator_design.model.scene import Scene

__all__ = ["solve_on", "make_result"]


def solve_on(scene: Scene, options: SolverOptions, initial=None,
             solver: Optional[EquilibriumSolver] = None, strict: bool = False) -> EquilibriumResult:
    """One solve from ``initial`` (default the straight rod) on ``solver``'s mesh (default the
    cached solver of ``options``), with the stability verdict and saddle escapes; no mesh choice
    and no acceptance checks (see :func:`solve`). ``strict``: every IPOPT failure status is a
    failure, even when Newton from IPOPT's last iterate converges (the public ``solve``);
    otherwise such a Newton point is accepted (the analyses' warm re-solves)."""
    if solver is None:
        solver = get_solver(scene, options)
    else:
        solver.check_structure(scene)
    t0 = time.perf_counter()
    params = solver.parameter_vector(scene)
    if isinstance(initial, EquilibriumResult):
        initial = initial.z
    z0 = solver.initial_guess(params, initial)

    method = options.method
    raw = _solve_once(solver, z0, params, method, strict)
    verdict = solver.stability(raw.z, params) if raw.converged else None
    escaped = False
    notes = []
    for _ in range(3):
        if not (options.ensure_stable and raw.converged and verdict.morse_index > 0):
            break
        v = verdict.eigenvector * (1.0 if verdict.eigenvector[-1] >= 0 else -1.0)
        trial = _solve_once(solver, raw.z + 0.2 * v, params, "ipopt", strict)
        if not trial.converged:
            notes.append("a saddle escape did not converge")
            break
        notes.append(f"left an unstable equilibrium (Morse index {verdict.morse_index}) along its unstable mode")
        raw, verdict, escaped = trial, solver.stability(trial.z, params), True
    solve_time = time.perf_counter() - t0
    return make_result(scene, options, solver, params, raw, verdict, escaped, notes, solve_time)


def _solve_once(solver: EquilibriumSolver, z0, params, method: str, strict: bool = False) -> RawSolution:
    """One solve with the requested method, a Newton polish, and an IPOPT fallback for Newton.

    ``"fast"``: full Newton steps (:meth:`EquilibriumSolver.solve_fast`); when a safeguard stops it,
    the damped Newton and then IPOPT take over and the message says so.
    """
    if method == "fast":
        raw = solver.solve_fast(z0, params)
        if raw.converged:
            return raw
        fallback = _solve_once(solver, z0, params, "newton", strict)
        fallback.message = f"{raw.message}; fell back to {fallback.message}"
        return fallback
    if method == "newton":
        raw = solver.solve_newton(z0, params)
        if raw.converged:
            return raw
        fallback = solver.solve_ipopt(z0, params)
        fallback.message = f"{raw.message}; fell back to {fallback.message}"
        raw = fallback
    else:
        raw = solver.solve_ipopt(z0, params)
    if np.all(np.isfinite(raw.z)):
        # confirm a converged IPOPT point (up to 30 cheap steps); from a failed one try briefly
        polish = solver.solve_newton(raw.z, params, max_iter=30 if raw.converged else 4,
                                     tol=solver.options.tol)
        if polish.converged and not raw.converged and strict:
            # every IPOPT failure status is a failure: Newton found a stationary point near
            # IPOPT's last iterate, but the minimisation did not finish (issue 10)
            polish.iterations += raw.iterations
            polish.converged, polish.status = False, raw.status
            polish.message = (raw.message + "; Newton from its last iterate found a stationary point, "
                              "but IPOPT's failure stands")
            raw = polish
        elif polish.converged:  # a small gradient and a small Newton step: the equilibrium located
            polish.iterations += raw.iterations
            polish.message = raw.message + " (+ Newton polish)"
            raw = polish
        elif raw.converged:
            # IPOPT's stopping test is on the gradient only: where the energy is flat (near
            # bifurcations and folds) that does not locate the equilibrium, so do not claim it
            raw.converged = False
            raw.status = "not_converged"
            raw.message += f"; not confirmed by Newton ({polish.message})"
    return raw


def make_result(scene, options, solver, params, raw: RawSolution, verdict, escaped, notes, solve_time):
    z = raw.z
    finite = bool(np.all(np.isfinite(z)))
    stats = {"method": options.method, "iterations": raw.iterations, "solve_time_s": solve_time,
             "build_time_s": solver.build_time, "nlp_reused": bool(getattr(solver, "cached", False)),
             "n_unknowns": int(z.size)}
    message = "; ".join([raw.message] + notes)
    if not finite:
        nan = np.full(z.size, np.nan)
        return EquilibriumResult(
            success=False, status=raw.status if raw.status != "converged" else "not_converged",
            message=message + "; the iterate is not finite", scene=scene, options=options,
            s=solver.transcription.nodes.copy(), theta=nan, tip={"x": np.nan, "y": np.nan, "angle": np.nan},
            energy=np.nan, stationarity=np.inf, eigenvalues=np.full(1, np.nan), morse_index=-1,
            stable=False, stats=stats, z=z, _dense=nan_shape, _balance=nan_balance, _intersects=never_intersects)
    if verdict is None:
        verdict = solver.stability(z, params)
    dense = DenseShape(solver.transcription, z)
    energy, tip_theta, tip_x, tip_y = solver.summary(z, params)
    if solver.jit_note:
        stats["jit"] = solver.jit_note
    return EquilibriumResult(
        success=bool(raw.converged), status="converged" if raw.converged else raw.status, message=message,
        scene=scene, options=options, s=solver.transcription.nodes.copy(), theta=z.copy(),
        tip={"x": tip_x, "y": tip_y, "angle": tip_theta},
        energy=energy, stationarity=raw.stationarity,
        eigenvalues=np.asarray(verdict.eigenvalues), morse_index=verdict.morse_index, stable=verdict.stable,
        marginal=verdict.marginal, escaped_saddle=escaped, stats=stats, z=z.copy(), _dense=dense,
        _balance=Balance(solver, params, dense, scene, z), _intersects=self_intersecting,
        _clamp_curvature=partial(clamp_curvature, solver.transcription, z))
