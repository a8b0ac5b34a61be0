"""The Newton methods of the reduced system: one module for every Newton iteration in the package.

* :func:`damped_newton` — damped Newton on ∇Ê(u) = 0 (exact Hessian, backtracking on the residual);
* :func:`fast_newton` — Newton from a warm start reusing the Hessian's factorisation while the
  residual contracts (the ``method="fast"`` path);
* :func:`newton` — plain Newton on an augmented square system F(x) = 0 (continuation correctors,
  the Moore–Spence fold system, fold curves), with the step safeguards the callers choose.

The two equilibrium Newtons share one convergence rule: the residual r = max_i |∂Ê/∂θ_i| / m_i is
below ``atol`` **and** the Newton step there is below ``xtol`` (rad) — near bifurcations and folds
the energy is so flat that a small gradient alone does not locate the equilibrium — or, at the
rounding floor (:meth:`~actuator_design.reduced.kernel.FastKernel.rounding_floor`), a step below ``xtol``
with the residual within min(floor, 1e4 atol) of tolerance.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Tuple

import numpy as np

from actuator_design.reduced.linalg import FLOOR_EXCUSE

__all__ = ["RawSolution", "damped_newton", "fast_newton", "newton"]


@dataclass
class RawSolution:
    """The outcome of an equilibrium solve.

    z : ndarray, shape (n_nodes,)
        θ at the nodes (rad), θ_0 the clamp angle.
    stationarity : float
        max_i |∂Ê/∂θ_i| / m_i at z.
    """

    z: np.ndarray
    converged: bool
    status: str
    message: str
    iterations: int
    stationarity: float


def _rounding_step(step_norm: float, zr: np.ndarray) -> bool:
    return step_norm <= 1e-14 * (1.0 + float(np.abs(zr).max(initial=0.0)))


def damped_newton(kernel, z0: np.ndarray, theta0: float, atol: float, xtol: float,
                  max_iter: int, excuse: Optional[float] = None) -> RawSolution:
    """Damped Newton on ∇Ê = 0 in the free unknowns (exact Hessian, backtracking on |∇Ê|).

    Converged when r ≤ ``atol`` and the Newton step there is ≤ ``xtol`` (the point after that step
    is returned), or when a full step is below rounding with the residual within 1e3 of ``atol``.

    Parameters
    ----------
    kernel : FastKernel
        With its parameters already set.
    z0 : ndarray, shape (n_nodes,)
        Start (θ_0 is reset to ``theta0``).
    theta0 : float
        Clamp angle (rad).
    atol, xtol : float
        Residual and step tolerances.
    max_iter : int
    excuse : float, optional
        The most a residual above ``atol`` may exceed it by rounding (the floor's cap; default
        :data:`~actuator_design.reduced.linalg.FLOOR_EXCUSE` × ``atol``).
    """
    k = kernel
    cap = FLOOR_EXCUSE * atol if excuse is None else excuse
    z = np.array(z0, float)
    z[0] = theta0
    zr = z[1:].copy()
    res = k.evaluate(zr)
    it = 0

    def done(zr_, r_, how=""):
        z[1:] = zr_
        return RawSolution(z, True, "converged", f"Newton: converged{how}", it, float(r_))

    for it in range(max_iter + 1):
        if not np.isfinite(res):
            break
        step = k.newton_step()
        if step is None:
            break
        snorm = float(np.abs(step).max())
        if res <= atol and snorm <= xtol:
            if _rounding_step(snorm, zr):
                return done(zr, res)  # the step is rounding noise: nothing to improve
            res_new = k.evaluate(zr - step)
            return done(zr - step, res_new) if res_new <= atol else done(zr, res)
        if snorm <= xtol and res <= atol + min(k.rounding_floor(zr), cap):
            return done(zr, res, " (at the rounding floor)")
        if it == max_iter:
            break
        if res <= atol:  # flat energy (near-singular Hessian): follow Newton while it stays small
            res_new = k.evaluate(zr - step)
            if res_new <= atol:
                zr, res = zr - step, res_new
                continue
        t = 1.0
        while t > 1e-4:
            res_new = k.evaluate(zr - t * step)
            if np.isfinite(res_new) and res_new < (1 - 1e-4 * t) * res + 1e-14:
                break
            t *= 0.5
        else:
            k.evaluate(zr)
            if snorm <= xtol and res <= atol + min(k.rounding_floor(zr), cap):
                return done(zr, res, " (at the rounding floor)")
            break
        zr, res = zr - t * step, res_new
        if t == 1.0 and res <= 1e3 * atol and snorm <= 1e-14 * (1.0 + np.max(np.abs(zr))):
            return done(zr, res, " (step below rounding)")  # converged to machine precision
    z[1:] = zr
    return RawSolution(z, False, "not_converged",
                       f"Newton: stationarity {res:.3g} (tol {atol:.3g}) not confirmed by a small "
                       f"Newton step after {it} iterations", it, float(res))


def fast_newton(kernel, z0: np.ndarray, theta0: float, atol: float, xtol: float,
                max_iter: int, excuse: Optional[float] = None) -> RawSolution:
    """Newton on ∇Ê = 0 from a warm start, reusing the Hessian's factorisation while it contracts.

    The Hessian is evaluated and LU-factorised once; later steps reuse the factorisation (one
    gradient evaluation and one triangular solve each) as long as the residual falls at least
    tenfold per step; otherwise the Hessian is re-evaluated at the current iterate. Safeguards, so
    that it never returns a wrong answer as converged: a step computed with a fresh Hessian must
    reduce r (while r is above tolerance), the Hessian must be non-singular and every value finite
    — otherwise it stops with ``converged=False``.

    Parameters are those of :func:`damped_newton`.
    """
    k = kernel
    cap = FLOOR_EXCUSE * atol if excuse is None else excuse
    zr = np.array(z0[1:], float)
    res = k.evaluate(zr, hessian=False)
    fresh = factored = False
    it, why = 0, ""

    def done(z, r, how=""):
        return RawSolution(np.concatenate(([theta0], z)), True, "converged",
                           f"fast Newton: converged{how}", it, float(r))

    ratio = 1.0  # residual contraction of the last step: ~‖I − H0⁻¹H‖ for a reused H0
    while True:
        if not res < np.inf:  # also catches NaN
            why = "the residual is not finite"
            break
        if it >= max_iter:
            why = f"stationarity {res:.3g} (tol {atol:.3g}) after {it} steps"
            break
        if not factored:
            res = k.evaluate(zr, hessian=True)
            fresh = factored = k.factorize()
            if not factored:
                why = "singular Hessian"
                break
        step = k.solve()
        if step is None:
            why = "singular Hessian"
            break
        snorm = float(np.abs(step).max())
        # a reused factorisation measures the Newton step well when it contracted strongly
        trusted = fresh or ratio <= 0.1
        if res <= atol and snorm <= xtol and trusted:  # converged: finish with the small step
            if _rounding_step(snorm, zr):
                return done(zr, res)  # the step is rounding noise: nothing to improve
            zr_new = zr - step
            res_new = k.evaluate(zr_new, hessian=False)
            return done(zr_new, res_new) if res_new <= atol else done(zr, res)
        if res <= atol and not trusted:
            factored = False  # small gradient, step not certified: refresh the Hessian
            continue
        if fresh and snorm <= xtol and res <= atol + min(k.rounding_floor(zr), cap):
            return done(zr, res, " (at the rounding floor)")
        zr_new = zr - step
        res_new = k.evaluate(zr_new, hessian=False)
        it += 1
        accept = res_new < res or (res <= atol and res_new <= atol)
        if not accept:
            if not fresh:  # the reused factorisation is stale: a full Newton step instead
                factored = False
                ratio = 1.0
                continue
            if _rounding_step(snorm, zr) and res <= 1e3 * atol:
                return done(zr, res, " (step below rounding)")
            why = f"a full Newton step did not reduce the residual ({res:.3g} -> {res_new:.3g})"
            break
        ratio = res_new / res if res > 0 else 0.0
        zr, res = zr_new, res_new
        fresh = False
        if ratio > 0.1:  # slow contraction (or near-singular): refresh the Hessian
            factored = False
    return RawSolution(np.concatenate(([theta0], zr)), False, "not_converged",
                       f"fast Newton: {why}", it, float(res))


def newton(evaluate: Callable[[np.ndarray], Tuple[np.ndarray, np.ndarray]], x0: np.ndarray,
           converged: Callable[[np.ndarray, np.ndarray], bool], max_iter: int, *,
           reject_above: Optional[float] = None, reject_slice: slice = slice(None),
           clip_at: Optional[float] = None,
           solve: Callable[[np.ndarray, np.ndarray], np.ndarray] = np.linalg.solve,
           converged_after_step: Optional[Callable[[np.ndarray, np.ndarray], bool]] = None,
           reject: Optional[Callable[[np.ndarray], bool]] = None):
    """Newton's method on a square system F(x) = 0 with the exact Jacobian.

    Each iteration evaluates (F, J) at x, stops successfully when ``converged(x, F)``, and
    otherwise steps x ← x − J⁻¹F.

    Parameters
    ----------
    evaluate : callable
        x (m,) -> (F (m,), J (m, m)).
    x0 : ndarray, shape (m,)
    converged : callable
        (x, F) -> bool.
    max_iter : int
        Maximum number of steps.
    reject_above : float, optional
        Fail when max |δx[reject_slice]| exceeds it (a step that leaves the basin).
    clip_at : float, optional
        Scale the step down to max |δx| = clip_at (damping).
    solve : callable
        (J, b) -> J⁻¹ b; raises ``numpy.linalg.LinAlgError`` when singular.
    converged_after_step : callable, optional
        (F, δx) -> bool, tested after the step x ← x + δx: success with the new x (a residual
        test confirmed by a small step).
    reject : callable, optional
        x -> bool after each step: fail (the iterate left the region of interest).

    Returns
    -------
    (x, converged, iterations)
    """
    x = np.array(x0, float)
    for it in range(max_iter + 1):
        F, J = evaluate(x)
        if not np.all(np.isfinite(F)):
            return x, False, it
        if converged(x, F):
            return x, True, it
        if it == max_iter:
            break
        try:
            dx = solve(J, -F)
        except np.linalg.LinAlgError:
            return x, False, it
        if not np.all(np.isfinite(dx)):
            return x, False, it
        if reject_above is not None and np.max(np.abs(dx[reject_slice])) > reject_above:
            return x, False, it
        if clip_at is not None:
            big = np.max(np.abs(dx))
            if big > clip_at:
                dx = dx * (clip_at / big)
        x = x + dx
        if reject is not None and reject(x):
            return x, False, it + 1
        if converged_after_step is not None and converged_after_step(F, dx):
            return x, True, it + 1
    return x, False, max_iter
