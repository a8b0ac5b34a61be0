"""The continuation problem: the reduced system G(u, λ) = ∇_u Ê(u; λ) = 0 in one lens parameter λ,
with its corrector, tangent and inertia (THEORY §7–8; Allgower & Georg ch. 2).

Unknowns x = (u, λ) (n + 1,), u the free node values (θ_0 = θ0 eliminated). The metric
W = diag(m_1, …, m_n, 1) makes ‖δu‖_W approximate the L² norm of δθ, so arclength steps do not
depend on the resolution.

:class:`FoldCurveProblem`: the fold curve as a continuation problem, the Moore–Spence system
continued in a second parameter μ (THEORY §7–8). Unknowns x = (u, λ, v, μ) (2n + 2,): the fold
state u, the folding parameter λ, the null vector v of H and the continuation parameter μ;
equations F = [g; H v; cᵀ M v − 1] (2n + 1,), with c the null vector of the last accepted point
scaled so that cᵀMc = 1. The metric weights (M, 1, 0, 1) measure arclength in (θ, λ, μ) only.
Plugged into :func:`~.engine.continuation` like :class:`BifurcationProblem`, it traces λ_crit(μ),
e.g. p_crit^(1)(h²).
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np
from scipy.linalg import lapack

from actuator_design.reduced.banded import BandedBordered, use_band
from actuator_design.reduced.fold import fold_converged, fold_converged_at_floor, locate_fold
from actuator_design.reduced.linalg import (FLOOR_STEP, banded_negatives, ldl_negatives, lowest_eigenpair,
                                            lowest_eigenpair_banded, lu_det_sign,
                                            signed_distance_to_singularity, within_rounding_floor)
from actuator_design.reduced.newton import newton
from actuator_design.reduced.system import ReducedSystem

__all__ = ["BifurcationProblem", "FoldCurveProblem"]

_dgesv, _dgetrf, _dgetrs = lapack.dgesv, lapack.dgetrf, lapack.dgetrs


class BifurcationProblem:
    """G(u, λ) = 0 for one built reduced system, λ its first parameter name (the lens).

    Parameters
    ----------
    system : ReducedSystem
        ``system.names[0]`` is the continuation parameter.
    P : ndarray, shape (n_P,)
        NLP parameters of the other values (the entries λ controls are ignored).
    u0 : ndarray (n,), optional
        Start guess (free unknowns, rad); λ0 its parameter value.
    lam0 : float, optional
    theta0 : float
        Clamp angle (rad) of the full node vector z = (θ0, u) — λ itself when the lens is θ0.
    """

    def __init__(self, system: ReducedSystem, P: np.ndarray, u0=None, lam0: Optional[float] = None,
                 theta0: float = 0.0):
        self.system = system
        self.lens = system.names[0]
        self.P = np.asarray(P, float)
        self.ev = system.evaluator(self.P)
        self.mass = system.mass
        self.n = system.n
        self.W = np.append(self.mass, 1.0)
        self.Ms = 1.0 / np.sqrt(self.mass)
        self.u0 = None if u0 is None else np.asarray(u0, float)
        self.lam0 = lam0
        self.theta0 = float(theta0)
        n = self.n
        self._Jb = np.empty((n + 1, n + 1), order="F")  # bordered Jacobian, LAPACK's layout
        self._F = np.empty(n + 1)
        self._e_last = np.zeros(n + 1)
        self._e_last[n] = 1.0
        self._scale = self.Ms[:, None] * self.Ms[None, :]  # (M^{-1/2})_i (M^{-1/2})_j
        self._v_low = None  # eigenvector of the smallest eigenvalue at the last fast_inertia
        # long band Hessians (fine meshes): corrector, tangent and stability in band storage
        self._band = (BandedBordered(n, system.bandwidth, self.Ms)
                      if use_band(n, system.bandwidth) else None)

    def polish_fold(self, x: np.ndarray):
        """The fold near ``x`` = (u, λ) by the one fold locator (Moore–Spence, :mod:`actuator_design.reduced.fold`),
        or None when it does not converge close by (then the event's bracketed root stands)."""
        if len(self.system.names) != 1:
            return None
        n = self.n
        fp = locate_fold(self.system, self.P, x[:n], float(x[n]), tol=1e-12)
        if not fp.converged or abs(fp.lam - x[n]) > 1e-6 * (1.0 + abs(x[n])) or \
                np.max(np.abs(fp.u - x[:n])) > 1e-3:
            return None
        return np.append(fp.u, fp.lam)

    @property
    def evaluations(self) -> int:
        """Number of system evaluations so far."""
        return self.ev.calls

    def accept(self, x: np.ndarray) -> None:
        """Hook called by the engine on every accepted point (nothing to update here)."""

    def inside(self, x: np.ndarray) -> bool:
        """Whether x is in the problem's domain (always: the window is the settings')."""
        return True

    def stability(self, x: np.ndarray) -> Tuple[int, float]:
        """(Morse index, smallest eigenvalue) at x (:meth:`fast_inertia` after an evaluation)."""
        self.ev(x[:self.n], x[self.n])
        return self.fast_inertia()

    # -- points ---------------------------------------------------------------------------------
    def full(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Node vector z = (θ0, u), shape (n + 1,)."""
        return np.concatenate(([lam if self.lens == "theta0" else self.theta0], u))

    def tip(self, x: np.ndarray):
        """(θ(1), x(1), y(1)) at x = (u, λ)."""
        t = np.asarray(self.system.f_tip(x[:self.n], x[self.n], self.P)[0], float).ravel()
        return float(t[0]), float(t[1]), float(t[2])

    def residual(self, g: np.ndarray) -> float:
        """max_i |g_i| / m_i."""
        return float(np.max(np.abs(g / self.mass)))

    def at_rounding_floor(self, g: np.ndarray, H: np.ndarray, u: np.ndarray, tol: float) -> bool:
        """:func:`~actuator_design.reduced.linalg.within_rounding_floor` at ``u`` (gradient ``g``,
        Hessian ``H`` there)."""
        return within_rounding_floor(g, H, u, self.mass, tol)

    # -- correctors -----------------------------------------------------------------------------
    def correct_fixed(self, u, lam, tol: float, max_iter: int = 20):
        """Newton at fixed λ (steps clipped to 1 rad): converged at max_i |g_i| / m_i ≤ ``tol``, or
        after a step below :data:`FLOOR_STEP` from a point :meth:`at_rounding_floor`.
        Returns (u, converged, iterations)."""
        last = [None]

        def evaluate(u_):
            g, H, _ = self.ev(u_, lam)
            last[0] = u_
            return g, H

        def floor_step(g, du):
            return float(np.max(np.abs(du))) <= FLOOR_STEP and self.at_rounding_floor(g, self.ev.H, last[0], tol)

        return newton(evaluate, u, lambda u_, g: self.residual(g) <= tol, max_iter, clip_at=1.0,
                      converged_after_step=floor_step)

    def correct(self, xp, row, tol: float, arc_tol: float = 1e-9, max_iter: int = 8,
                start: Optional[np.ndarray] = None):
        """Newton on [G(x); rowᵀ(x − x_p)] = 0 from ``start`` (default x_p; PALC: row = W t;
        natural: row = e_λ), converged at max_i |g_i| / m_i ≤ ``tol`` and |rowᵀ(x − x_p)| ≤ ``arc_tol``, or
        after a step below :data:`FLOOR_STEP` from a point :meth:`at_rounding_floor`. Steps larger
        than 2 (rad) fail. Returns (x, converged, iterations).

        The loop of :func:`~actuator_design.reduced.newton.newton` (same tests, same order) with
        the bordered Jacobian assembled in one Fortran buffer and solved by LAPACK ``dgesv``
        directly: the per-step overhead matters on a 1000-point branch."""
        n, ev, mass = self.n, self.ev, self.mass
        Jb, F = self._Jb, self._F
        row = np.asarray(row, float)
        xp = np.asarray(xp, float)
        x = xp.copy() if start is None else np.array(start, float)
        for it in range(max_iter + 1):
            g, H, gl = ev(x[:n], x[n])
            res = float(np.max(np.abs(g / mass)))  # NaN or inf when g is not finite
            arc = float(row @ (x - xp))
            if not (res < math.inf and abs(arc) < math.inf):
                return x, False, it
            if res <= tol and abs(arc) <= arc_tol:
                return x, True, it
            if it == max_iter:
                break
            np.negative(g, out=F[:n])
            F[n] = -arc
            banded = self._band and self._band.bordered(H, gl, row[:n], float(row[n]), F)
            if banded:
                dx, info = banded[0], 0
            else:
                Jb[:n, :n] = H
                Jb[:n, n] = gl
                Jb[n] = row
                dx, info = _dgesv(Jb, F, overwrite_a=1)[2:]
            step = float(np.max(np.abs(dx)))
            if info != 0 or not step <= 2.0:  # also NaN
                return x, False, it
            if step <= FLOOR_STEP and abs(arc) <= arc_tol and self.at_rounding_floor(g, H, x[:n], tol):
                # the residual is rounding: the step confirms the point (counted as the iterations that
                # reached it, as a residual below tol is: the step control sees the same count)
                return x + dx, True, it
            x = x + dx
        return x, False, max_iter

    # -- tangent and inertia --------------------------------------------------------------------
    def tangent(self, x, t_prev=None, evaluate: bool = True) -> Tuple[np.ndarray, float]:
        """Unit tangent (W-norm) at a converged x, oriented along ``t_prev`` (or +λ), and the sign of
        det [G_x; tᵀW]. ``evaluate=False`` reuses the last evaluation (which must be at x)."""
        n = self.n
        g, H, gl = self.ev(x[:n], x[n]) if evaluate else (self.ev.g, self.ev.H, self.ev.gl)
        J = self._Jb
        J[:n, :n], J[:n, n] = H, gl
        if t_prev is None:
            # null vector of [H gl] by SVD (robust also at a singular H)
            _, _, Vt = np.linalg.svd(J[:n] / np.sqrt(self.W)[None, :])
            t = Vt[-1] / np.sqrt(self.W)
            if t[n] < 0:
                t = -t
            t /= math.sqrt(float(t @ (self.W * t)))
            J[n] = t * self.W
            lu, piv, _ = _dgetrf(J, overwrite_a=1)
            return t, lu_det_sign(lu, piv)
        # [G_x; t_prevᵀW] t = e_{n+1}. det[G_x; cᵀ] = κ (c·t) for any row c (the row space of
        # G_x is t^⊥), so det[G_x; t_prevᵀW] and det[G_x; tᵀW] share the sign of κ: t_prevᵀW t
        # = 1 > 0 and tᵀW t > 0.
        c = t_prev * self.W
        banded = self._band and self._band.bordered(H, gl, c[:n], float(c[n]), self._e_last)
        if banded:
            t, sign = banded
            return t / math.sqrt(float(t @ (self.W * t))), sign
        J[n] = c
        lu, piv, info = _dgetrf(J, overwrite_a=1)
        if info < 0:
            raise ValueError(f"dgetrf: illegal argument {-info}")
        t = _dgetrs(lu, piv, self._e_last)[0]  # a singular J gives inf/nan, as lu_solve did
        t /= math.sqrt(float(t @ (self.W * t)))
        return t, lu_det_sign(lu, piv)

    def _scaled_hessian(self, H):
        """Symmetrised M^{-1/2} H M^{-1/2}, shape (n, n)."""
        A = H * self._scale
        A += A.T.copy()
        A *= 0.5
        return A

    def inertia(self, x, evaluate: bool = True) -> Tuple[int, float, float]:
        """(Morse index, smallest eigenvalue, (−1)^index · min|μ|) of M^{-1/2} H M^{-1/2} at x
        (``evaluate=False`` reuses the last evaluation, which must be at x)."""
        H = self.ev(x[: self.n], x[self.n])[1] if evaluate else self.ev.H
        return signed_distance_to_singularity(self._scaled_hessian(H))

    def fast_inertia(self) -> Tuple[int, float]:
        """(Morse index, smallest eigenvalue) at the last evaluation: the smallest eigenpair by
        Rayleigh-quotient iteration from the previous point's eigenvector, certified
        (:func:`~actuator_design.reduced.linalg.lowest_eigenpair`; its band-storage twin on the
        band path); the index is 0 when that certifies positive definiteness, else the LDLᵀ
        inertia (the count of the banded eigensolver on the band path)."""
        if self._band:
            a = self._band.scaled_band(self.ev.H)
            mu, self._v_low, definite = lowest_eigenpair_banded(a, self._v_low)
            return (0 if definite else banded_negatives(a)), mu
        A = self._scaled_hessian(self.ev.H)
        mu, self._v_low, definite = lowest_eigenpair(A, self._v_low)
        return (0 if definite else ldl_negatives(A)), mu

    def null_directions(self, x) -> np.ndarray:
        """The two right singular vectors of [G_u G_λ] (W-scaled) with the smallest singular
        values, shape (2, n + 1): at a simple branch point they span the two branch tangents."""
        g, H, gl = self.ev(x[:self.n], x[self.n])
        J = np.column_stack([H, gl]) / np.sqrt(self.W)[None, :]
        _, _, Vt = np.linalg.svd(J)
        return Vt[-2:] / np.sqrt(self.W)[None, :]


class FoldCurveProblem:
    """A fold of ``system.names[0]`` continued in ``system.names[1]``.

    Parameters
    ----------
    system : ReducedSystem
        In the names (λ, μ).
    P : ndarray, shape (n_P,)
        NLP parameters of the other values.
    v0 : ndarray, shape (n,)
        Null vector at the start (sets c).
    lam_window : (float, float)
        The curve ends where λ leaves it.
    """

    def __init__(self, system: ReducedSystem, P: np.ndarray, v0: np.ndarray,
                 lam_window: Tuple[float, float] = (-math.inf, math.inf)):
        self.lam_window = (min(lam_window), max(lam_window))
        self.system, self.P = system, np.asarray(P, float)
        self.lens = system.names[1]
        self.m = system.n
        self.mass = system.mass
        self.n = 2 * self.m + 1
        self.W = np.concatenate([self.mass, [1.0], np.zeros(self.m), [1.0]])
        self.fn = system.f_fold
        self.evaluations = 0
        self._J = None
        self.accept(np.concatenate([np.zeros(self.m + 1), v0, [0.0]]))

    def accept(self, x: np.ndarray) -> None:
        """Re-normalise c on the accepted point's null vector."""
        v = x[self.m + 1:2 * self.m + 1]
        self.c = v / float(v @ (self.mass * v))

    def inside(self, x: np.ndarray) -> bool:
        """Whether λ is inside ``lam_window``."""
        return bool(self.lam_window[0] <= x[self.m] <= self.lam_window[1])

    def evaluate(self, x: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """(F (2n + 1,), [∂F/∂(u, λ, v), ∂F/∂μ] (2n + 1, 2n + 2)) at x."""
        m = self.m
        F, J, Fm = self.fn(x[:m], x[[m, -1]], x[m + 1:2 * m + 1], self.c, self.P)
        self.evaluations += 1
        self._x = x
        self._J = np.column_stack([np.asarray(J), np.asarray(Fm).ravel()])
        return np.asarray(F).ravel(), self._J

    def correct(self, xp, row, tol: float, arc_tol: float = 1e-10, max_iter: int = 9,
                start=None):
        """Newton on [F(x); rowᵀ(x − x_p)] = 0 from ``start`` (default x_p). Returns
        (x, converged, iterations)."""
        xp = np.asarray(xp, float)

        def bordered(x):
            F, J = self.evaluate(x)
            return np.append(F, float(row @ (x - xp))), np.vstack([J, row])

        def converged(x, Fa):
            return fold_converged(Fa[:-1], self.mass, tol) and abs(Fa[-1]) <= arc_tol

        def floor_step(Fa, dx):  # (self._J, the last x: where Fa was evaluated)
            return abs(Fa[-1]) <= arc_tol and fold_converged_at_floor(Fa[:-1], dx, self._J, self._x, self.mass, tol)

        return newton(bordered, xp if start is None else start, converged, max_iter, reject_above=2.0,
                      reject_slice=slice(0, self.m + 1), converged_after_step=floor_step)

    def correct_fixed(self, y, mu, tol: float, max_iter: int = 20):
        """The fold at fixed μ from y = (u, λ, v) (Moore–Spence). Returns (y, converged, iterations)."""
        m = self.m
        fp = locate_fold(self.system, self.P, y[:m], y[m], y[m + 1:], others=[mu], tol=tol,
                         max_iter=max_iter)
        return np.concatenate([fp.u, [fp.lam], fp.v]), fp.converged, fp.iterations

    def tangent(self, x, t_prev=None, evaluate: bool = True):
        """Unit tangent (W-norm): the null vector of the Jacobian (SVD) at the start, else from
        [J; t_prevᵀW] t = e_last. The determinant sign is not used (returns 1)."""
        J = self.evaluate(x)[1] if evaluate or self._J is None else self._J
        if t_prev is None:
            t = np.linalg.svd(J)[2][-1]
            if t[-1] < 0:
                t = -t
        else:
            t = np.linalg.solve(np.vstack([J, t_prev * self.W]), np.eye(J.shape[1])[-1])
        return t / math.sqrt(float(t @ (self.W * t))), 1.0

    def stability(self, x):
        return 0, math.nan

    def fast_inertia(self):
        return 0, math.nan

    def full(self, y, mu):
        return np.append(y, mu)
