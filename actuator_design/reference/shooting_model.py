"""The uniform-field rod model of the reference shooting solver: its parameters, the Jacobi
coefficient Q(s) and the first-order right-hand side of the Euler–Lagrange equation.

Equations (E), (EL) and (Q) are stated in :mod:`actuator_design.reference.shooting`; numpy only
(an independent reference: nothing from the rest of :mod:`actuator_design`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Optional, Tuple, Union

import numpy as np

__all__ = ["ShootingParams", "jacobi_coefficient", "ProfileLike", "RTOL", "ATOL"]

ProfileLike = Union[float, Callable[[Any], Any]]
RTOL = 1e-12
ATOL = 1e-13
_EPS = np.finfo(float).eps


def _snap(v: float) -> float:
    """Round trigonometric values within 4 ε of 0 to exactly 0.

    ``math.sin(2 * (math.pi / 2))`` is 1.2e-16, not 0: snapping makes φ = π/2 (or any multiple of
    π/4) given as a float describe the exactly symmetric scene, so that e.g. the straight rod is an
    exact solution and the mirror symmetry θ → −θ holds bit for bit.
    """
    return 0.0 if abs(v) < 4.0 * _EPS else v


def _as_scalar_fun(p: ProfileLike) -> Tuple[Callable[[float], float], Optional[float]]:
    """Return (scalar function of s, constant value or None)."""
    if callable(p):
        return (lambda s: float(np.asarray(p(s), dtype=float))), None
    c = float(p)
    return (lambda s: c), c


def _eval_profile(p: ProfileLike, s: np.ndarray) -> np.ndarray:
    """Evaluate a profile (float or callable) on an array of s; returns an array of shape s."""
    s = np.asarray(s, dtype=float)
    if callable(p):
        return np.broadcast_to(np.asarray(p(s), dtype=float), s.shape).astype(float)
    return np.full(s.shape, float(p))


@dataclass
class ShootingParams:
    """Scene parameters of the uniform-field rod (all dimensionless, THEORY §5).

    Attributes
    ----------
    h : float
        Field magnitude, h² = μ0 χ̄ H² A ℓ² / (2 B₀).
    phi : float
        Field angle to the undeformed rod axis [rad].
    fx, fy : float
        Dead tip force / (B₀/ℓ²); THEORY's p is ``fy``.
    m : float
        Tip moment / (B₀/ℓ) (boundary condition b(1) θ'(1) = m).
    qx, qy : float
        Uniform distributed dead load / (B₀/ℓ³) (e.g. weight).
    theta0 : float
        Clamp angle θ(0) [rad].
    alpha : float or callable
        Fibre angle α(s) [rad]; a float or a callable of s (e.g. a ``Profile``); default 0.
    b : float or callable
        Relative bending stiffness b(s) = B(s)/B₀ > 0; float or callable; default 1.
    h_r : float
        Hard-magnetic group h_r = μ0 M_r H A ℓ² / B₀ (THEORY §9); default 0.
    beta : float or callable
        Remanent magnetisation angle β(s) to the tangent [rad]; default 0.
    """

    h: float = 0.0
    phi: float = 0.0
    fx: float = 0.0
    fy: float = 0.0
    m: float = 0.0
    qx: float = 0.0
    qy: float = 0.0
    theta0: float = 0.0
    alpha: ProfileLike = 0.0
    b: ProfileLike = 1.0
    h_r: float = 0.0
    beta: ProfileLike = 0.0

    # -- derived quantities (not fields) ---------------------------------------------------
    @property
    def cos2phi(self) -> float:
        return _snap(math.cos(2.0 * self.phi))

    @property
    def sin2phi(self) -> float:
        return _snap(math.sin(2.0 * self.phi))


def jacobi_coefficient(theta, s, params: ShootingParams):
    """Coefficient Q(s) of the second variation / Jacobi equation, eq. (Q) of the module docstring.

    Q = 2h² cos(2(θ + α − φ)) + h_r cos(θ + β − φ) + n_x cos θ + n_y sin θ,
    n(s) = f + q (1 − s)   (THEORY §7, §9).

    Parameters
    ----------
    theta : array_like, shape (n,)
        Tangent angle θ(s) [rad].
    s : array_like, shape (n,)
        Arc length in [0, 1].
    params : ShootingParams

    Returns
    -------
    Q : ndarray, shape (n,)
    """
    theta = np.asarray(theta, dtype=float)
    s = np.asarray(s, dtype=float)
    ta = theta + _eval_profile(params.alpha, s)
    c2, s2 = params.cos2phi, params.sin2phi
    cos2psi = np.cos(2.0 * ta) * c2 + np.sin(2.0 * ta) * s2  # cos(2(θ+α−φ))
    nx = params.fx + params.qx * (1.0 - s)
    ny = params.fy + params.qy * (1.0 - s)
    hard = params.h_r * np.cos(theta + _eval_profile(params.beta, s) - params.phi)
    return 2.0 * params.h**2 * cos2psi + hard + nx * np.cos(theta) + ny * np.sin(theta)


def _make_rhs(params: ShootingParams, variational: bool):
    """Right-hand side of the first-order form of (EL) (+ its linearisation).

    State y = (θ, M, x, y[, η, P]) with M = b θ', P = b η':
        θ' = M/b,  M' = h² sin(2(θ+α−φ)) + h_r sin(θ+β−φ) − n_y cos θ + n_x sin θ,
        x' = cos θ,  y' = sin θ,
        η' = P/b,  P' = Q η                                        (EL), (Q)
    """
    h2 = float(params.h) ** 2
    c2, s2 = params.cos2phi, params.sin2phi
    fx, fy, qx, qy = (float(params.fx), float(params.fy), float(params.qx), float(params.qy))
    bfun, bconst = _as_scalar_fun(params.b)
    afun, aconst = _as_scalar_fun(params.alpha)
    h_r, phi = float(params.h_r), float(params.phi)
    bfun_r, bconst_r = _as_scalar_fun(params.beta)
    sin, cos = math.sin, math.cos

    def rhs(s, y):
        th = y[0]
        b = bconst if bconst is not None else bfun(s)
        ta = th + (aconst if aconst is not None else afun(s))
        nx = fx + qx * (1.0 - s)
        ny = fy + qy * (1.0 - s)
        sn2, cs2 = sin(2.0 * ta), cos(2.0 * ta)
        ct, st = cos(th), sin(th)
        # sin(2(θ+α−φ)) = sin 2(θ+α) cos 2φ − cos 2(θ+α) sin 2φ
        dM = h2 * (sn2 * c2 - cs2 * s2) - ny * ct + nx * st  # (EL)
        if h_r:  # the remanent torque of THEORY §9
            u = th + (bconst_r if bconst_r is not None else bfun_r(s)) - phi
            dM += h_r * sin(u)
        if not variational:
            return [y[1] / b, dM, ct, st]
        Q = 2.0 * h2 * (cs2 * c2 + sn2 * s2) + nx * ct + ny * st  # (Q)
        if h_r:
            Q += h_r * cos(u)
        return [y[1] / b, dM, ct, st, y[5] / b, Q * y[4]]

    return rhs


