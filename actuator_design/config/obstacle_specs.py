"""Configuration of obstacles (contact, :mod:`actuator_design.contact.equilibrium`): walls, pegs, convex
polygons and straight channels.

    obstacles:                                   # dimensionless scene: rod lengths, rad
      - {type: wall, point: {x: 0, y: -0.1}, normal_angle: 90 deg}   # a floor 0.1 below the clamp
      - {type: peg, centre: {x: 0.6, y: -0.3}, radius: 0.1}
      - {type: polygon, vertices: [{x: 0.5, y: -0.3}, {x: 0.8, y: -0.3}, {x: 0.8, y: -0.2}]}
      - {type: channel, centre: {x: 0, y: 0}, angle: 0 deg, width: 0.2}  # two walls, 0.2 apart
      - type: lumen                              # a curved tube the rod lies in
        start: {x: 0, y: 0}
        angle: 0 deg
        radius: 0.08                             # the tube's half-width, centre line to wall
        path: [{straight: 0.3}, {arc: 0.5, turn: 60 deg}, {straight: 0.5}]

In a physical scene positions and radii carry lengths ("2 mm") and the rod keeps half its
thickness from every obstacle; in a dimensionless one ``contact_gap`` (rod lengths, default 0) sets it.
"""
from __future__ import annotations

import dataclasses
import math
from typing import List, Literal, Optional

from pydantic import Field, model_validator

from actuator_design.config.base import Angle, LengthXY, Number, NumberXY, Q, StrictModel, tagged
from actuator_design.config.errors import ConfigError, error
from actuator_design.contact.obstacles import Lumen, Peg, Polygon, Wall

__all__ = ["WallSpec", "PegSpec", "PolygonSpec", "ChannelSpec", "LumenSpec", "PhysicalWall", "PhysicalPeg",
           "PhysicalPolygon", "PhysicalChannel", "PhysicalLumen", "DimensionlessObstacle", "PhysicalObstacle", "MAX_OBSTACLES", "MAX_VERTICES"]

MAX_OBSTACLES = 32  # bounds the constraint rows (each obstacle: one row per point of the mesh)
MAX_VERTICES = 64  # bounds a polygon's distance expression (a few operations per edge and point)
MAX_PIECES = 32  # bounds a lumen's distance expression (a few operations per piece and point)
#: the largest coordinate, radius or length of an obstacle, in rod lengths (beyond it an obstacle is
#: out of any rod's reach, and its distance expressions would overflow)
MAX_EXTENT = 1e6


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


class PolygonSpec(StrictModel):
    """A solid convex polygon through ``vertices`` (rod lengths), in order around it."""

    type: Literal["polygon"]
    vertices: List[NumberXY] = Field(min_length=3, max_length=MAX_VERTICES)

    @model_validator(mode="after")
    def _convex(self):
        xy = [(float(v.x), float(v.y)) for v in self.vertices]
        if not all(math.isfinite(c) and abs(c) <= MAX_EXTENT for p in xy for c in p):
            raise error(f"positions must be finite and within {MAX_EXTENT:g} rod lengths of the clamp", "vertices")
        try:
            Polygon(tuple(xy))
        except ValueError as err:
            raise error(str(err), "vertices") from None
        return self

    def to_obstacle(self, length: float = 1.0) -> Polygon:
        return Polygon(tuple((v.x / length, v.y / length) for v in self.vertices))


class ChannelSpec(StrictModel):
    """A straight channel: two parallel walls ``width`` apart (rod lengths, wall to wall), about
    a centre line through ``centre`` at ``angle`` to the x axis; the rod is inside it."""

    type: Literal["channel"]
    centre: NumberXY
    angle: Angle = 0.0
    width: Q("dimensionless", gt=0, le=100)

    def to_obstacle(self, length: float = 1.0) -> tuple:
        c, a, half = (self.centre.x / length, self.centre.y / length), float(self.angle), 0.5 * float(self.width) / length
        n = (-math.sin(a), math.cos(a))  # the centre line's left normal
        return (Wall((c[0] + half * n[0], c[1] + half * n[1]), a - 0.5 * math.pi),   # its left wall
                Wall((c[0] - half * n[0], c[1] - half * n[1]), a + 0.5 * math.pi))   # its right wall


