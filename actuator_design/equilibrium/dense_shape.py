"""What an equilibrium result evaluates between its nodes, as objects that pickle (a result computed
in a forked process, :mod:`.forked`, or by a worker travels back whole): the dense shape, the clamp
curvature, the force and moment balance, and the self-intersection test."""
from __future__ import annotations

import numpy as np

from actuator_design.equilibrium.balance import balance

__all__ = ["DenseShape", "Balance", "clamp_curvature", "self_intersecting", "never_intersects", "nan_shape",
           "nan_balance"]

_GL_T, _GL_W = np.polynomial.legendre.leggauss(12)
_GL4_T, _GL4_W = np.polynomial.legendre.leggauss(4)
#: a sorted grid of at least this many points is integrated piece by piece (:class:`DenseShape`)
_MANY = 200
#: ... when no piece turns by more than this (rad): piece length × max |θ'|
_SHORT = 0.25


class DenseShape:
    """s -> (θ, θ', x, y): the transcription's interpolant of θ at the nodes ``z``, positions by
    Gauss quadrature of (cos θ, sin θ) between the breakpoints (exact to rounding for LGL; the
    midpoint rod is the polygon through its nodes).

    Parameters
    ----------
    transcription : the solver's transcription (``theta_dense``, ``breakpoints``, ``nodes``)
    z : ndarray, shape (n_nodes,)
        θ at the nodes, rad.
    """

    def __init__(self, transcription, z: np.ndarray):
        self.tr, self.z = transcription, np.asarray(z, float)
        self._bp_xy = None  # x, y at the breakpoints, computed on first use
        self._values = None  # the LGL interpolant's element values, computed on first use

    def _theta(self, s):
        """θ, θ' at ``s`` (LGL): its element values computed once for this shape."""
        if self._values is None:
            self._values = self.tr.element_values(self.z)
        return self.tr.theta_dense(self.z, s, self._values)

    def _breakpoint_positions(self):
        if self._bp_xy is None:
            bp = self.tr.breakpoints
            a, b = bp[:-1], bp[1:]
            sg = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * _GL_T[None, :]
            thg, _ = self._theta(sg.ravel())
            wg = 0.5 * (b - a)[:, None] * _GL_W[None, :]
            self._bp_xy = (np.concatenate(([0.0], np.cumsum((wg * np.cos(thg.reshape(sg.shape))).sum(1)))),
                           np.concatenate(([0.0], np.cumsum((wg * np.sin(thg.reshape(sg.shape))).sum(1)))))
        return self._bp_xy

    def __call__(self, s):
        tr, z = self.tr, self.z
        if tr.name == "midpoint":
            th_q = 0.5 * (z[1:] + z[:-1])
            xn = np.concatenate(([0.0], np.cumsum(tr.h * np.cos(th_q))))
            yn = np.concatenate(([0.0], np.cumsum(tr.h * np.sin(th_q))))
            th, dth = tr.theta_dense(z, s)
            return th, dth, np.interp(s, tr.nodes, xn), np.interp(s, tr.nodes, yn)
        bp = tr.breakpoints
        a = bp[:-1]
        s = np.clip(np.asarray(s, float), 0.0, 1.0)
        if s.ndim == 1 and s.size >= _MANY and np.all(np.diff(s) >= 0.0):
            th, dth = self._theta(s)
            knots = np.union1d(s, bp)  # the breakpoints too: no kink of θ inside a piece
            if np.max(np.diff(knots)) * np.max(np.abs(dth)) <= _SHORT:
                # a dense grid: positions by short Gauss rules between neighbouring samples, summed
                # (4 angles per sample instead of 12: the pieces turn by ≤ 0.25 rad, the rule's
                # error ~ 0.25^8/3.5e6 of a piece's length, below rounding)
                lo, hi = knots[:-1], knots[1:]
                thg = self._theta((0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * _GL4_T).ravel())[0]
                w = 0.5 * (hi - lo)[:, None] * _GL4_W
                thg = thg.reshape(w.shape)
                at = np.searchsorted(knots, s)
                X = np.concatenate(([0.0], np.cumsum((w * np.cos(thg)).sum(1))))
                Y = np.concatenate(([0.0], np.cumsum((w * np.sin(thg)).sum(1))))
                return th, dth, X[at], Y[at]
        # each point from the breakpoint before it by a 12-point Gauss rule: θ at the points and at
        # their Gauss points in one interpolation
        X0, Y0 = self._breakpoint_positions()
        k = np.clip(np.searchsorted(bp, s, side="right") - 1, 0, len(a) - 1)
        lo = bp[k]
        pts = lo[..., None] + 0.5 * (s - lo)[..., None] * (_GL_T + 1.0)
        both, dboth = self._theta(np.concatenate([np.ravel(s), pts.ravel()]))
        th, dth = both[:s.size].reshape(s.shape), dboth[:s.size].reshape(s.shape)
        th_p = both[s.size:].reshape(pts.shape)
        half = 0.5 * (s - lo)[..., None] * _GL_W
        return th, dth, X0[k] + (half * np.cos(th_p)).sum(-1), Y0[k] + (half * np.sin(th_p)).sum(-1)


class Balance:
    """() -> the force and moment balance of a result (:func:`actuator_design.equilibrium.balance.balance`),
    computed once.

    Pickled as its value (CasADi functions do not pickle, and a contact result's mesh is not the one
    its scene and options build): a result sent back by a worker carries its balance, computed there.
    """

    def __init__(self, solver, params, dense: DenseShape, scene, z, point_loads=None):
        self.solver, self.params, self.dense, self.scene, self.z = solver, params, dense, scene, z
        self.point_loads = point_loads
        self._value = None

    def __getstate__(self):
        return {"_value": self()}

    def __call__(self):
        if self._value is None:
            self._value = balance(self.solver, self.params, self.dense, self.scene, self.z,
                                  point_loads=self.point_loads)
        return self._value


def clamp_curvature(transcription, z) -> float:
    """θ'(0) of the interpolant of θ at the nodes ``z``."""
    return transcription.theta_dense(z, np.array([0.0]))[1][0]


def nan_shape(s):
    """The dense shape of a result whose iterate is not finite: NaN everywhere."""
    return (np.full(np.shape(s), np.nan),) * 4


def nan_balance():
    """The balance of a result whose iterate is not finite."""
    return np.full(2, np.nan), np.nan, np.nan


def never_intersects(x, y) -> bool:
    """The self-intersection test of a result whose iterate is not finite."""
    return False


def self_intersecting(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether the polyline through the nodes crosses itself (non-adjacent segments)."""
    p = np.stack([x, y], 1)
    if len(p) > 400:
        p = p[np.linspace(0, len(p) - 1, 400).astype(int)]
    A, B = p[:-1], p[1:]
    d = B - A
    n = len(A)
    for i in range(n - 2):
        Ai, di = A[i], d[i]
        Aj, dj = A[i + 2:], d[i + 2:]
        den = di[0] * dj[:, 1] - di[1] * dj[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((Aj[:, 0] - Ai[0]) * dj[:, 1] - (Aj[:, 1] - Ai[1]) * dj[:, 0]) / den
            u = ((Aj[:, 0] - Ai[0]) * di[1] - (Aj[:, 1] - Ai[1]) * di[0]) / den
        if np.any((den != 0) & (t > 0) & (t < 1) & (u > 0) & (u < 1)):
            return True
    return False
