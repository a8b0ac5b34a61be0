"""Independent shooting solver and Jacobi stability test for uniform-field scenes.

The model (parameters, Q(s), right-hand side) lives in :mod:`.shooting_model`, the Jacobi/Sturm
test in :mod:`.jacobi`; this module holds the solver and re-exports all public names.

This module is one of the project's *independent references*: numpy/scipy only, no casadi and
nothing from :mod:`actuator_design` except that the profiles b(s), α(s) may be
:class:`actuator_design.model.profiles.Profile` objects (any callable of s, or a float, works).

Model (THEORY §4–§5, generalised to tip force, tip moment, distributed dead load, graded
stiffness and fibre angle).  All quantities are dimensionless (lengths / ℓ, energies / (B₀/ℓ),
forces / (B₀/ℓ²), distributed loads / (B₀/ℓ³), B₀ the reference bending stiffness):

    Ê[θ] = ½∫₀¹ b θ'² ds − h² ∫₀¹ cos²(θ + α − φ) ds − f·r(1) − m θ(1) − ∫₀¹ q·r ds,     (E)

plus, for a hard-magnetic rod (THEORY §9), −h_r ∫₀¹ cos(θ + β − φ) ds, which adds
h_r sin(θ + β − φ) to M' in (EL) and h_r cos(θ + β − φ) to Q in (Q).

with r(s) = ∫₀ˢ (cos θ, sin θ) dσ, θ(0) = θ0, f = (fx, fy) the dead tip force, m the tip moment,
q = (qx, qy) a uniform dead distributed load.  Using ∫₀¹ q·r ds = ∫₀¹ (1 − s) q·r'(s) ds,

    Ê[θ] = ∫₀¹ [ ½ b θ'² − h² cos²(θ + α − φ) − n(s)·(cos θ, sin θ) ] ds − m θ(1),         (E')

with the internal force n(s) = f + q (1 − s).  Its Euler–Lagrange boundary-value problem is

    (b θ')' − h² sin(2(θ + α − φ)) + n_y cos θ − n_x sin θ = 0,  θ(0) = θ0,  b(1) θ'(1) = m, (EL)

which for b ≡ 1, α ≡ 0, f = (0, p), m = 0, q = 0 is THEORY §5's
θ'' − h² sin(2(θ − φ)) + p cos θ = 0.  The second variation is (THEORY §7, generalised)

    δ²Ê = ∫₀¹ b η'² + Q(s) η² ds,  Q = 2h² cos(2(θ + α − φ)) + n_x cos θ + n_y sin θ,       (Q)

obtained by differentiating (E') twice: ∂²/∂θ² of −h² cos²ψ is 2h² cos 2ψ, of −n·(cos θ, sin θ)
is n_x cos θ + n_y sin θ (for THEORY §5: Q = 2h² cos(2(θ − φ)) + p sin θ).  It is the
linearisation of (EL): the Jacobi equation is (b η')' = Q η.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Optional, Tuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.optimize import newton as _secant

from actuator_design.reference.jacobi import JacobiResult, jacobi_morse_index, sturm_morse_index
from actuator_design.reference.shooting_model import (ATOL, RTOL, _EPS, ShootingParams, _eval_profile,
                                                      _make_rhs, jacobi_coefficient)

__all__ = [
    "ShootingParams",
    "ShootingSolution",
    "JacobiResult",
    "shoot",
    "solve_shooting",
    "energy_functional",
    "jacobi_coefficient",
    "sturm_morse_index",
    "jacobi_morse_index",
]

@dataclass(eq=False)
class ShootingSolution:
    """A shot (or, if ``converged``, an equilibrium) of the boundary-value problem (EL).

    Attributes
    ----------
    params : ShootingParams
    gamma : float
        Initial curvature θ'(0) (dimensionless).
    ode : scipy.integrate.OdeSolution
        Dense output of the state (θ, M = b θ', x, y[, η, P]) on s ∈ [0, 1].
    s_nodes : ndarray, shape (n_steps + 1,)
        Step points of the integrator.
    residual : float
        M(1) − m, the violation of the free-end condition b(1) θ'(1) = m.
    dresidual : float or None
        d residual / d gamma (= b(0) × the Jacobi field P(1)) when it was integrated.
    converged : bool
        |residual| ≤ tol (tol of :func:`solve_shooting`, default 1e-10 · max(1, |m|)).
    iterations : int
        Number of shots spent by the root finder (0 for a bare :func:`shoot`).
    method : str
        How gamma was found ("shot", "newton+brentq", "newton", "brentq", "secant", ...).
    """

    params: ShootingParams
    gamma: float
    ode: Any
    s_nodes: np.ndarray
    residual: float
    dresidual: Optional[float] = None
    converged: bool = False
    iterations: int = 0
    method: str = "shot"

    def _state(self, s, i):
        out = self.ode(np.asarray(s, dtype=float))[i]
        return float(out) if np.ndim(out) == 0 else out

    def theta(self, s):
        """Tangent angle θ(s) [rad]; s float or array of shape (n,) → same shape."""
        return self._state(s, 0)

    def moment(self, s):
        """Bending moment M(s) = b(s) θ'(s) (dimensionless)."""
        return self._state(s, 1)

    def dtheta(self, s):
        """Curvature θ'(s) = M(s)/b(s)."""
        sa = np.asarray(s, dtype=float)
        out = np.asarray(self.ode(sa)[1]) / _eval_profile(self.params.b, sa)
        return float(out) if np.ndim(out) == 0 else out

    def x(self, s):
        """x(s) (units of ℓ)."""
        return self._state(s, 2)

    def y(self, s):
        """y(s) (units of ℓ)."""
        return self._state(s, 3)

    @property
    def tip(self) -> Tuple[float, float, float]:
        """(x(1), y(1), θ(1)) — tip position (units of ℓ) and tip angle [rad]."""
        end = self.ode(1.0)
        return float(end[2]), float(end[3]), float(end[0])

    @property
    def tip_x(self) -> float:
        return self.tip[0]

    @property
    def tip_y(self) -> float:
        return self.tip[1]

    @property
    def tip_angle(self) -> float:
        return self.tip[2]

    @cached_property
    def energy(self) -> float:
        """Dimensionless energy Ê of eq. (E), by Gauss–Legendre quadrature on every solver step."""
        return energy_functional(self.theta, self.dtheta, self.params, breakpoints=self.s_nodes)


def energy_functional(theta, dtheta, params: ShootingParams, breakpoints=None, order: int = 8,
                      n_panels: int = 256) -> float:
    """Dimensionless energy Ê[θ] of eq. (E) (THEORY §4–§5) for any admissible θ(s).

    Ê = ∫₀¹ [½ b θ'² − h² cos²(θ + α − φ) − n(s)·(cos θ, sin θ)] ds − m θ(1)   (eq. E'),
    which equals ½∫bθ'² − h²∫cos²(θ+α−φ) − f·r(1) − m θ(1) − ∫q·r ds.

    Parameters
    ----------
    theta, dtheta : callable
        θ(s) [rad] and θ'(s), vectorised over arrays of s of shape (n,).
    params : ShootingParams
    breakpoints : array_like, shape (k,), optional
        Panel boundaries in [0, 1] (e.g. the integrator's steps); default ``n_panels`` equal panels.
    order : int
        Gauss–Legendre points per panel.

    Returns
    -------
    float
        Ê (energy / (B₀/ℓ)).
    """
    if breakpoints is None:
        breakpoints = np.linspace(0.0, 1.0, n_panels + 1)
    edges = np.unique(np.clip(np.asarray(breakpoints, dtype=float), 0.0, 1.0))
    edges = np.unique(np.concatenate([[0.0], edges, [1.0]]))
    xg, wg = np.polynomial.legendre.leggauss(order)
    a, bnd = edges[:-1, None], edges[1:, None]
    s = (0.5 * (a + bnd) + 0.5 * (bnd - a) * xg[None, :]).ravel()
    w = (0.5 * (bnd - a) * wg[None, :]).ravel()
    th = np.asarray(theta(s), dtype=float)
    dth = np.asarray(dtheta(s), dtype=float)
    bb = _eval_profile(params.b, s)
    ta = th + _eval_profile(params.alpha, s)
    c2, s2 = params.cos2phi, params.sin2phi
    cos2psi = np.cos(2.0 * ta) * c2 + np.sin(2.0 * ta) * s2
    cos_sq = 0.5 * (1.0 + cos2psi)  # cos²(θ+α−φ)
    nx = params.fx + params.qx * (1.0 - s)
    ny = params.fy + params.qy * (1.0 - s)
    integrand = 0.5 * bb * dth**2 - params.h**2 * cos_sq - (nx * np.cos(th) + ny * np.sin(th))
    if params.h_r:  # THEORY §9: −h_r cos(θ + β − φ)
        integrand = integrand - params.h_r * np.cos(th + _eval_profile(params.beta, s) - params.phi)
    return float(np.dot(w, integrand) - params.m * float(theta(1.0)))


def _integrate(gamma: float, params: ShootingParams, variational: bool = False,
               rtol: float = RTOL, atol: float = ATOL):
    b0 = float(_eval_profile(params.b, np.array(0.0)))
    y0 = [float(params.theta0), b0 * float(gamma), 0.0, 0.0]
    if variational:
        y0 += [0.0, b0]  # η(0) = 0, b η'(0) = b(0): η = ∂θ/∂γ
    sol = solve_ivp(_make_rhs(params, variational), (0.0, 1.0), y0, method="DOP853",
                    rtol=rtol, atol=atol, dense_output=True)
    if not sol.success:
        raise RuntimeError(f"shooting integration failed: {sol.message}")
    return sol


def shoot(gamma: float, params: ShootingParams, *, variational: bool = False) -> ShootingSolution:
    """Integrate the initial-value problem of (EL) from θ(0) = θ0, θ'(0) = gamma over s ∈ [0, 1].

    Uses ``solve_ivp(method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True)`` on the state
    (θ, M = b θ', x, y); with ``variational=True`` also the Jacobi field (η, P = b η') with
    η(0) = 0, P(0) = b(0), so that ∂M(1)/∂gamma = P(1).

    Parameters
    ----------
    gamma : float
        Initial curvature θ'(0).
    params : ShootingParams

    Returns
    -------
    ShootingSolution
        With ``residual = M(1) − m``; ``converged`` is True when |residual| ≤ 1e-10 · max(1, |m|).
    """
    sol = _integrate(gamma, params, variational)
    end = sol.y[:, -1]
    res = float(end[1] - params.m)
    return ShootingSolution(
        params=params,
        gamma=float(gamma),
        ode=sol.sol,
        s_nodes=np.asarray(sol.t),
        residual=res,
        dresidual=float(end[5]) if variational else None,
        converged=abs(res) <= 1e-10 * max(1.0, abs(params.m)),
        iterations=0,
        method="shot",
    )


def solve_shooting(params: ShootingParams, gamma_guess: float = 0.0, *,
                   bracket: Optional[Tuple[float, float]] = None, tol: Optional[float] = None,
                   maxiter: int = 50) -> ShootingSolution:
    """Find gamma = θ'(0) with M(1) = m (free-end condition of (EL)) and return the equilibrium.

    Strategy: with ``bracket`` given (a sign change of M(1) − m), ``brentq`` on it.  Otherwise
    damped Newton from ``gamma_guess`` with the exact derivative ∂M(1)/∂γ from the variational
    (Jacobi) equation (steps limited to max(1, |γ|), backtracking on |M(1) − m|, at most 15
    iterations); the root is then enclosed in a small bracket and polished with ``brentq``
    (method "newton+brentq"), so the result is a verified sign change.  If Newton fails, a sign change is searched for at
    gamma_guess ± 0.05·max(1, |gamma_guess|)·2^j and refined by ``brentq`` ("bracket+brentq");
    a secant iteration (``scipy.optimize.newton``) is the last resort.
    Which equilibrium is found depends on the guess (there may be several, THEORY §8).

    Parameters
    ----------
    params : ShootingParams
    gamma_guess : float
        Initial guess for θ'(0).
    bracket : (float, float), optional
        Interval of gamma with a sign change of the residual.
    tol : float, optional
        Residual tolerance on |M(1) − m|; default 1e-10 · max(1, |m|).
    maxiter : int
        Maximum Newton / secant iterations.

    Returns
    -------
    ShootingSolution
        ``converged`` tells whether |residual| ≤ tol; ``iterations`` counts shots.
    """
    if tol is None:
        tol = 1e-10 * max(1.0, abs(params.m))
    n_shots = 0

    def resid(g: float) -> float:
        nonlocal n_shots
        n_shots += 1
        sol = _integrate(g, params)
        return float(sol.y[1, -1] - params.m)

    def finish(g: float, method: str) -> ShootingSolution:
        out = shoot(g, params)
        out.converged = bool(np.isfinite(out.residual) and abs(out.residual) <= tol)
        out.iterations = n_shots + 1
        out.method = method
        return out

    if bracket is not None:
        a, b = float(bracket[0]), float(bracket[1])
        g = brentq(resid, a, b, xtol=1e-300, rtol=4.0 * _EPS, maxiter=200)
        return finish(g, "brentq")

    # Damped Newton with the exact derivative (variational equation) and backtracking on |r|.
    def rdr(g_: float) -> Tuple[float, float]:
        nonlocal n_shots
        n_shots += 1
        sol_ = _integrate(g_, params, variational=True)
        return float(sol_.y[1, -1] - params.m), float(sol_.y[5, -1])

    g = float(gamma_guess)
    newton_ok = False
    r, dr = rdr(g)
    for _ in range(min(maxiter, 15)):  # quadratic convergence or give up early
        if not np.isfinite(r):
            break
        if abs(r) <= 0.01 * tol:
            newton_ok = True
            break
        if not np.isfinite(dr) or dr == 0.0:
            break
        step = -r / dr
        lim = max(1.0, abs(g))
        if abs(step) > lim:
            step = math.copysign(lim, step)
        if abs(step) <= 4.0 * _EPS * max(1.0, abs(g)):
            newton_ok = abs(r) <= tol
            break
        for _ in range(8):  # backtracking: accept the first step that decreases |r|
            r_new, dr_new = rdr(g + step)
            if np.isfinite(r_new) and abs(r_new) < abs(r):
                break
            step *= 0.5
        else:
            break
        g, r, dr = g + step, r_new, dr_new
    if not newton_ok:
        # Fallback 1: expanding search for a sign change around the guess, then brentq.
        g0 = float(gamma_guess)
        r_g0 = resid(g0)
        d = 0.05 * max(1.0, abs(g0))
        prev = {+1: (g0, r_g0), -1: (g0, r_g0)}
        for _ in range(14):
            for side in (+1, -1):
                gb = g0 + side * d
                rb = resid(gb)
                ga, ra = prev[side]
                if np.isfinite(rb) and np.isfinite(ra) and ra * rb <= 0.0:
                    lo, hi = (ga, gb) if ga < gb else (gb, ga)
                    g = brentq(resid, lo, hi, xtol=1e-300, rtol=4.0 * _EPS, maxiter=200)
                    return finish(g, "bracket+brentq")
                prev[side] = (gb, rb)
            d *= 2.0
        # Fallback 2: secant iteration.
        try:
            g = float(_secant(resid, g0, x1=g0 * 1.01 + 1e-3, tol=1e-15, maxiter=maxiter))
            method = "secant"
        except (RuntimeError, ArithmeticError):
            return finish(g, "failed")
    else:
        method = "newton"
    # Enclose the root in a small bracket and polish with brentq (verified sign change).
    r0 = resid(g)
    if r0 == 0.0:
        return finish(g, method)
    delta = 1e-13 * max(1.0, abs(g))
    if np.isfinite(dr) and dr != 0.0:  # Newton's own error estimate |r/dr|, with margin
        delta = max(delta, 4.0 * abs(r0 / dr))
    for _ in range(6):
        for gb in (g - delta, g + delta):
            rb = resid(gb)
            if np.isfinite(rb) and rb * r0 < 0.0:
                lo, hi = (gb, g) if gb < g else (g, gb)
                g2 = brentq(resid, lo, hi, xtol=1e-300, rtol=4.0 * _EPS, maxiter=200)
                return finish(g2, method + "+brentq")
            if rb == 0.0:
                return finish(gb, method)
        delta *= 10.0
    return finish(g, method)
