"""The fold curve as a continuation problem: the Moore–Spence system continued in a second
parameter μ (THEORY §7–8).

Unknowns x = (u, λ, v, μ) (2n + 2,): the fold state u, the folding parameter λ, the null vector v
of H and the continuation parameter μ; equations F = [g; H v; cᵀ M v − 1] (2n + 1,), with c the
null vector of the last accepted point scaled so that cᵀMc = 1. The metric weights (M, 1, 0, 1)
measure arclength in (θ, λ, μ) only. Plugged into :func:`~.engine.continuation` like
:class:`~.problem.BifurcationProblem`, it traces λ_crit(μ), e.g. p_crit^(1)(h²).
"""
from __future__ import annotations

import math
from typing import Tuple

import numpy as np

from actuator_design.reduced.fold import fold_converged, fold_converged_at_floor, locate_fold
from actuator_design.reduced.newton import newton
from actuator_design.reduced.system import ReducedSystem

__all__ = ["FoldCurveProblem"]


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
