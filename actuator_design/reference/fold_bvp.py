"""A fold of the continuous rod by scipy's collocation BVP solver: an independent reference.

At a quadratic fold in a parameter λ the equilibrium (EL) and its Jacobi equation (Q) have a
non-trivial solution together (THEORY §7): with y = (θ, M, x, y, η, P) of
:func:`actuator_design.reference.shooting_model._make_rhs` (variational form) and λ unknown,

    θ(0) = θ0,  x(0) = y(0) = 0,  M(1) = m,      (the equilibrium)
    η(0) = 0,   P(1) = 0,                        (the Jacobi field)
    w' = η²,  w(0) = 0,  w(1) = 1                (its normalisation ∫η² ds = 1)

is a two-point BVP with one unknown parameter, solved by :func:`scipy.integrate.solve_bvp`
(4th-order collocation with its own mesh control, residual tolerance ``tol``). Plain shooting
(:mod:`.shooting`) is the usual reference; at h ≳ 7 its tip is so sensitive to θ'(0) that a warm
start jumps branches, and a BVP solver is the robust independent method there. numpy/scipy only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_bvp

from actuator_design.reference.shooting_model import ShootingParams, _eval_profile

__all__ = ["BVPFold", "fold_by_bvp"]


@dataclass
class BVPFold:
    """lam : the fold's parameter value; converged : solve_bvp's success; message : its text;
    s, theta : the fold's state on solve_bvp's final mesh."""

    lam: float
    converged: bool
    message: str
    s: np.ndarray
    theta: np.ndarray


def _rhs(s: np.ndarray, Y: np.ndarray, q: ShootingParams, b: np.ndarray) -> np.ndarray:
    """(EL) and (Q) in first-order form, vectorised over s (the same equations as
    :func:`.shooting_model._make_rhs`, which works point by point)."""
    th, eta, P = Y[0], Y[4], Y[5]
    M = Y[1]
    psi = th + _eval_profile(q.alpha, s) - q.phi
    nx, ny = q.fx + q.qx * (1.0 - s), q.fy + q.qy * (1.0 - s)
    ct, st = np.cos(th), np.sin(th)
    dM = q.h ** 2 * np.sin(2.0 * psi) - ny * ct + nx * st
    Q = 2.0 * q.h ** 2 * np.cos(2.0 * psi) + nx * ct + ny * st
    if q.h_r:
        u = th + _eval_profile(q.beta, s) - q.phi
        dM, Q = dM + q.h_r * np.sin(u), Q + q.h_r * np.cos(u)
    return np.vstack([M / b, dM, ct, st, P / b, Q * eta, eta ** 2])


def fold_by_bvp(params_of: Callable[[float], ShootingParams], lam_guess: float, s: np.ndarray,
                theta: np.ndarray, dtheta: np.ndarray, eta: np.ndarray, deta: np.ndarray, *,
                tol: float = 1e-8, max_nodes: int = 100000) -> BVPFold:
    """Solve the fold BVP from a guess of the state and of the Jacobi field near the fold.

    Parameters
    ----------
    params_of : callable
        λ -> ShootingParams of the scene at λ.
    lam_guess : float
    s : ndarray, shape (m,)
        Initial mesh on [0, 1] (increasing, s[0] = 0, s[-1] = 1).
    theta, dtheta : ndarray, shape (m,)
        Guess of θ (rad) and θ' on ``s`` (any branch point of view: the solver decides).
    eta, deta : ndarray, shape (m,)
        Guess of the Jacobi field and its derivative (any scale: normalised to ∫η² = 1).
    tol, max_nodes : float, int
        :func:`scipy.integrate.solve_bvp`'s residual tolerance and node bound.

    Returns
    -------
    BVPFold
    """
    b = _eval_profile(params_of(float(lam_guess)).b, s)
    w = np.concatenate(([0.0], np.cumsum(0.5 * (eta[1:] ** 2 + eta[:-1] ** 2) * np.diff(s))))
    scale = 1.0 / np.sqrt(w[-1])  # ∫η² = 1 (its sign and scale are free)
    dx = np.cos(theta)
    x = np.concatenate(([0.0], np.cumsum(0.5 * (dx[1:] + dx[:-1]) * np.diff(s))))
    dy = np.sin(theta)
    y = np.concatenate(([0.0], np.cumsum(0.5 * (dy[1:] + dy[:-1]) * np.diff(s))))
    Y0 = np.vstack([theta, b * dtheta, x, y, scale * eta, b * scale * deta, scale ** 2 * w])

    def fun(ss, Y, p):
        q = params_of(float(p[0]))
        return _rhs(ss, Y, q, _eval_profile(q.b, ss))

    def bc(ya, yb, p):
        q = params_of(float(p[0]))
        return np.array([ya[0] - q.theta0, ya[2], ya[3], yb[1] - q.m, ya[4], yb[5], ya[6], yb[6] - 1.0])

    sol = solve_bvp(fun, bc, s, Y0, p=[float(lam_guess)], tol=tol, max_nodes=max_nodes)
    return BVPFold(float(sol.p[0]), bool(sol.success), str(sol.message), sol.x, sol.y[0])
