"""Kinematics of the rod, apart from the energy terms that read it (THEORY §4).

A transcription builds one kinematics object at its quadrature points and one at the free end; the
energy terms read the rod's configuration only through it: the director frame (tangent, normal),
the curvature and, when a term asks, the positions. Positions r(s) = ∫₀ˢ (cos θ, sin θ) dσ cost a
dense coupling of all unknowns, so they are built lazily, on the first access of ``x``, ``y`` or
``position`` — a scene whose terms never ask for them keeps a banded Hessian.

Only the planar rod exists today (the configuration is the angle θ(s)); a 3-D rod is a new
kinematics class with the same attribute names (directors, curvature, positions), not a second
package.
"""
from __future__ import annotations

from typing import Callable, Dict, Optional, Tuple

import casadi as ca

__all__ = ["PlanarKinematics", "PlanarTip"]

PositionBuilder = Callable[[], Tuple[ca.SX, ca.SX]]


class PlanarKinematics:
    """The planar rod at a set of points (the transcription's quadrature points, or one point).

    Parameters
    ----------
    theta : SX, shape (n,)
        Director angle θ from the undeformed axis c1, rad.
    kappa : SX, shape (n,)
        Curvature θ', units of 1/ℓ.
    fields : dict of str -> SX, shape (n,) each
        Per-point material fields (e.g. fibre angle ``alpha``, relative stiffness ``b``), read from
        the NLP parameter vector.
    positions : callable () -> (x, y), or (x, y), optional
        Builds the positions (units of ℓ) on first use; ``None`` when unavailable.

    Attributes
    ----------
    positions_built : bool
        Whether some term asked for the positions (the transcription then reports that the energy
        couples all unknowns).
    """

    def __init__(self, theta: ca.SX, kappa: ca.SX, fields: Dict[str, ca.SX],
                 positions=None):
        self.theta = theta
        self.kappa = kappa
        self.fields = fields
        if callable(positions):
            self._builder: Optional[PositionBuilder] = positions
            self._xy = None
        else:
            self._builder = None
            self._xy = positions
        self.positions_built = False

    # -- directors -------------------------------------------------------------------------------
    @property
    def tangent(self) -> Tuple[ca.SX, ca.SX]:
        """d1 = (cos θ, sin θ), the unit tangent (dimensionless)."""
        return ca.cos(self.theta), ca.sin(self.theta)

    @property
    def normal(self) -> Tuple[ca.SX, ca.SX]:
        """d2 = (−sin θ, cos θ), the unit normal, tangent rotated by +90° (dimensionless)."""
        return -ca.sin(self.theta), ca.cos(self.theta)

    @property
    def curvature(self) -> ca.SX:
        """θ', units of 1/ℓ (alias of ``kappa``)."""
        return self.kappa

    # -- positions (lazy) ------------------------------------------------------------------------
    @property
    def position(self) -> Tuple[ca.SX, ca.SX]:
        """r = (x, y), units of ℓ, clamp at the origin; built on first access."""
        if self._xy is None:
            if self._builder is None:
                raise RuntimeError("this kinematics has no positions")
            self._xy = self._builder()
        self.positions_built = True
        return self._xy

    @property
    def x(self) -> ca.SX:
        return self.position[0]

    @property
    def y(self) -> ca.SX:
        return self.position[1]


class PlanarTip:
    """The free end s = 1: director angle θ(1) (rad) and position (x(1), y(1)) (units of ℓ)."""

    def __init__(self, theta: ca.SX, x: ca.SX, y: ca.SX):
        self.theta, self.x, self.y = theta, x, y

    @property
    def tangent(self) -> Tuple[ca.SX, ca.SX]:
        return ca.cos(self.theta), ca.sin(self.theta)

    @property
    def position(self) -> Tuple[ca.SX, ca.SX]:
        return self.x, self.y
