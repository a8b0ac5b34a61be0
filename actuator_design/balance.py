"""Clamp reactions and the integrated Euler–Lagrange residual of a discrete equilibrium (THEORY §4).

With τ = −∂V/∂θ and F = −∂V/∂r the distributed torque and force, f and m the tip force and moment,
n(s) = f + ∫_s^1 F the internal force, the moment balance of the free part [s, 1] about the origin
reads  R(s) = M(s) − m − r(1)×f − ∫_s^1 (τ + r×F) dσ + r(s)×n(s) = 0,  M = ∂V/∂θ' the internal
moment of all densities V (bθ' for bending). Its derivative is the Euler–Lagrange equation
(bθ')' + τ + r'×n = 0 and R(1) = 0 is the free-end condition. Every term enters through the
solver's pointwise functions, so a plug-in term is checked like a built-in one. Evaluated on 8
sub-intervals per element (2 for the midpoint rule) with 12-point Gauss quadrature.

The evaluation points depend only on the mesh, and θ, θ' there are linear in the node values:
:class:`BalanceOperator` builds those linear maps once per solver, so a check costs two
matrix–vector products and one vectorised evaluation of the pointwise loads
(:mod:`actuator_design.pointwise`; a study checks thousands of states on one mesh).
"""
from __future__ import annotations

import weakref
from typing import Tuple

import numpy as np

__all__ = ["BalanceOperator", "balance", "GAUSS_T", "GAUSS_W"]

GAUSS_T, GAUSS_W = np.polynomial.legendre.leggauss(12)

#: meshes with more nodes than this are evaluated without stored maps (their memory grows as n²)
MAX_NODES_STORED = 400

