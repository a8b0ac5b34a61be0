"""Rigid obstacles a rod can touch: walls (half-planes) and pegs (discs), frictionless.

Each obstacle gives a signed distance d(r) of a point r of the centre line (units of ℓ), positive on
the free side; contact is the unilateral constraint d(r(s)) ≥ gap (the rod's half-thickness, so its
surface and not its centre line touches). :mod:`actuator_design.contact` imposes it at the
transcription's quadrature points and the tip; the contact force on the rod at a point is
μ ∇d (μ ≥ 0 the constraint's multiplier): normal to the obstacle, pushing the rod away.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field as dc_field
from typing import Tuple

import casadi as ca
import numpy as np

__all__ = ["Wall", "Peg", "Obstacle"]


@dataclass(frozen=True)
class Wall:
    """The half-plane (r − point)·n ≤ 0 is solid, n = (cos normal_angle, sin normal_angle) pointing
    into the free side; units of ℓ and rad (a floor below the rod at y = −d: point (0, −d),
    normal_angle π/2)."""

    point: Tuple[float, float]
    normal_angle: float
    kind: str = dc_field(default="wall", init=False)

    def distance(self, x, y):
        """Signed distance (CasADi or numpy), positive on the free side."""
        return (x - self.point[0]) * math.cos(self.normal_angle) + (y - self.point[1]) * math.sin(self.normal_angle)

    def normal(self, x, y) -> np.ndarray:
        """∇d at points, shape (2, k)."""
        k = np.size(x)
        return np.tile([[math.cos(self.normal_angle)], [math.sin(self.normal_angle)]], (1, k))

    def describe(self) -> str:
        return (f"wall through ({self.point[0]:.4g}, {self.point[1]:.4g}) l, free side towards "
                f"{math.degrees(self.normal_angle):.4g} deg")


@dataclass(frozen=True)
class Peg:
    """A solid disc of ``radius`` about ``centre`` (units of ℓ)."""

    centre: Tuple[float, float]
    radius: float
    kind: str = dc_field(default="peg", init=False)

    def distance(self, x, y):
        dx, dy = x - self.centre[0], y - self.centre[1]
        if isinstance(dx, (ca.SX, ca.MX)):
            return ca.sqrt(dx * dx + dy * dy) - self.radius
        return np.hypot(dx, dy) - self.radius

    def normal(self, x, y) -> np.ndarray:
        dx, dy = np.asarray(x, float) - self.centre[0], np.asarray(y, float) - self.centre[1]
        r = np.hypot(dx, dy)
        return np.vstack([np.atleast_1d(dx / r), np.atleast_1d(dy / r)])

    def describe(self) -> str:
        return f"peg at ({self.centre[0]:.4g}, {self.centre[1]:.4g}) l, radius {self.radius:.4g} l"


Obstacle = (Wall, Peg)
