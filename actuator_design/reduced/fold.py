"""The fold locator of the reduced system: Newton on the Moore–Spence system (THEORY §7–8).

A fold (limit point) of G(u, λ) = ∇_u Ê = 0 in λ is an equilibrium whose reduced Hessian H is
singular with ψᵀG_λ ≠ 0. It solves the augmented system (2n + 1 equations in X = (u, λ, v))

    G(u, λ) = 0,   H(u, λ) v = 0,   cᵀ M v = 1,

whose Jacobian [[H, G_λ, 0], [∂(Hv)/∂u, ∂(Hv)/∂λ, H], [0, 0, (Mc)ᵀ]] is regular at a quadratic
fold (Moore & Spence 1980), so Newton converges quadratically; ∂(Hv)/∂u is the third derivative of
the energy in the direction v.

λ is either the system's first parameter (the others held fixed) or the coordinate of a curve
λ ↦ (p_1(λ), …, p_k(λ)) through the system's parameters (a loading-path segment: several NLP
slots moving at once); then ∂/∂λ = Σ_i p_i'(λ) ∂/∂p_i by the chain rule, exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Tuple

import numpy as np

from actuator_design.reduced.linalg import FLOOR_STEP, null_vector, within_rounding_floor
from actuator_design.reduced.newton import newton
from actuator_design.reduced.system import ReducedSystem

__all__ = ["FoldPoint", "locate_fold", "fold_converged", "fold_converged_at_floor"]


@dataclass
class FoldPoint:
    """A fold located by :func:`locate_fold`.

    u : ndarray, shape (n,)
        Free unknowns (rad).
    lam : float
        The folding parameter's value.
    v : ndarray, shape (n,)
        Null vector of H, scaled so that cᵀMv = 1.
    converged : bool
    iterations : int
    """

    u: np.ndarray
    lam: float
    v: np.ndarray
    converged: bool
    iterations: int


def fold_converged(F: np.ndarray, mass: np.ndarray, tol: float) -> bool:
    """The Moore–Spence residual test: stationarity max|g/m| ≤ tol, |Hv| ≤ 1e-9, |cᵀMv − 1| ≤ 1e-12."""
    n = mass.size
    return bool(np.max(np.abs(F[:n] / mass)) <= tol and np.max(np.abs(F[n:2 * n])) <= 1e-9
                and abs(F[2 * n]) <= 1e-12)


def fold_converged_at_floor(F: np.ndarray, dX: np.ndarray, J: np.ndarray, X: np.ndarray, mass: np.ndarray,
                            tol: float) -> bool:
    """:func:`fold_converged` with the stationarity within its rounding floor
    (:func:`~actuator_design.reduced.linalg.within_rounding_floor`), after a Newton step ``dX`` below
    :data:`~actuator_design.reduced.linalg.FLOOR_STEP` from X (residual F, Jacobian J, whose leading
    n × n block is the Hessian): a graded mesh's small end elements."""
    n = mass.size
    return bool(float(np.max(np.abs(dX))) <= FLOOR_STEP and np.max(np.abs(F[n:2 * n])) <= 1e-9
                and abs(F[2 * n]) <= 1e-12 and within_rounding_floor(F[:n], J[:n, :n], X[:n], mass, tol))


def locate_fold(system: ReducedSystem, P: np.ndarray, u: np.ndarray, lam: float,
                v: Optional[np.ndarray] = None, *, others: Sequence[float] = (), tol: float = 1e-10,
                max_iter: int = 30,
                path: Optional[Callable[[float], Tuple[np.ndarray, np.ndarray]]] = None) -> FoldPoint:
    """Newton on the Moore–Spence system from an approximate fold (u, λ).

    Parameters
    ----------
    system : ReducedSystem
        Its first name is the folding parameter λ; further names (fold curves) are held at
        ``others``.
    P : ndarray, shape (n_P,)
        NLP parameters (the entries the names control are ignored).
    u : ndarray, shape (n,)
        Free unknowns near the fold.
    lam : float
    v : ndarray (n,), optional
        Null-vector guess; default the eigenvector of (H, M) whose eigenvalue is closest to zero.
    others : sequence of float
        Values of the further parameters.
    tol : float
        Stationarity tolerance (max_i |g_i| / m_i).
    max_iter : int
    path : callable, optional
        λ -> (p (k,), dp/dλ (k,)): the values of all k system parameters along a curve and their
        exact derivatives. Then λ is the curve's coordinate and ``others`` is ignored.

    Returns
    -------
    FoldPoint
    """
    n, mass = system.n, system.mass
    if path is None:
        fixed = np.concatenate([[lam], np.asarray(others, float)])

        def path(lam_):
            fixed[0] = lam_
            return fixed, None  # λ is the first parameter itself

    u = np.asarray(u, float).copy()
    if v is None:
        ev = system.evaluator(P)
        v = null_vector(ev(u, path(lam)[0])[1].copy(), mass)
    v = np.asarray(v, float)
    c = v / float(v @ (mass * v))
    fn = system.f_fold

    def evaluate(X):
        values, slope = path(X[n])
        F, J, Fp = fn(X[:n], values, X[n + 1:], c, P)
        J = np.array(J)
        if slope is not None:  # chain rule: ∂F/∂λ = Σ_i p_i' ∂F/∂p_i
            J[:, n] = J[:, n] * slope[0] + np.asarray(Fp).reshape(2 * n + 1, -1) @ slope[1:]
        return np.asarray(F).ravel(), J

    X0 = np.concatenate([u, [lam], v])
    last = {}

    def evaluate_kept(X):
        F, J = evaluate(X)
        last["X"], last["J"] = X, J
        return F, J

    def floor_step(F, dX):
        return fold_converged_at_floor(F, dX, last["J"], last["X"], mass, tol)

    X, ok, it = newton(evaluate_kept, X0, lambda X, F: fold_converged(F, mass, tol), max_iter,
                       converged_after_step=floor_step)
    return FoldPoint(X[:n].copy(), float(X[n]), X[n + 1:].copy(), ok, it)