_OPERATORS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_VECTORISED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _unit_maps(tr, s: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """A0, A1 with θ(s) = A0 z and θ'(s) = A1 z for the transcription's interpolant, shapes (len(s), n)."""
    n = tr.nodes.size
    A0, A1 = np.empty((s.size, n)), np.empty((s.size, n))
    e = np.zeros(n)
    for i in range(n):
        e[i] = 1.0
        A0[:, i], A1[:, i] = tr.theta_dense(e, s)
        e[i] = 0.0
    return A0, A1


class BalanceOperator:
    """The fixed evaluation points of the balance check on one mesh, and θ, θ' there as matrices.

    Positions (LGL): x, y at the sub-interval edges by the 12-point Gauss rule of (cos θ, sin θ)
    on each sub-interval, and at its Gauss points by integrating exactly the interpolant of
    (cos θ, sin θ) through them (degree 11 on an interval of length ≤ 1/(8E): the same integrals
    as the dense shape's to rounding). Midpoint: the polygon through the nodes.
    """

    def __init__(self, transcription, stored: bool = True):
        tr = self.tr = transcription
        bp = tr.breakpoints
        self.lgl = tr.name != "midpoint"
        sub = 8 if self.lgl else 2
        edges = np.unique(np.concatenate([np.linspace(bp[i], bp[i + 1], sub + 1)
                                          for i in range(len(bp) - 1)]))
        a, b = edges[:-1], edges[1:]
        self.n_sub = a.size
        sg = (0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * GAUSS_T[None, :]).ravel()
        self.sg, self.wg = sg, (0.5 * (b - a)[:, None] * GAUSS_W[None, :]).ravel()
        keep = ~np.isin(edges, bp[1:-1]) if self.lgl else ~np.isin(edges, bp)
        self.keep, self.se = keep, edges[keep]
        if not stored:
            return
        self.A0, self.A1 = _unit_maps(tr, np.concatenate((sg, self.se)))
        # x, y at the Gauss points from the interpolant of (cos θ, sin θ) through the Gauss
        # points of their sub-interval, integrated exactly from its left edge
        self.S = 0.5 * (b - a)[:, None, None] * _gauss_integration_matrix()[None, :, :]

    def dense(self, z: np.ndarray):
        """θ, θ', x, y at the quadrature points ``sg`` and at the residual edges ``se``."""
        th = self.A0 @ z
        dth = self.A1 @ z
        m = self.sg.size
        th_g, th_e, dth_g, dth_e = th[:m], th[m:], dth[:m], dth[m:]
        if self.lgl:
            c, s = np.cos(th_g).reshape(self.n_sub, -1), np.sin(th_g).reshape(self.n_sub, -1)
            w = self.wg.reshape(self.n_sub, -1)
            x_edge = np.concatenate(([0.0], np.cumsum((w * c).sum(1))))
            y_edge = np.concatenate(([0.0], np.cumsum((w * s).sum(1))))
            x_g = (x_edge[:-1, None] + np.einsum("kij,kj->ki", self.S, c)).ravel()
            y_g = (y_edge[:-1, None] + np.einsum("kij,kj->ki", self.S, s)).ravel()
            xy = [(x_g, y_g), (x_edge[self.keep], y_edge[self.keep])]
        else:  # the midpoint rod is the polygon through its nodes
            tr = self.tr
            th_q = 0.5 * (z[1:] + z[:-1])
            xn = np.concatenate(([0.0], np.cumsum(tr.h * np.cos(th_q))))
            yn = np.concatenate(([0.0], np.cumsum(tr.h * np.sin(th_q))))
            xy = [(np.interp(q, tr.nodes, xn), np.interp(q, tr.nodes, yn)) for q in (self.sg, self.se)]
        return (th_g, dth_g, *xy[0]), (th_e, dth_e, *xy[1])


def _gauss_integration_matrix() -> np.ndarray:
    """S with (S f)_i = ∫_{-1}^{t_i} p(t) dt for the interpolant p of f through the 12 Gauss
    points t_j, shape (12, 12)."""
    from numpy.polynomial import legendre as L

    d = GAUSS_T.size - 1
    V = L.legvander(GAUSS_T, d)
    antider = np.empty((d + 1, d + 1))
    for m in range(d + 1):
        c = np.zeros(d + 1)
        c[m] = 1.0
        antider[:, m] = L.legval(GAUSS_T, L.legint(c, lbnd=-1.0))
    return antider @ np.linalg.inv(V)


def operator_for(solver):
    """The :class:`BalanceOperator` of ``solver``'s mesh (built on first use), or None for big meshes."""
    if solver.transcription.nodes.size > MAX_NODES_STORED:
        return None
    op = _OPERATORS.get(solver)
    if op is None:
        op = _OPERATORS[solver] = BalanceOperator(solver.transcription)
    return op


def balance(solver, params, dense, scene, z):
    """Clamp force (2,), clamp moment and max |R(s)| (units of B0/ℓ², B0/ℓ, B0/ℓ; module doc).

    Parameters
    ----------
    solver : EquilibriumSolver
    params : ndarray
        The NLP parameter vector of ``scene``.
    dense : callable
        s -> (θ, θ', x, y), the dense shape (used for meshes without a stored operator).
    scene : Scene
    z : ndarray, shape (n_nodes,)
    """
    op = operator_for(solver)
    if op is None:
        op = BalanceOperator(solver.transcription, stored=False)  # points only; values from ``dense``
        g, e = dense(op.sg), dense(op.se)
    else:
        g, e = op.dense(np.asarray(z, float))
    return _reactions(solver, params, scene, z, op, g, e)


def _vectorised(solver):
    """The solver's pointwise loads replayed on numpy arrays (:mod:`actuator_design.pointwise`),
    or None when the function cannot be (CasADi then evaluates it point by point)."""
    from .pointwise import NotVectorisable, VectorisedSX

    if solver not in _VECTORISED:
        dens_f = solver._pointwise[0]
        try:
            _VECTORISED[solver] = VectorisedSX(dens_f, shared=[dens_f.n_in() - 1])
        except NotVectorisable:
            _VECTORISED[solver] = None
    return _VECTORISED[solver]


def _reactions(solver, params, scene, z, op, g, e):
    dens_f, tip_f = solver._pointwise
    fast = _vectorised(solver)
    row = lambda v: np.asarray(v, float).reshape(1, -1)  # CasADi evaluates row inputs pointwise

    def loads(th_, dth_, x_, y_, s_):  # (τ, Fx, Fy, M) of every term at arc lengths s_
        fields = [fn(scene, s_) for fn in solver._node_fields.values()]
        if fast is not None:
            return fast(th_, x_, y_, dth_, *[np.broadcast_to(f, np.shape(s_)) for f in fields], params)
        return [np.asarray(v, float).ravel()
                for v in dens_f(row(th_), row(x_), row(y_), row(dth_), *map(row, fields), params)]

    x, y = g[2], g[3]
    xe, ye = e[2], e[3]
    n_g = x.size  # one CasADi call for the quadrature points and the residual edges
    tau, Fx, Fy, moment = loads(*(np.concatenate((u, v)) for u, v in zip(g, e)),
                                np.concatenate((op.sg, op.se)))
    tau, Fx, Fy, moment = tau[:n_g], Fx[:n_g], Fy[:n_g], moment[n_g:]
    _, tip_theta, tip_x, tip_y = solver.summary(z, params)
    m, fx, fy = (float(v) for v in tip_f(tip_theta, tip_x, tip_y, params))
    wg = op.wg

    def tail(values):  # ∫_{edge_k}^1 values, for every edge k
        per = (wg * values).reshape(op.n_sub, -1).sum(1)
        return np.concatenate((np.cumsum(per[::-1])[::-1], [0.0]))

    I_tau, I_Fx, I_Fy, I_rF = tail(tau), tail(Fx), tail(Fy), tail(x * Fy - y * Fx)
    r1xf = tip_x * fy - tip_y * fx
    clamp_force = -np.array([fx + I_Fx[0], fy + I_Fy[0]])
    clamp_moment = -(m + r1xf + I_tau[0] + I_rF[0])
    # residual at the edges where θ' is defined (not on element boundaries, where it may jump)
    keep = op.keep  # moment: the internal moment ∂V/∂θ' (= bθ' for bending) at the edges
    nx, ny = fx + I_Fx[keep], fy + I_Fy[keep]
    R = moment - m - r1xf - I_tau[keep] - I_rF[keep] + (xe * ny - ye * nx)
    return clamp_force, float(clamp_moment), float(np.max(np.abs(R)))
