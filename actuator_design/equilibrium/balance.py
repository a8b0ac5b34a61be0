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
(:mod:`actuator_design.equilibrium.pointwise`; a study checks thousands of states on one mesh).
"""
from __future__ import annotations

import weakref
from typing import Tuple

import numpy as np
from numpy.polynomial import legendre as L

from actuator_design.equilibrium.pointwise import NotVectorisable, VectorisedSX

__all__ = ["BalanceOperator", "balance", "balance_many", "GAUSS_T", "GAUSS_W"]

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
        self.clamp_curvature_row = _unit_maps(tr, np.array([0.0]))[1][0]  # θ'(0) = row · z
        # x, y at the Gauss points from the interpolant of (cos θ, sin θ) through the Gauss
        # points of their sub-interval, integrated exactly from its left edge
        self.S = 0.5 * (b - a)[:, None, None] * _gauss_integration_matrix()[None, :, :]

    def dense(self, z: np.ndarray):
        """θ, θ', x, y at the quadrature points ``sg`` and at the residual edges ``se``.

        ``z`` of shape (n_nodes,) gives arrays of shape (n_points,); of shape (n_nodes, m), the
        values of m states at once, shape (n_points, m).
        """
        th = self.A0 @ z
        dth = self.A1 @ z
        m = self.sg.size
        th_g, th_e, dth_g, dth_e = th[:m], th[m:], dth[:m], dth[m:]
        if self.lgl:
            tail = th_g.shape[1:]  # () or (m,)
            c = np.cos(th_g).reshape(self.n_sub, -1, *tail)
            s = np.sin(th_g).reshape(self.n_sub, -1, *tail)
            w = self.wg.reshape(self.n_sub, -1, *(1,) * len(tail))
            x_edge = np.concatenate((np.zeros((1, *tail)), np.cumsum((w * c).sum(1), axis=0)))
            y_edge = np.concatenate((np.zeros((1, *tail)), np.cumsum((w * s).sum(1), axis=0)))
            x_g = (x_edge[:-1, None] + np.einsum("kij,kj...->ki...", self.S, c)).reshape(th_g.shape)
            y_g = (y_edge[:-1, None] + np.einsum("kij,kj...->ki...", self.S, s)).reshape(th_g.shape)
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


def balance(solver, params, dense, scene, z, point_loads=None):
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
    point_loads : (s, Fx, Fy, x, y) arrays, optional
        Point forces on the rod (contact forces, units of B0/ℓ²) at arc lengths s, positions (x, y).
    """
    op = operator_for(solver)
    if op is None:
        op = BalanceOperator(solver.transcription, stored=False)  # points only; values from ``dense``
        g, e = dense(op.sg), dense(op.se)
    else:
        g, e = op.dense(np.asarray(z, float))
    loads = _loads_function(solver, scene, params)
    col = lambda v: np.asarray(v, float)[:, None]
    tip = np.array([solver.summary(z, params)[1:]])
    force, moment, R = _moment_balance(solver, op, [col(v) for v in g], [col(v) for v in e],
                                       loads, tip, np.atleast_2d(params), point_loads)
    return force[0], float(moment[0]), float(R[0])


def balance_many(solver, params: np.ndarray, Z: np.ndarray, scene):
    """:func:`balance` of m states on one mesh at once, or None when the mesh has no stored
    operator, the loads are not vectorisable, or a per-point field is a load (scaled with λ).

    Parameters
    ----------
    params : ndarray, shape (m, n_params)
    Z : ndarray, shape (m, n_nodes)
    scene : Scene
        The scene whose per-point fields (fibre angle, stiffness: geometry, the same at every
        state of a load ray) all states share.

    Returns
    -------
    (ndarray (m, 2), ndarray (m,), ndarray (m,)) or None
        Clamp forces, clamp moments, max |R|.
    """
    op = operator_for(solver)
    loads = set(solver._scale_lin) | set(solver._scale_sq)
    slices = solver.layout.slices
    if (op is None or not op.lgl or _vectorised(solver) is None
            or any(loads.intersection(range(slices[n].start, slices[n].stop))
                   for n in solver._node_fields if n in slices)):
        return None
    P, Z = np.atleast_2d(params), np.atleast_2d(Z)
    g, e = op.dense(Z.T)
    tip = np.array([solver.summary(z, p)[1:] for z, p in zip(Z, P)])
    return _moment_balance(solver, op, g, e, _loads_function(solver, scene, P), tip, P)


