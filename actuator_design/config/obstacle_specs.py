"""Configuration of obstacles (contact, :mod:`actuator_design.contact`): walls and pegs.

    obstacles:                                   # dimensionless scene: rod lengths, rad
      - {type: wall, point: {x: 0, y: -0.1}, normal_angle: 90 deg}   # a floor 0.1 below the clamp
      - {type: peg, centre: {x: 0.6, y: -0.3}, radius: 0.1}

In a physical scene positions and radii carry lengths ("2 mm") and the rod keeps half its
thickness from every obstacle; in a dimensionless one ``contact_gap`` (rod lengths, default 0) sets it.
"""
from __future__ import annotations

import math
from typing import Literal

from ..obstacles import Peg, Wall
from .base import Angle, Number, Q, StrictModel, tagged
from .errors import error
from .vectors import LengthXY, NumberXY

__all__ = ["WallSpec", "PegSpec", "PhysicalWall", "PhysicalPeg", "DimensionlessObstacle", "PhysicalObstacle",
           "MAX_OBSTACLES"]

MAX_OBSTACLES = 32  # bounds the constraint rows (each obstacle: one row per point of the mesh)


class WallSpec(StrictModel):
    """A wall through ``point`` (rod lengths), its free side towards ``normal_angle``."""

    type: Literal["wall"]
    point: NumberXY
    normal_angle: Angle

    def to_obstacle(self, length: float = 1.0) -> Wall:
        return Wall((self.point.x / length, self.point.y / length), float(self.normal_angle))


class PegSpec(StrictModel):
    """A solid disc (a peg, an object) about ``centre`` with ``radius`` (rod lengths)."""

    type: Literal["peg"]
    centre: NumberXY
    radius: Q("dimensionless", gt=0, le=100)

    def to_obstacle(self, length: float = 1.0) -> Peg:
        return Peg((self.centre.x / length, self.centre.y / length), float(self.radius) / length)


class PhysicalWall(WallSpec):
    point: LengthXY


class PhysicalPeg(PegSpec):
    centre: LengthXY
    radius: Q("length", gt=0)


DimensionlessObstacle = tagged(("obstacles",), WallSpec, PegSpec)
PhysicalObstacle = tagged(("obstacles",), PhysicalWall, PhysicalPeg)


def obstacles_of(specs, length: float = 1.0) -> tuple:
    """The scene's obstacles (units of ℓ) from their configs; positions must be finite."""
    out = []
    for k, spec in enumerate(specs or ()):
        ob = spec.to_obstacle(length)
        nums = (*getattr(ob, "point", ()), *getattr(ob, "centre", ()), getattr(ob, "radius", 0.0))
        if not all(math.isfinite(v) for v in nums):
            raise error("positions and radii must be finite", f"obstacles[{k}]")
        out.append(ob)
    return tuple(out)
