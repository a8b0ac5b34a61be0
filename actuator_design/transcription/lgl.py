"""Spectral elements on Legendre–Gauss–Lobatto (LGL) nodes: the high-order transcription.

θ is a continuous piecewise polynomial of degree d on E equal elements (E·d + 1 unknowns). The
energy is integrated with the (d+1)-point LGL rule of each element, which integrates the bending
energy ½θ'² exactly; θ' comes from the spectral differentiation matrix and the positions
r = ∫(cos θ, sin θ) from the spectral integration matrix. For smooth solutions the error decays
like (1/E)^(2d) in the energy and faster than any power of d (spectral convergence).
"""
from __future__ import annotations

from functools import lru_cache
from typing import Optional, Tuple

import casadi as ca
import numpy as np
from numpy.polynomial import legendre as L

from actuator_design.transcription.base import Transcription

__all__ = ["LGL", "graded_breakpoints", "lgl_nodes_weights", "differentiation_matrix", "integration_matrix"]


@lru_cache(maxsize=None)
def lgl_nodes_weights(d: int):
    """LGL nodes τ ∈ [-1, 1] (ascending) and weights, shape (d+1,), for polynomial degree d ≥ 1."""
    cd = np.zeros(d + 1)
    cd[-1] = 1.0
    interior = np.sort(np.real(L.legroots(L.legder(cd)))) if d > 1 else np.array([])
    tau = np.concatenate(([-1.0], interior, [1.0]))
    # Newton polish of the interior roots of P'_d for full accuracy at high degree.
    for _ in range(3):
        if d > 1:
            d1 = L.legval(tau[1:-1], L.legder(cd))
            d2 = L.legval(tau[1:-1], L.legder(cd, 2))
            tau[1:-1] -= d1 / d2
    w = 2.0 / (d * (d + 1) * L.legval(tau, cd) ** 2)
    return tau, w


@lru_cache(maxsize=None)
def _bary_weights(d: int):
    tau, _ = lgl_nodes_weights(d)
    diff = tau[:, None] - tau[None, :]
    np.fill_diagonal(diff, 1.0)
    return 1.0 / np.prod(diff, axis=1)


@lru_cache(maxsize=None)
def differentiation_matrix(d: int) -> np.ndarray:
    """D with (D f)_j = p'(τ_j) for the interpolant p of f on the LGL nodes, shape (d+1, d+1)."""
    tau, _ = lgl_nodes_weights(d)
    lam = _bary_weights(d)
    diff = tau[:, None] - tau[None, :]
    np.fill_diagonal(diff, 1.0)
    D = (lam[None, :] / lam[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))  # negative-sum trick: exact for constants
    return D


@lru_cache(maxsize=None)
def integration_matrix(d: int) -> np.ndarray:
    """S with (S f)_j = ∫_{-1}^{τ_j} p(τ) dτ for the interpolant p of f, shape (d+1, d+1)."""
    tau, _ = lgl_nodes_weights(d)
    V = L.legvander(tau, d)  # f = V c (Legendre coefficients)
    antider = np.zeros((d + 1, d + 1))  # columns: ∫_{-1}^{τ_j} P_m
    for m in range(d + 1):
        c = np.zeros(d + 1)
        c[m] = 1.0
        antider[:, m] = L.legval(tau, L.legint(c, lbnd=-1.0))
    return antider @ np.linalg.inv(V)


def _interp_matrix(d: int, t: np.ndarray) -> np.ndarray:
    """Barycentric interpolation matrix from the LGL nodes to points t ∈ [-1, 1], shape (len(t), d+1)."""
    tau, _ = lgl_nodes_weights(d)
    lam = _bary_weights(d)
    diff = t[:, None] - tau[None, :]
    exact = np.abs(diff) <= 1e-15
    diff[exact] = 1.0
    M = lam[None, :] / diff
    M /= M.sum(axis=1, keepdims=True)
    rows = np.where(exact.any(axis=1))[0]
    M[rows] = exact[rows].astype(float)
    return M


