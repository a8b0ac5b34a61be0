"""Jacobi conjugate-point (Sturm) stability test of the reference shooting solver (THEORY §7).

Counts the negative eigenvalues of the second variation δ²Ê = ∫₀¹ b η'² + Q η² ds (eq. (Q) of
:mod:`actuator_design.reference.shooting`) on the clamped–free rod by the Prüfer angle; numpy/scipy
only (an independent reference).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Optional

import numpy as np
from scipy.integrate import solve_ivp

from actuator_design.reference.shooting_model import ATOL, RTOL, ProfileLike, ShootingParams, _as_scalar_fun

if TYPE_CHECKING:  # only for annotations: the solver module re-exports this one
    from actuator_design.reference.shooting import ShootingSolution

__all__ = ["JacobiResult", "sturm_morse_index", "jacobi_morse_index"]

@dataclass(eq=False)
class JacobiResult:
    """Result of the Jacobi conjugate-point (Sturm) test.

    Attributes
    ----------
    index : int
        Morse index: number of negative eigenvalues λ of −(b η')' + Q η = λ η, η(0) = 0,
        b(1) η'(1) = 0 (the second variation on the clamped–free rod, THEORY §7).
    degenerate : bool
        True when 0 is (within ``tol``) an eigenvalue: b η'(1) = 0 for the Jacobi field.
    stable : bool
        index == 0 and not degenerate (second variation positive definite).
    prufer_end : float
        Prüfer angle ϑ(1) = atan2(η, b η') continued from ϑ(0) = 0 [rad].
    zeros_moment : int
        Number of sign changes of b η' in (0, 1) (equals ``index`` whenever ϑ crosses the
        levels π/2 + jπ only upwards, e.g. when Q ≤ 0 there; see Notes of
        :func:`sturm_morse_index`).
    zeros_eta : int
        Number of zeros of η in (0, 1) (conjugate points of s = 0).
    eta, moment : callable
        η(s) and b η'(s) of the Jacobi field (dense output).
    """

    index: int
    degenerate: bool
    prufer_end: float
    zeros_moment: int
    zeros_eta: int
    eta: Callable = field(repr=False)
    moment: Callable = field(repr=False)

    @property
    def stable(self) -> bool:
        return self.index == 0 and not self.degenerate


def sturm_morse_index(Q: Callable[[float], float], b: ProfileLike = 1.0, *, tol: float = 1e-8,
                      rtol: float = RTOL, atol: float = ATOL) -> JacobiResult:
    """Morse index of Q[η] = ∫₀¹ b η'² + Q(s) η² ds on {η(0) = 0, η(1) free} by Sturm theory.

    Integrates the Jacobi equation (b η')' = Q η, η(0) = 0, b η'(0) = 1, together with the
    Prüfer angle ϑ = atan2(η, b η'):  ϑ' = cos² ϑ / b − Q sin² ϑ, ϑ(0) = 0.

    Parameters
    ----------
    Q : callable
        Q(s), scalar s → float.
    b : float or callable
        b(s) > 0.
    tol : float
        Distance of ϑ(1) from a level π/2 + jπ below which the zero eigenvalue is reported
        (``degenerate=True``).

    Returns
    -------
    JacobiResult

    Notes
    -----
    For the eigenproblem −(b η')' + Q η = λ η, η(0) = 0, b(1)η'(1) = 0, the Prüfer angle
    ϑ(1; λ) of the solution with η(0) = 0 increases strictly with λ and tends to 0 as λ → −∞;
    λ is an eigenvalue iff ϑ(1; λ) = π/2 + jπ (j = 0, 1, ...).  Hence the number of negative
    eigenvalues is the number of levels π/2 + jπ strictly below ϑ(1; 0):

        index = #{j ≥ 0 : π/2 + jπ < ϑ(1)},   degenerate ⟺ ϑ(1) ∈ π/2 + πℤ  (b η'(1) = 0).

    ϑ crosses the levels jπ (zeros of η) only upwards (ϑ' = 1/b > 0 there), but it can cross a
    level π/2 + jπ downwards where Q > 0 (ϑ' = −Q there).  So "the number of zeros of b η' in
    (0, 1)" equals the index only when those crossings are all upward (always true where Q ≤ 0 at
    the zeros of b η', e.g. Q constant); ``zeros_moment`` is reported for comparison.
    Equivalently index = Z + [η(1) · b η'(1) < 0] with Z the number of zeros of η in (0, 1).
    """
    bfun, bconst = _as_scalar_fun(b)
    half_pi = 0.5 * math.pi

    def rhs(s, y):
        bb = bconst if bconst is not None else bfun(s)
        q = float(Q(s))
        c, sn = math.cos(y[2]), math.sin(y[2])
        return [y[1] / bb, q * y[0], c * c / bb - q * sn * sn]

    def ev_eta(s, y):
        return y[0]

    def ev_mom(s, y):
        return y[1]

    sol = solve_ivp(rhs, (0.0, 1.0), [0.0, 1.0, 0.0], method="DOP853", rtol=rtol, atol=atol,
                    dense_output=True, events=[ev_eta, ev_mom])
    if not sol.success:
        raise RuntimeError(f"Jacobi integration failed: {sol.message}")
    theta_end = float(sol.y[2, -1])
    levels_below = math.floor((theta_end - half_pi) / math.pi) + 1 if theta_end > half_pi else 0
    # nearest level π/2 + jπ
    j_near = round((theta_end - half_pi) / math.pi)
    degenerate = j_near >= 0 and abs(theta_end - (half_pi + j_near * math.pi)) < tol
    index = levels_below
    if degenerate and theta_end > half_pi + j_near * math.pi:
        index -= 1  # that eigenvalue is (numerically) zero, not negative

    interior = 1e-9
    zeros_eta = int(np.sum((sol.t_events[0] > interior) & (sol.t_events[0] < 1.0 - interior)))
    zeros_mom = int(np.sum((sol.t_events[1] > interior) & (sol.t_events[1] < 1.0 - interior)))
    return JacobiResult(
        index=int(index),
        degenerate=bool(degenerate),
        prufer_end=theta_end,
        zeros_moment=zeros_mom,
        zeros_eta=zeros_eta,
        eta=lambda s: sol.sol(s)[0],
        moment=lambda s: sol.sol(s)[1],
    )


def jacobi_morse_index(solution: ShootingSolution, params: Optional[ShootingParams] = None, *,
                       tol: float = 1e-8) -> JacobiResult:
    """Jacobi conjugate-point test of THEORY §7 along an equilibrium (independent of any Hessian).

    Q(s) = 2h² cos(2(θ + α − φ)) + n_x cos θ + n_y sin θ (eq. Q) is evaluated on the dense output
    θ(s) of ``solution``; then :func:`sturm_morse_index` counts the negative eigenvalues of the
    second variation ∫ b η'² + Q η² on η(0) = 0 with the end s = 1 free.

    Parameters
    ----------
    solution : ShootingSolution
        An equilibrium (``converged``); any object with a vectorised ``theta(s)`` works.
    params : ShootingParams, optional
        Defaults to ``solution.params``.
    tol : float
        Tolerance of the zero-eigenvalue (``degenerate``) detection on the Prüfer angle.

    Returns
    -------
    JacobiResult
        ``index`` (Morse index), ``degenerate``, ``stable``, diagnostics.
    """
    if params is None:
        params = solution.params

    h2 = float(params.h) ** 2
    c2, s2 = params.cos2phi, params.sin2phi
    afun, aconst = _as_scalar_fun(params.alpha)
    bfun, bconst = _as_scalar_fun(getattr(params, "beta", 0.0))
    h_r = float(getattr(params, "h_r", 0.0))

    def Q(s: float) -> float:  # eq. (Q), scalar version of jacobi_coefficient (THEORY §7, §9)
        th = float(solution.theta(s))
        ta = th + (aconst if aconst is not None else afun(s))
        cos2psi = math.cos(2.0 * ta) * c2 + math.sin(2.0 * ta) * s2
        nx = params.fx + params.qx * (1.0 - s)
        ny = params.fy + params.qy * (1.0 - s)
        hard = h_r * math.cos(th + (bconst if bconst is not None else bfun(s)) - params.phi) if h_r else 0.0
        return 2.0 * h2 * cos2psi + hard + nx * math.cos(th) + ny * math.sin(th)

    return sturm_morse_index(Q, params.b, tol=tol)
