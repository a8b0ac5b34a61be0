"""Piecewise-linear θ with the midpoint rule: the low-order (second-order) transcription.

Unknowns θ_i at s_i = i/N; on each interval θ' = (θ_{i+1} − θ_i)/Δ and every density is evaluated
at the midpoint with θ = (θ_i + θ_{i+1})/2. Positions follow the same rule: the rod is the polygon
r_{i+1} = r_i + Δ (cos θ_{i+½}, sin θ_{i+½}). Errors are O(Δ²) = O(N⁻²).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from actuator_design.transcription.base import Transcription

__all__ = ["Midpoint"]


class Midpoint(Transcription):
    """Midpoint rule on ``elements`` = N equal intervals."""

    name = "midpoint"
    order_description = "second order, O(N^-2)"

    def __init__(self, elements: int = 100):
        self.N = int(elements)
        self.h = 1.0 / self.N
        self._nodes = np.linspace(0.0, 1.0, self.N + 1)
        self._sq = 0.5 * (self._nodes[1:] + self._nodes[:-1])
        self._wq = np.full(self.N, self.h)
        mass = np.full(self.N + 1, self.h)
        mass[[0, -1]] = 0.5 * self.h
        self._mass = mass

    @property
    def breakpoints(self):
        return self._nodes

    def structure(self):
        return (self.name, self.N)

    def point_values(self, z):
        return 0.5 * (z[1:] + z[:-1]), (z[1:] - z[:-1]) / self.h

    def point_positions(self, theta_q):
        c, s = ca.cos(theta_q), ca.sin(theta_q)
        # r at the midpoint = sum of the previous full steps + half a step
        xn = ca.cumsum(self.h * c)
        yn = ca.cumsum(self.h * s)
        return xn - 0.5 * self.h * c, yn - 0.5 * self.h * s

    def theta_dense(self, z, s):
        """θ piecewise linear; θ' interpolated linearly between the interval slopes, which are
        second-order accurate at the midpoints (and so is the interpolant, away from the ends)."""
        s = np.clip(np.asarray(s, float), 0.0, 1.0)
        z = np.asarray(z, float)
        slopes = np.diff(z) / self.h
        return np.interp(s, self._nodes, z), np.interp(s, self._sq, slopes)
