"""Rigid obstacles a rod can touch: walls (half-planes), pegs (discs) and convex polygons, frictionless.

Each obstacle gives a signed distance d(r) of a point r of the centre line (units of ℓ), positive on
the free side; contact is the unilateral constraint d(r(s)) ≥ gap (the rod's half-thickness, so its
surface and not its centre line touches). :mod:`actuator_design.contact` imposes it at the
transcription's quadrature points and the tip; the contact force on the rod at a point is
μ ∇d (μ ≥ 0 the constraint's multiplier): normal to the obstacle, pushing the rod away.

Every obstacle also gives ``normal`` (∇d at points, shape (2, k)), ``describe()`` (one line, units
of ℓ) and ``outline(span)``: the solid's drawable outline, vertices of shape (m, 2), for the figures
(a wall's as a band ``span`` long).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field as dc_field
from functools import lru_cache
from typing import Tuple

import casadi as ca
import numpy as np

__all__ = ["Wall", "Peg", "Polygon", "Obstacle"]


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

    def outline(self, span: float) -> np.ndarray:
        n = np.array([math.cos(self.normal_angle), math.sin(self.normal_angle)])
        t, p = np.array([-n[1], n[0]]), np.array(self.point)
        a, b = p - 2 * span * t, p + 2 * span * t
        return np.array([a, b, b - 0.04 * span * n, a - 0.04 * span * n])

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

    def outline(self, span: float) -> np.ndarray:
        a = np.linspace(0.0, 2 * math.pi, 97)
        return np.column_stack([self.centre[0] + self.radius * np.cos(a), self.centre[1] + self.radius * np.sin(a)])

    def describe(self) -> str:
        return f"peg at ({self.centre[0]:.4g}, {self.centre[1]:.4g}) l, radius {self.radius:.4g} l"


@dataclass(frozen=True)
class Polygon:
    """A solid convex polygon (an object to press, a block, a channel's corner) with ``vertices``
    (units of ℓ) in order around it, either way round; stored counter-clockwise.

    Its signed distance is the Euclidean distance to the polygon outside it (C¹ there: the
    projection onto a convex set is continuous) and max_k n_k·(r − a_k) inside (edges a_k → b_k,
    outward normals n_k), negative.
    """

    vertices: Tuple[Tuple[float, float], ...]
    kind: str = dc_field(default="polygon", init=False)

    def __post_init__(self):
        v = np.asarray(self.vertices, float)
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise ValueError(f"a polygon needs at least 3 vertices (x, y), got {len(self.vertices)}")
        area2 = float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
        if area2 < 0:
            v = v[::-1]
        e = np.roll(v, -1, axis=0) - v
        turn = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
        scale = float(np.max(np.hypot(e[:, 0], e[:, 1])))
        if not scale > 0 or np.min(np.hypot(e[:, 0], e[:, 1])) <= 1e-12 * scale or np.any(turn <= 1e-12 * scale**2):
            raise ValueError("the polygon's vertices must go round a convex polygon, each edge of positive "
                             "length and every corner turning the same way (no straight corner)")
        object.__setattr__(self, "vertices", tuple((float(a), float(b)) for a, b in v))

    def distance(self, x, y):
        """Signed distance (CasADi or numpy), positive outside."""
        sym = isinstance(x, (ca.SX, ca.MX))
        mx, mn, where = (ca.fmax, ca.fmin, ca.if_else) if sym else (np.maximum, np.minimum, np.where)
        v = self.vertices
        inside, outside = None, None
        for (ax, ay), (bx, by) in zip(v, v[1:] + v[:1]):
            ex, ey = bx - ax, by - ay
            length = math.hypot(ex, ey)
            px, py = x - ax, y - ay
            e = (px * ey - py * ex) / length  # outward normal (ey, −ex)/|e| of a counter-clockwise edge
            t = mn(mx((px * ex + py * ey) / length**2, 0.0), 1.0)
            dx, dy = px - t * ex, py - t * ey
            sq = dx * dx + dy * dy
            d = ca.sqrt(mx(sq, 1e-300)) if sym else np.sqrt(sq)
            inside = e if inside is None else mx(inside, e)
            outside = d if outside is None else mn(outside, d)
        return where(inside > 0, outside, inside)

    def normal(self, x, y) -> np.ndarray:
        """∇d at points, shape (2, k)."""
        g = _gradient_function(self)
        gx, gy = g(np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float)))
        return np.vstack([np.asarray(gx, float).ravel(), np.asarray(gy, float).ravel()])

    def outline(self, span: float) -> np.ndarray:
        return np.asarray(self.vertices + self.vertices[:1], float)

    def describe(self) -> str:
        pts = ", ".join(f"({a:.4g}, {b:.4g})" for a, b in self.vertices)
        return f"polygon with vertices {pts} l"


@lru_cache(maxsize=64)
def _gradient_function(obstacle) -> ca.Function:
    """∇d of an obstacle's signed distance, as a Function of point coordinates (vectorised)."""
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    d = obstacle.distance(x, y)
    f = ca.Function("normal", [x, y], [ca.jacobian(d, x), ca.jacobian(d, y)])
    return lambda xs, ys: f.map(xs.size)(xs.reshape(1, -1), ys.reshape(1, -1))


Obstacle = (Wall, Peg, Polygon)
