"""``solve``: one equilibrium of a scene, with its stability verdict (the public forward API)."""
from __future__ import annotations

import time
from functools import partial
from typing import Optional, Union

import numpy as np

from .dense_shape import (Balance, DenseShape, clamp_curvature, nan_balance, nan_shape, never_intersects,
                          self_intersecting)
from .options import SolverOptions
from .result import EquilibriumResult
from .scene import Scene
from .solver import EquilibriumSolver, RawSolution, get_solver

__all__ = ["solve", "solve_on"]


def solve(scene: Scene, options: Optional[SolverOptions] = None,
          initial: Union[None, np.ndarray, EquilibriumResult] = None,
          solver: Optional[EquilibriumSolver] = None) -> EquilibriumResult:
    """Compute an equilibrium of ``scene`` by minimising its discrete energy.

    Without a ``solver`` (and without a node-array ``initial``) ``solve`` chooses the mesh from the
    scene and checks the answer (:mod:`actuator_design.acceptance`): the state reached from rest
    (``options.start``), the mesh graded towards boundary layers and refined until the
    Euler–Lagrange residual meets ``options.residual_tol``; an inaccurate or self-intersecting
    result is ``success=False`` with ``status`` ``"inaccurate"`` or ``"self_intersecting"``.
    With a ``solver`` it is one warm-started solve on that solver's mesh (the analyses' path).

    Parameters
    ----------
    scene : Scene
        Dimensionless scene (THEORY §5).
    options : SolverOptions, optional
        Transcription, resolution, method; defaults to ``SolverOptions()``. With
        ``options.accuracy`` set (and no ``solver``), the resolution is chosen for that tip error
        and the result carries ``error_estimate`` (:func:`actuator_design.accuracy.solve_to_tolerance`).
    initial : ndarray of shape (n_nodes,) or EquilibriumResult, optional
        Warm start (θ at the nodes). Default: the state reached from rest, or with
        ``options.start="straight"`` (or a ``solver`` given) the straight rod at the clamp angle.
    solver : EquilibriumSolver, optional
        A solver built for this scene's structure (default: the cached one).

    Returns
    -------
    EquilibriumResult
        Never raises on non-convergence: ``success``/``status``/``message`` say what happened.
    """
    options = options or SolverOptions()
    warm_self = (isinstance(initial, EquilibriumResult) and options.self_contact
                 and not options.keep_self_intersecting and scene.contact_gap > 0 and _near_itself(initial))
    if scene.obstacles or warm_self:  # unilateral constraints: IPOPT with the contact rows (a start
        from .contact import solve_contact  # pressing on itself keeps its self-contact rows)
        result = solve_contact(scene, options, initial if isinstance(initial, EquilibriumResult) else None)
    elif options.accuracy is not None and solver is None:
        from dataclasses import replace

        from .acceptance import check_physical
        from .accuracy import solve_to_tolerance
        result = check_physical(solve_to_tolerance(scene, options.accuracy,
                                                   options=replace(options, accuracy=None), initial=initial))
    elif solver is None and not isinstance(initial, np.ndarray):
        from .acceptance import solve_checked
        result = solve_checked(scene, options, initial)
    else:
        return solve_on(scene, options, initial, solver)
    if (options.self_contact and not options.keep_self_intersecting and scene.contact_gap > 0
            and not (result.contact or {}).get("self_contact")):
        # a shape that crosses itself or enters its own thickness: the rod against itself, the
        # contact equilibrium reached from rest (issue 20 item 3)
        from .self_contact import self_penetration, solve_self_contact
        # (also a contact result judged inaccurate for entering an obstacle: the rod wound round a
        # peg onto itself enters the peg because it passes through its own turn)
        through = result.status == "self_intersecting" or (
            (result.success or result.status == "inaccurate") and self_penetration(result, scene.contact_gap))
        if through:
            return solve_self_contact(scene, options, initial if isinstance(initial, EquilibriumResult) else None)
    return result


def _near_itself(state: EquilibriumResult) -> bool:
    """Whether a warm start presses on itself, or comes within reach of it
    (:data:`~actuator_design.self_contact.REACH`): a step from it keeps the self-contact rows, which
    keep the rod on its side of itself (a free step could pass through the rod's thickness)."""
    from .self_contact import REACH, self_penetration

    if (state.contact or {}).get("self_contact"):
        return True
    gap = state.scene.contact_gap
    return bool(state.success and gap > 0 and self_penetration(state, gap, n=401, tol=-REACH) is not None)


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
    return _make_result(scene, options, solver, params, raw, verdict, escaped, notes, solve_time)


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


def _make_result(scene, options, solver, params, raw: RawSolution, verdict, escaped, notes, solve_time):
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
        _balance=Balance(solver, params, dense, scene, options, z), _intersects=self_intersecting,
        _clamp_curvature=partial(clamp_curvature, solver.transcription, z))