class LumenPiece(StrictModel):
    """One piece of a lumen's centre line: ``{straight: L}`` or ``{arc: L, turn: angle}`` (rod lengths;
    a positive turn bends to the left)."""

    straight: Optional[Q("dimensionless", gt=0, le=1000)] = None
    arc: Optional[Q("dimensionless", gt=0, le=1000)] = None
    turn: Optional[Angle] = None

    @model_validator(mode="after")
    def _one_kind(self):
        if (self.straight is None) == (self.arc is None) or (self.arc is None) != (self.turn is None):
            raise error("a piece is {straight: length} or {arc: length, turn: angle}")
        return self

    def as_tuple(self, length: float) -> tuple:
        if self.straight is not None:
            return ("straight", float(self.straight) / length)
        return ("arc", float(self.arc) / length, float(self.turn))


class LumenSpec(StrictModel):
    """A curved tube the rod lies in: its centre line from ``start`` at ``angle`` through ``path``,
    and its ``radius`` (centre line to wall; rod lengths). Open at both ends (continued straight)."""

    type: Literal["lumen"]
    start: NumberXY = NumberXY()
    angle: Angle = 0.0
    radius: Q("dimensionless", gt=0, le=100)
    path: List[LumenPiece] = Field(min_length=1, max_length=MAX_PIECES)

    @model_validator(mode="after")
    def _buildable(self):
        try:
            self.to_obstacle(1.0)
        except ValueError as err:
            raise error(str(err), "path") from None
        return self

    def to_obstacle(self, length: float = 1.0) -> Lumen:
        return Lumen((float(self.start.x) / length, float(self.start.y) / length), float(self.angle),
                     float(self.radius) / length, tuple(p.as_tuple(length) for p in self.path))


class PhysicalLumenPiece(LumenPiece):
    straight: Optional[Q("length", gt=0)] = None
    arc: Optional[Q("length", gt=0)] = None


class PhysicalWall(WallSpec):
    point: LengthXY


class PhysicalPeg(PegSpec):
    centre: LengthXY
    radius: Q("length", gt=0)


class PhysicalPolygon(PolygonSpec):
    vertices: List[LengthXY] = Field(min_length=3, max_length=MAX_VERTICES)


class PhysicalChannel(ChannelSpec):
    centre: LengthXY
    width: Q("length", gt=0)


class PhysicalLumen(LumenSpec):
    start: LengthXY = LengthXY()
    radius: Q("length", gt=0)
    path: List[PhysicalLumenPiece] = Field(min_length=1, max_length=MAX_PIECES)


DimensionlessObstacle = tagged(("obstacles",), WallSpec, PegSpec, PolygonSpec, ChannelSpec, LumenSpec)
PhysicalObstacle = tagged(("obstacles",), PhysicalWall, PhysicalPeg, PhysicalPolygon, PhysicalChannel, PhysicalLumen)


def obstacles_of(specs, length: float = 1.0) -> tuple:
    """The scene's obstacles (units of ℓ) from their configs (a channel gives its two walls).

    Raises
    ------
    ConfigError
        Naming ``scene.obstacles[k]``: a number that is not finite, or an obstacle (after scaling to
        rod lengths) beyond :data:`MAX_EXTENT`.
    """
    out = []
    for k, spec in enumerate(specs or ()):
        where = f"scene.obstacles[{k}]"
        if not all(math.isfinite(float(v)) for v in _numbers(spec)):
            raise ConfigError(where, "positions, radii and widths must be finite")
        try:
            ob = spec.to_obstacle(length)
        except (ValueError, OverflowError) as err:
            raise ConfigError(where, str(err)) from None
        for o in ob if isinstance(ob, tuple) else (ob,):
            big = max((abs(v) for v in _leaves(o)), default=0.0)
            if not big <= MAX_EXTENT:
                raise ConfigError(where, f"positions, radii and lengths must lie within {MAX_EXTENT:g} rod lengths "
                                         f"of the clamp, got {big:g} rod lengths")
            out.append(o)
    return tuple(out)


def _leaves(obstacle):
    """Every number of an obstacle (units of ℓ; angles in rad)."""
    def walk(v):
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            yield float(v)
        elif isinstance(v, (tuple, list)):
            for x in v:
                yield from walk(x)
    for f in dataclasses.fields(obstacle):
        yield from walk(getattr(obstacle, f.name))


def _numbers(spec):
    """Every number of an obstacle's config (positions, radius, width)."""
    for v in spec.model_dump().values():
        if isinstance(v, dict):
            yield from (c for c in v.values() if isinstance(c, (int, float)))
        elif isinstance(v, list):
            yield from (c for item in v for c in item.values() if isinstance(c, (int, float)))
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            yield v