class LGL(Transcription):
    """Spectral elements of polynomial ``degree`` d on ``elements`` elements of [0, 1].

    Parameters
    ----------
    elements : int
        Number of base elements (equal lengths 1/E).
    degree : int
        Polynomial degree per element.
    clamp_levels, tip_levels : int
        Geometric grading: the first (last) base element is split at 2^-j/E (1 − 2^-j/E),
        j = 1..levels, so the element next to the clamp (tip) has length 2^-levels/E. Boundary
        layers of width ~1/k (THEORY §5: k = √2 h at the clamp in strong fields, √|p| under large
        loads) are resolved with levels ≈ log2(k/E) extra elements instead of k/3 uniform ones.
    """

    name = "lgl"
    order_description = "spectral in the degree; O(E^-2d) in the energy"

    def __init__(self, elements: int = 4, degree: int = 10, clamp_levels: int = 0, tip_levels: int = 0,
                 split_at=()):
        self.d = int(degree)
        self.levels = (int(clamp_levels), int(tip_levels))
        bp = graded_breakpoints(int(elements), *self.levels)
        # extra boundaries (contact points), none closer than 1e-6 to another: no sliver elements
        split = []
        for v in sorted(float(v) for v in split_at):
            if np.min(np.abs(bp - v)) > 1e-6 and (not split or v - split[-1] > 1e-6):
                split.append(v)
        self.split = tuple(split)
        self._bp = np.union1d(bp, self.split) if self.split else bp
        self.E = self._bp.size - 1
        tau, w = lgl_nodes_weights(self.d)
        self._tau, self._w = tau, w
        self.uniform = not any(self.levels) and not self.split
        if self.uniform:  # the equal-element formulas, bit for bit (warm-started analyses rely on it)
            self.J = 0.5 / self.E
            self._J = np.full(self.E, self.J)
            starts = np.arange(self.E) / self.E
            self._wq = np.tile(self.J * w, self.E)
        else:
            self._J = 0.5 * np.diff(self._bp)  # ds/dτ per element, shape (E,)
            self.J = self._J
            starts = self._bp[:-1]
            self._wq = (self._J[:, None] * w[None, :]).ravel()
        self._sq = (starts[:, None] + self._J[:, None] * (tau[None, :] + 1.0)).ravel()
        self._nodes = np.append((starts[:, None] + self._J[:, None] * (tau[None, :-1] + 1.0)).ravel(), 1.0)
        # global node index of each quadrature point
        self._gidx = (np.arange(self.E)[:, None] * self.d + np.arange(self.d + 1)[None, :]).ravel()
        mass = np.zeros(self._nodes.size)
        np.add.at(mass, self._gidx, self._wq)
        self._mass = mass

    @property
    def breakpoints(self):
        return self._bp.copy()

    def structure(self):
        return ((self.name, self.E, self.d) + ((self.levels,) if any(self.levels) else ())
                + ((self.split,) if self.split else ()))

    def point_values(self, z):
        theta_q = z[self._gidx.tolist()]
        D = differentiation_matrix(self.d)
        Ds = [ca.DM(D / self.J)] * self.E if self.uniform else [ca.DM(D / j) for j in self._J]
        kappa = [ca.mtimes(Ds[e], z[e * self.d:(e + 1) * self.d + 1]) for e in range(self.E)]
        return theta_q, ca.vertcat(*kappa)

    def point_positions(self, theta_q):
        S0 = integration_matrix(self.d)
        Ss = [ca.DM(S0 * self.J)] * self.E if self.uniform else [ca.DM(S0 * j) for j in self._J]
        n = self.d + 1
        xs, ys = [], []
        x0 = y0 = 0
        for e in range(self.E):
            S = Ss[e]
            th = theta_q[e * n:(e + 1) * n]
            xe = x0 + ca.mtimes(S, ca.cos(th))
            ye = y0 + ca.mtimes(S, ca.sin(th))
            xs.append(xe)
            ys.append(ye)
            x0, y0 = xe[-1], ye[-1]
        return ca.vertcat(*xs), ca.vertcat(*ys)

    def element_values(self, z) -> Tuple[np.ndarray, np.ndarray]:
        """θ and θ' at every element's nodes, shapes (E, d + 1) (rad, rad per ℓ): what
        :meth:`theta_dense` interpolates, for a caller that evaluates one ``z`` many times."""
        zel = np.asarray(z, float)[np.arange(self.E)[:, None] * self.d + np.arange(self.d + 1)[None, :]]
        return zel, (zel @ differentiation_matrix(self.d).T) / self._J[:, None]

    def theta_dense(self, z, s, values: Optional[Tuple[np.ndarray, np.ndarray]] = None):
        """θ and θ' at arc lengths ``s`` (any shape) of the interpolant of the nodal values ``z``;
        ``values``: :meth:`element_values` of ``z``, computed once by the caller."""
        shape = np.shape(s)
        s = np.clip(np.atleast_1d(np.asarray(s, float)).ravel(), 0.0, 1.0)
        if self.uniform:
            e = np.minimum((s * self.E).astype(int), self.E - 1)
            t = (s - e / self.E) / self.J - 1.0
        else:
            e = np.clip(np.searchsorted(self._bp, s, side="right") - 1, 0, self.E - 1)
            t = (s - self._bp[e]) / self._J[e] - 1.0
        # every point at once: its element's nodal values and their derivative, weighted by the
        # barycentric row of its local coordinate (no loop over elements: few points are common)
        zel, dzel = self.element_values(z) if values is None else values
        M = _interp_matrix(self.d, t)
        return (np.einsum("ij,ij->i", M, zel[e]).reshape(shape),
                np.einsum("ij,ij->i", M, dzel[e]).reshape(shape))


def graded_breakpoints(elements: int, clamp_levels: int = 0, tip_levels: int = 0) -> np.ndarray:
    """Element boundaries on [0, 1]: E equal elements, the first split geometrically towards the
    clamp (boundaries 2^-j/E, j = 1..clamp_levels) and the last towards the tip, shape (E + levels + 1,)."""
    E = int(elements)
    bp = np.linspace(0.0, 1.0, E + 1)
    first = 1.0 / E
    if E == 1 and clamp_levels and tip_levels:  # both splits inside one element: halve it first
        bp, first = np.array([0.0, 0.5, 1.0]), 0.5
    clamp = 2.0 ** -np.arange(int(clamp_levels), 0, -1) * first
    tip = 1.0 - 2.0 ** -np.arange(1, int(tip_levels) + 1) * first
    return np.unique(np.concatenate((bp, clamp, tip)))
