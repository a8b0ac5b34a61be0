"""Closed-form reference results of THEORY.md §6 (independent of the NLP machinery).

This module is one of the project's *independent references*: it uses numpy/scipy only and does
not import casadi or any other part of :mod:`actuator_design`.

Contents
--------
lowload_stiffness
    Dimensionless low-load tip stiffness s(h) of the rod in an axial field (φ = 0), THEORY §6,
    evaluated stably for all h ≥ 0.
critical_field_transverse
    Critical fields h_crit^(m) = (2m − 1) π / (2√2) of the transverse scene (φ = π/2, p = 0).
transverse_mode
    The buckled mode m of the transverse scene in closed form (Jacobi elliptic functions).

Conventions (THEORY §5): lengths are scaled by ℓ, so s ∈ [0, 1] and the tip displacements are
in units of ℓ; h is the dimensionless field, h² = μ0 χ̄ H² A ℓ² / (2B).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import List

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipj, ellipkm1

__all__ = [
    "lowload_stiffness",
    "critical_field_transverse",
    "transverse_mode",
    "TransverseMode",
]


# ---------------------------------------------------------------------------------------------
# Low-load stiffness  s(h) = 4h³ / (2h − √2 tanh(√2 h))         (THEORY §6, paper eq. Stiffness)
# ---------------------------------------------------------------------------------------------
#
# With k = √2 h and x = k²:   s = k² / (1 − tanh(k)/k) = 1 / D(x),
#     D(x) = (1 − tanh(k)/k) / k² = 1/3 − 2x/15 + 17x²/315 − 62x³/2835 + 1382x⁴/155925 − ...
# (from tanh k = Σ_{n≥1} 2^{2n}(2^{2n} − 1) B_{2n} k^{2n−1} / (2n)!).  The reciprocal series
#     s(x) = 3 + 6x/5 − 2x²/350 + ...
# is analytic in x for |x| < y1² ≈ 20.19, where y1 ≈ 4.4934 is the first positive root of
# tan y = y (the zeros of k − tanh k are k = 0 and k = ±i y_j; tanh's poles are zeros of s, not
# singularities).  Its coefficients therefore decay like (−1/20.19)ⁿ and it has no cancellation.
# We use it for k ≤ _K_SWITCH (= 1.5, ratio of successive terms ≤ 0.112, 22 terms → truncation
# below 1e-18 relative).  For k > 1.5 the direct form k²/(1 − tanh(k)/k) loses at most a factor
# 1/(1 − tanh(1.5)/1.5) ≈ 2.5 to cancellation, i.e. a relative error of a few ε.

_K_SWITCH = 1.5
_N_SERIES = 22


def _stiffness_series_coefficients(n_terms: int) -> List[float]:
    """Coefficients c_j of s = Σ_j c_j x^j, x = k², computed in exact rational arithmetic."""
    n_bern = 2 * (n_terms + 2)
    bern = [Fraction(0)] * (n_bern + 1)
    bern[0] = Fraction(1)
    for n in range(1, n_bern + 1):  # standard recurrence Σ_{k=0}^{n} C(n+1, k) B_k = 0
        bern[n] = -sum(math.comb(n + 1, k) * bern[k] for k in range(n)) / (n + 1)
    # tanh(k)/k = Σ_{n≥1} T_n k^{2n−2}
    tan_coef = [
        Fraction(2 ** (2 * n) * (2 ** (2 * n) - 1)) * bern[2 * n] / math.factorial(2 * n)
        for n in range(1, n_terms + 3)
    ]
    # D(x) = (1 − tanh(k)/k)/x = −Σ_{n≥2} T_n x^{n−2}
    d = [-t for t in tan_coef[1:]]
    c = [Fraction(0)] * n_terms
    c[0] = 1 / d[0]
    for n in range(1, n_terms):  # reciprocal of a power series
        c[n] = -sum(d[j] * c[n - j] for j in range(1, n + 1)) / d[0]
    return [float(v) for v in c]


_S_COEF = np.array(_stiffness_series_coefficients(_N_SERIES))


def lowload_stiffness(h):
    """Dimensionless low-load tip stiffness of the rod in an axial field (THEORY §6).

    s(h) = 4h³ / (2h − √2 tanh(√2 h)) = (∂v1/∂p at p = 0)⁻¹ for φ = 0, b ≡ 1, α ≡ 0.
    The dimensional tip stiffness is K = s · B / ℓ³.

    Evaluated stably: with k = √2 h, a power series in k² for k ≤ 1.5 (s → 3 as h → 0) and
    s = k² / (1 − tanh(k)/k) otherwise (no 0/0 for small h, no overflow of cosh/sinh for large h;
    s ≈ k²/(1 − 1/k) once tanh(k) rounds to 1).  Relative error below 1e-14 for all h ≥ 0
    (checked against 60-digit arithmetic in ``tests/test_reference.py``).

    Parameters
    ----------
    h : float or array_like, shape (...)
        Dimensionless field magnitude, h ≥ 0 (THEORY §5).

    Returns
    -------
    s : float or ndarray, shape (...)
        Dimensionless stiffness, s ≥ 3 (a Python float for scalar input).

    Raises
    ------
    ValueError
        If any h is negative or NaN.
    """
    h_arr = np.asarray(h, dtype=float)
    if np.any(np.isnan(h_arr)) or np.any(h_arr < 0):
        raise ValueError(f"lowload_stiffness: h must be >= 0 (got {h!r})")
    k = math.sqrt(2.0) * h_arr
    out = np.empty_like(k)
    small = k <= _K_SWITCH
    if np.any(small):
        x = k[small] ** 2
        acc = np.zeros_like(x)
        for c in _S_COEF[::-1]:  # Horner, s = Σ c_j x^j   (THEORY §6 series for small k)
            acc = acc * x + c
        out[small] = acc
    big = ~small
    if np.any(big):
        kb = k[big]
        out[big] = kb * kb / (1.0 - np.tanh(kb) / kb)  # s = k²/(1 − tanh(k)/k)   (THEORY §6)
    if out.ndim == 0:
        return float(out)
    return out


# ---------------------------------------------------------------------------------------------
# Transverse field, φ = π/2, p = 0:   θ'' + h² sin 2θ = 0,  θ(0) = 0, θ'(1) = 0   (THEORY §6)
# ---------------------------------------------------------------------------------------------


def critical_field_transverse(m=1):
    """Critical field of mode m in a transverse field (THEORY §6).

    h_crit^(m) = (2m − 1) π / (2√2): the straight rod (φ = π/2, p = 0) bifurcates into the
    buckled mode m at h = h_crit^(m) (pitchfork, THEORY §8).

    Parameters
    ----------
    m : int or array_like of int, shape (...)
        Mode number, m ≥ 1.

    Returns
    -------
    h_crit : float or ndarray, shape (...)
        Dimensionless critical field.
    """
    m_arr = np.asarray(m)
    if np.any(m_arr < 1):
        raise ValueError(f"critical_field_transverse: mode m must be >= 1 (got {m!r})")
    out = (2.0 * m_arr - 1.0) * math.pi / (2.0 * math.sqrt(2.0))
    if np.ndim(out) == 0:
        return float(out)
    return out


@dataclass(frozen=True)
class TransverseMode:
    """Closed-form buckled mode m of the transverse scene (φ = π/2, p = 0), branch θ > 0 near s = 0.

    With w = √2 h and modulus k = sin β (parameter k² for scipy), THEORY §6:
        sin θ(s) = k sn(w s | k²),  cos θ(s) = dn(w s | k²),  θ'(s) = w k cn(w s | k²),
        w = (2m − 1) K(k²).

    Attributes
    ----------
    h : float
        Dimensionless field.
    mode : int
        Mode number m ≥ 1 (θ has m − 1 interior zeros; |θ(1)| = β).
    w : float
        √2 h.
    beta : float
        |θ(1)| = max |θ|, in (0, π/2) [rad].  For large h, β rounds to π/2 in floating point;
        use ``beta_complement``.
    beta_complement : float
        π/2 − β [rad], computed without cancellation (= arctan(cos β / sin β)); > 0 until
        cos β = exp(−(√2 h − ln 4)) underflows (h ≳ 500).
    k : float
        Elliptic modulus sin β.
    km1 : float
        Complementary parameter 1 − k² = cos² β (accurate when k → 1).
    K : float
        Complete elliptic integral of the first kind K(k²).
    u1 : float
        x(1) − 1 (units of ℓ).  u1 = π/(2K) − 1 for every mode (derivation in ``transverse_mode``).
    v1 : float
        y(1) (units of ℓ), positive on this branch: v1 = ln(cos β/(1 − sin β)) / ((2m − 1) K).
    gamma : float
        θ'(0) = w sin β (initial curvature, e.g. a shooting guess).
    theta1 : float
        θ(1) = (−1)^(m−1) β.
    """

    h: float
    mode: int
    w: float
    beta: float
    beta_complement: float
    k: float
    km1: float
    K: float
    u1: float
    v1: float
    gamma: float
    theta1: float

    def _reduced(self, s):
        """Reduce u = w s to r ∈ [0, K] using the quarter-period symmetries of sn, cn."""
        u = self.w * np.asarray(s, dtype=float)
        K = self.K
        r = np.mod(u, 4.0 * K)
        sign = np.where(r > 2.0 * K, -1.0, 1.0)  # sn(u + 2K) = −sn(u), cn(u + 2K) = −cn(u)
        r = np.where(r > 2.0 * K, r - 2.0 * K, r)
        second = r > K  # sn(2K − r) = sn(r), cn(2K − r) = −cn(r)
        r = np.where(second, 2.0 * K - r, r)
        return r, sign, second

    def theta(self, s):
        """Tangent angle θ(s) [rad].

        Parameters
        ----------
        s : float or array_like, shape (...)
            Arc length in [0, 1].

        Returns
        -------
        theta : float or ndarray, shape (...)

        Notes
        -----
        θ = atan2(k sn(u), dn(u)), u = w s (since cos θ = dn ≥ 0, THEORY §6).  For the upper half
        of each quarter period we use sn(K − v) = cd(v), dn(K − v) = k'/dn(v), so that
        θ = atan2(k cn(v), k'), which stays accurate when k → 1 (β → π/2).
        """
        r, sign, _ = self._reduced(s)
        m_par = 1.0 - self.km1
        kp = math.sqrt(self.km1)
        lower = r <= 0.5 * self.K
        # Clipping at 300 only acts when K > 600, i.e. 1 − k² < 1e-500 = 0 in double precision,
        # where sn = 1, cn = dn = 0 to machine precision (scipy's ellipj overflows beyond ~355).
        sn, cn, dn, _ = ellipj(np.minimum(np.where(lower, r, self.K - r), 300.0), m_par)
        th = np.where(lower, np.arctan2(self.k * sn, dn), np.arctan2(self.k * cn, kp))
        out = sign * th
        return float(out) if np.ndim(out) == 0 else out

    def dtheta(self, s):
        """Curvature θ'(s) = w k cn(w s | k²) (dimensionless, per unit ℓ).

        Parameters
        ----------
        s : float or array_like, shape (...)

        Returns
        -------
        dtheta : float or ndarray, shape (...)
        """
        r, sign, second = self._reduced(s)
        m_par = 1.0 - self.km1
        kp = math.sqrt(self.km1)
        lower = r <= 0.5 * self.K
        # Clipping at 300 only acts when K > 600, i.e. 1 − k² < 1e-500 = 0 in double precision,
        # where sn = 1, cn = dn = 0 to machine precision (scipy's ellipj overflows beyond ~355).
        sn, cn, dn, _ = ellipj(np.minimum(np.where(lower, r, self.K - r), 300.0), m_par)
        cn_r = np.where(lower, cn, kp * sn / dn)  # cn(K − v) = k' sd(v)
        cn_u = sign * np.where(second, -cn_r, cn_r)
        out = self.w * self.k * cn_u
        return float(out) if np.ndim(out) == 0 else out


def _K_of_logkm1(t: float) -> float:
    """K as a function of t = ln(1 − k²): accurate for k² → 1 (t → −∞) and without underflow."""
    if t < -700.0:
        # K = ln 4 − t/2 + O(e^t · t): exact in double precision for e^t < 1e-300.
        return math.log(4.0) - 0.5 * t
    return float(ellipkm1(math.exp(t)))


def transverse_mode(h, m=1) -> TransverseMode:
    """Buckled mode m of the rod in a transverse field, φ = π/2, p = 0 (THEORY §6).

    Solves w = √2 h = (2m − 1) K(k²), k = sin β, for β.  The unknown is t = ln(cos² β) =
    ln(1 − k²) (bracketed ``brentq``), with K evaluated by ``scipy.special.ellipkm1`` from the
    complementary parameter, so β is accurate both near h_crit (β → 0) and for large h (β → π/2).

    Parameters
    ----------
    h : float
        Dimensionless field, h > h_crit^(m).
    m : int, optional
        Mode number, m ≥ 1 (default 1).

    Returns
    -------
    TransverseMode
        β, u1 = x(1) − 1, v1 = y(1) (> 0 on the returned branch θ'(0) > 0), k, K, θ(s), ...

    Raises
    ------
    ValueError
        If h ≤ h_crit^(m) (only the straight rod and lower modes exist) or m < 1.

    Notes
    -----
    With sin θ = k sn(u), u = w s, one has cos θ = dn(u) ≥ 0 (|θ| ≤ β < π/2) and
    θ' = w k cn(u); θ'(1) = 0 requires cn(w) = 0, i.e. w = (2m − 1) K.  Then

    * x(1) = ∫₀¹ cos θ ds = (1/w) ∫₀^w dn(u) du = am(w)/w = (2m − 1)(π/2) / ((2m − 1) K)
      = π/(2K), so u1 = π/(2K) − 1 **for every mode** (the factor 2m − 1 cancels).
      Equivalently x(1) = h_crit^(m)/h.
    * y(1) = ∫₀¹ sin θ ds = (k/w) ∫₀^w sn(u) du, with ∫ sn du = (1/k) ln(dn u − k cn u).
      Over [0, K] this gives (1/k) ln(k'/(1 − k)); over each further half period [K + 2jK,
      K + 2(j+1)K] the integral of sn is zero, hence v1 = ln(cos β/(1 − sin β)) / w
      = ln(cos β/(1 − sin β)) / ((2m − 1) K)  (THEORY §6), = artanh(sin β)/((2m − 1) K).

    Both formulas are verified against adaptive quadrature of cos θ(s), sin θ(s) for m = 1, 2, 3
    (``tests/test_reference.py::test_transverse_mode_tip_formulas_by_quadrature``) and against
    the independent shooting solver.  The mirror branch (θ → −θ) has the same u1 and −v1.
    """
    if int(m) != m or m < 1:
        raise ValueError(f"transverse_mode: mode m must be an integer >= 1 (got {m!r})")
    m = int(m)
    h = float(h)
    h_crit = critical_field_transverse(m)
    if not h > h_crit:
        raise ValueError(
            f"transverse_mode: no mode {m} at h = {h!r}: it exists only for "
            f"h > h_crit^({m}) = (2m-1)*pi/(2*sqrt(2)) = {h_crit!r}"
        )
    w = math.sqrt(2.0) * h
    W = w / (2 * m - 1)  # required K = W > π/2   (THEORY §6: w = (2m − 1) K)

    def F(t: float) -> float:
        return _K_of_logkm1(t) - W

    t_hi = 0.0  # k = 0: K = π/2 < W
    # K ≈ ln 4 − t/2 for t → −∞ (and K ≥ that asymptote); start two units beyond it.
    t_lo = min(-1.0, 2.0 * (math.log(4.0) - W) - 2.0)
    while F(t_lo) <= 0.0:
        t_lo = 2.0 * t_lo
    t = brentq(F, t_lo, t_hi, xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=500)

    km1 = math.exp(t)  # cos² β  (may underflow to 0 for huge h: then cos β = e^{t/2} below)
    cos_b = math.exp(0.5 * t)
    sin_b = math.sqrt(-math.expm1(t))  # √(1 − cos² β), accurate for small β
    beta = math.atan2(sin_b, cos_b)
    beta_c = math.atan2(cos_b, sin_b)
    K = _K_of_logkm1(t)
    u1 = math.pi / (2.0 * K) - 1.0  # x(1) − 1 = π/(2K) − 1   (derived above; THEORY §6)
    # v1 = ln(cos β/(1 − sin β))/((2m − 1)K) = [ln(1 + sin β) − ln cos β]/((2m−1)K)  (THEORY §6)
    v1 = (math.log1p(sin_b) - 0.5 * t) / ((2 * m - 1) * K)
    return TransverseMode(
        h=h,
        mode=m,
        w=w,
        beta=beta,
        beta_complement=beta_c,
        k=sin_b,
        km1=km1,
        K=K,
        u1=u1,
        v1=v1,
        gamma=w * sin_b,  # θ'(0) = w k cn(0) = w sin β
        theta1=(-1.0) ** (m - 1) * beta,
    )