def _vectorised(solver):
    """The solver's pointwise loads replayed on numpy arrays (:mod:`actuator_design.equilibrium.pointwise`),
    or None when the function cannot be (CasADi then evaluates it point by point)."""
    if solver not in _VECTORISED:
        dens_f, tip_f = solver._pointwise
        try:
            _VECTORISED[solver] = (VectorisedSX(dens_f, shared=[dens_f.n_in() - 1]),
                                   VectorisedSX(tip_f, shared=[tip_f.n_in() - 1]))
        except NotVectorisable:
            _VECTORISED[solver] = None
    return _VECTORISED[solver]


def _loads_function(solver, scene, params):
    """(θ, θ', x, y, s) arrays of shape (k, m) -> (τ, Fx, Fy, M) of every term, each (k, m)."""
    dens_f = solver._pointwise[0]
    fast = _vectorised(solver)

    def loads(th, dth, x, y, s):
        fields = [np.asarray(fn(scene, s), float) for fn in solver._node_fields.values()]
        if fast is not None:
            return fast[0](th, x, y, dth, *[np.broadcast_to(f.reshape(-1, *(1,) * (th.ndim - 1)),
                                                            th.shape) for f in fields], params)
        row = lambda v: np.asarray(v, float).reshape(1, -1)  # CasADi evaluates rows pointwise
        return [np.asarray(v, float).reshape(th.shape)
                for v in dens_f(row(th), row(x), row(y), row(dth), *map(row, fields), params[0])]
    return loads


def _moment_balance(solver, op, g, e, loads, tip, P, point_loads=None):
    """The clamp reaction and max |R| of m states (module doc). ``g``, ``e``: (θ, θ', x, y) at the
    quadrature points and the residual edges, each (k, m); ``tip``: (θ(1), x(1), y(1)) per state,
    shape (m, 3); ``P``: parameters, shape (m, n_params); ``point_loads``: (s, Fx, Fy, x, y) of
    point forces on one state (contact), which enter n(s) and ∫ r×F for every edge s ≤ s_j."""
    fast = _vectorised(solver)
    x, y, xe, ye = g[2], g[3], e[2], e[3]
    n_g = x.shape[0]  # one evaluation for the quadrature points and the residual edges
    tau, Fx, Fy, moment = loads(*(np.concatenate((u, v)) for u, v in zip(g, e)),
                                np.concatenate((op.sg, op.se)))
    tau, Fx, Fy, moment = tau[:n_g], Fx[:n_g], Fy[:n_g], moment[n_g:]
    tip_theta, tip_x, tip_y = tip.T
    if fast is not None:
        m, fx, fy = fast[1](tip_theta, tip_x, tip_y, P)
    else:
        m, fx, fy = (np.array([float(v)]) for v in solver._pointwise[1](*tip[0], P[0]))
    wg = op.wg[:, None]

    def tail(values):  # ∫_{edge_k}^1 values, for every edge k, shape (n_edges, m)
        per = (wg * values).reshape(op.n_sub, -1, values.shape[1]).sum(1)
        return np.concatenate((np.cumsum(per[::-1], axis=0)[::-1], np.zeros((1, per.shape[1]))))

    I_tau, I_Fx, I_Fy, I_rF = tail(tau), tail(Fx), tail(Fy), tail(x * Fy - y * Fx)
    if point_loads is not None:  # beyond each edge (all edges, the clamp's first)
        sj, pfx, pfy, pxj, pyj = (np.asarray(v, float) for v in point_loads)
        edges = _all_edges(op)
        beyond = (sj[None, :] >= edges[:, None] - 1e-14).astype(float)  # (n_edges, n_points)
        I_Fx = I_Fx + (beyond @ pfx)[:, None]
        I_Fy = I_Fy + (beyond @ pfy)[:, None]
        I_rF = I_rF + (beyond @ (pxj * pfy - pyj * pfx))[:, None]
    r1xf = tip_x * fy - tip_y * fx
    clamp_force = -np.stack([fx + I_Fx[0], fy + I_Fy[0]], axis=1)
    clamp_moment = -(m + r1xf + I_tau[0] + I_rF[0])
    # residual at the edges where θ' is defined (not on element boundaries, where it may jump)
    keep = op.keep  # moment: the internal moment ∂V/∂θ' (= bθ' for bending) at the edges
    nx, ny = fx + I_Fx[keep], fy + I_Fy[keep]
    R = moment - m - r1xf - I_tau[keep] - I_rF[keep] + (xe * ny - ye * nx)
    return clamp_force, clamp_moment, np.max(np.abs(R), axis=0)


def _all_edges(op) -> np.ndarray:
    """Arc lengths of every sub-interval edge, the clamp's first: the rows of ``tail``."""
    w = op.wg.reshape(op.n_sub, -1).sum(1)
    return np.concatenate(([0.0], np.cumsum(w)))
