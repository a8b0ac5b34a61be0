"""Rigid obstacles a rod can touch: walls (half-planes), pegs (discs), convex polygons and lumens
(curved tubes the rod lies in), frictionless.

Each obstacle gives a signed distance d(r) of a point r of the centre line (units of ℓ), positive on
the free side; contact is the unilateral constraint d(r(s)) ≥ gap (the rod's half-thickness, so its
surface and not its centre line touches). :mod:`actuator_design.contact.equilibrium` imposes it at the
transcription's quadrature points and the tip; the contact force on the rod at a point is
μ ∇d (μ ≥ 0 the constraint's multiplier): normal to the obstacle, pushing the rod away.

Every obstacle also gives ``normal`` (∇d at points, shape (2, k)), ``describe(scale, unit)`` (one line,
in rod lengths or, given ``scale`` of them per rod length, in a user's ``unit``) and ``outline(span)``: the solid's drawable outline, vertices of shape (m, 2), for the figures
(a wall's as a band ``span`` long).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field as dc_field
from functools import lru_cache
from typing import Tuple

import casadi as ca
import numpy as np

__all__ = ["Wall", "Peg", "Polygon", "Lumen", "Obstacle", "distance_jet"]


@dataclass(frozen=True)
class Wall:
    """The half-plane (r − point)·n ≤ 0 is solid, n = (cos normal_angle, sin normal_angle) pointing
    into the free side; units of ℓ and rad (a floor below the rod at y = −d: point (0, −d),
    normal_angle π/2)."""

    point: Tuple[float, float]
    normal_angle: float
    kind: str = dc_field(default="wall", init=False)

    def mirrored(self) -> "Wall":
        """The reflection in the rod's axis (y → −y)."""
        return Wall((self.point[0], -self.point[1]), -self.normal_angle)

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

    def describe(self, scale: float = 1.0, unit: str = "l") -> str:
        """One line; lengths in ``unit``, ``scale`` of them per rod length (default: rod lengths)."""
        x, y = (scale * v for v in self.point)
        return f"wall through ({x:.4g}, {y:.4g}) {unit}, free side towards {math.degrees(self.normal_angle):.4g} deg"


@dataclass(frozen=True)
class Peg:
    """A solid disc of ``radius`` about ``centre`` (units of ℓ)."""

    centre: Tuple[float, float]
    radius: float
    kind: str = dc_field(default="peg", init=False)

    def mirrored(self) -> "Peg":
        """The reflection in the rod's axis (y → −y)."""
        return Peg((self.centre[0], -self.centre[1]), self.radius)

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

    def describe(self, scale: float = 1.0, unit: str = "l") -> str:
        """One line; lengths in ``unit``, ``scale`` of them per rod length (default: rod lengths)."""
        x, y = (scale * v for v in self.centre)
        return f"peg at ({x:.4g}, {y:.4g}) {unit}, radius {scale * self.radius:.4g} {unit}"


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

    def mirrored(self) -> "Polygon":
        """The reflection in the rod's axis (y → −y; the vertices re-ordered counter-clockwise)."""
        return Polygon(tuple((x, -y) for x, y in self.vertices))

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

    def describe(self, scale: float = 1.0, unit: str = "l") -> str:
        """One line; lengths in ``unit``, ``scale`` of them per rod length (default: rod lengths)."""
        pts = ", ".join(f"({scale * a:.4g}, {scale * b:.4g})" for a, b in self.vertices)
        return f"polygon with vertices {pts} {unit}"


@lru_cache(maxsize=64)
def _gradient_function(obstacle) -> ca.Function:
    """∇d of an obstacle's signed distance, as a Function of point coordinates (vectorised)."""
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    d = obstacle.distance(x, y)
    return _mapped(ca.Function("normal", [x, y], [ca.jacobian(d, x), ca.jacobian(d, y)]))


def distance_jet(obstacle, x, y) -> Tuple[np.ndarray, np.ndarray]:
    """∇d and ∇²d of ``obstacle``'s signed distance at the points (x, y): shapes (2, k) and
    (3, k), the Hessian's rows (d_xx, d_xy, d_yy); from the obstacle's own CasADi expression."""
    g, h = _jet_function(obstacle)(np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float)))
    return np.asarray(g, float).reshape(2, -1, order="F"), np.asarray(h, float).reshape(3, -1, order="F")


@lru_cache(maxsize=64)
def _jet_function(obstacle):
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    r, d = ca.vertcat(x, y), obstacle.distance(x, y)
    H = ca.hessian(d, r)[0]
    f = ca.Function("distance_jet", [x, y], [ca.gradient(d, r), ca.vertcat(H[0, 0], H[0, 1], H[1, 1])])
    return _mapped(f)


def _mapped(f: ca.Function):
    """``f`` of one point (x, y) as a function of arrays of points: its map over k points kept by k
    (building one costs as much as evaluating it)."""
    maps = {}

    def over(xs, ys):
        if xs.size not in maps:
            if len(maps) >= 16:
                maps.clear()
            maps[xs.size] = f.map(xs.size)
        return maps[xs.size](xs.reshape(1, -1), ys.reshape(1, -1))
    return over


@dataclass(frozen=True)
class Lumen:
    """A curved tube the rod lies in (a vessel, a catheter, a guide): the free region is within
    ``radius`` of its centre line, which starts at ``start`` heading at ``angle`` (rad) and runs
    through ``pieces``, each ``("straight", length)`` or ``("arc", length, turn)`` (turn in rad,
    positive to the left), units of ℓ. Both ends continue straight along their tangents (the tube
    is open there), so the centre line is C¹ and the distance to it is C¹ within the tube where
    ``radius`` is below every arc's radius of curvature (checked).

    Signed distance: d = radius − dist(r, centre line), positive inside.
    """

    start: Tuple[float, float]
    angle: float
    radius: float
    pieces: Tuple[Tuple[float, ...], ...]
    kind: str = dc_field(default="lumen", init=False)

    def mirrored(self) -> "Lumen":
        """The reflection in the rod's axis (y → −y): every turn of the centre line reversed."""
        pieces = tuple(p if p[0] == "straight" else (p[0], p[1], -p[2]) for p in self.pieces)
        return Lumen((self.start[0], -self.start[1]), -self.angle, self.radius, pieces)

    def __post_init__(self):
        if not self.radius > 0:
            raise ValueError(f"a lumen's radius must be > 0, got {self.radius!r}")
        if not self.pieces:
            raise ValueError("a lumen needs at least one piece (straight or arc)")
        for piece in self.pieces:
            if piece[0] not in ("straight", "arc") or not piece[1] > 0:
                raise ValueError(f"a lumen piece is ('straight', length > 0) or ('arc', length > 0, turn), got {piece!r}")
            if piece[0] == "arc" and piece[2] != 0 and abs(piece[1] / piece[2]) <= self.radius:
                raise ValueError(f"an arc of length {piece[1]:.4g} turning {math.degrees(piece[2]):.4g} deg has a "
                                 f"radius of curvature {abs(piece[1] / piece[2]):.4g} l, not above the lumen's "
                                 f"radius {self.radius:.4g} l: its walls would fold over")

    def _segments(self):
        """The centre line as ("line", A, B, open_before, open_after) and ("arc", C, ρ, start, turn, E0, E1)
        (start: the polar angle of E0 about the centre C; the arc sweeps ``turn`` from there)."""
        p, a = np.array(self.start, float), float(self.angle)
        out = [("line", p - np.array([math.cos(a), math.sin(a)]), p, True, False)]
        for piece in self.pieces:
            length, turn = piece[1], (piece[2] if piece[0] == "arc" else 0.0)
            t = np.array([math.cos(a), math.sin(a)])
            if turn == 0.0:
                q = p + length * t
                out.append(("line", p, q, False, False))
            else:
                rho = length / abs(turn)
                side = math.copysign(1.0, turn)
                c = p + side * rho * np.array([-t[1], t[0]])
                start = math.atan2(p[1] - c[1], p[0] - c[0])
                q = c + rho * np.array([math.cos(start + turn), math.sin(start + turn)])
                out.append(("arc", c, rho, start, turn, p, q))
            p, a = q, a + turn
        out.append(("line", p, p + np.array([math.cos(a), math.sin(a)]), False, True))
        return out

    def distance(self, x, y):
        """Signed distance (CasADi or numpy), positive inside the tube."""
        sym = isinstance(x, (ca.SX, ca.MX))
        mx, mn, where = (ca.fmax, ca.fmin, ca.if_else) if sym else (np.maximum, np.minimum, np.where)
        sqrt, atan2, sin, cos, fabs = ((ca.sqrt, ca.atan2, ca.sin, ca.cos, ca.fabs) if sym else
                                       (np.sqrt, np.arctan2, np.sin, np.cos, np.abs))
        best = None
        for seg in self._segments():
            if seg[0] == "line":
                _, A, B, open_before, open_after = seg
                e = B - A
                t = ((x - A[0]) * e[0] + (y - A[1]) * e[1]) / float(e @ e)
                if not open_before:
                    t = mx(t, 0.0)
                if not open_after:
                    t = mn(t, 1.0)
                sq = (x - A[0] - t * e[0]) ** 2 + (y - A[1] - t * e[1]) ** 2
            else:
                _, C, rho, start, turn, E0, E1 = seg
                mid, half = start + 0.5 * turn, 0.5 * abs(turn)
                vx, vy = x - C[0], y - C[1]
                rel = atan2(vy * cos(mid) - vx * sin(mid), vx * cos(mid) + vy * sin(mid))  # polar angle from mid
                radial = (sqrt(vx * vx + vy * vy) - rho) ** 2
                ends = mn((x - E0[0]) ** 2 + (y - E0[1]) ** 2, (x - E1[0]) ** 2 + (y - E1[1]) ** 2)
                sq = where(fabs(rel) <= half, radial, ends)
            best = sq if best is None else mn(best, sq)
        eps2 = (1e-6 * self.radius) ** 2  # smooths the distance's kink on the centre line (unused there)
        return self.radius - sqrt(best + eps2)

    def normal(self, x, y) -> np.ndarray:
        """∇d at points, shape (2, k) (towards the centre line)."""
        return Polygon.normal(self, x, y)

    def centreline(self, n: int = 400, extend: float = 0.0) -> np.ndarray:
        """Points of the centre line, shape (m, 2), with ``extend`` (ℓ) of its straight continuations."""
        pts = []
        segs = self._segments()
        for seg in segs:
            if seg[0] == "line":
                _, A, B, before, after = seg
                if before or after:
                    d = (B - A) / np.linalg.norm(B - A)
                    A, B = (B - extend * d, B) if before else (A, A + extend * d)
                pts.append(np.linspace(A, B, max(2, n // len(segs))))
            else:
                _, C, rho, start, turn, E0, E1 = seg
                a = np.linspace(start, start + turn, max(8, n // len(segs)))
                pts.append(np.column_stack([C[0] + rho * np.cos(a), C[1] + rho * np.sin(a)]))
        return np.vstack(pts)

    def tangent_angle(self, u: np.ndarray) -> np.ndarray:
        """The centre line's heading (rad, unwrapped) at arc lengths ``u`` from its start (ℓ)."""
        u = np.atleast_1d(np.asarray(u, float))
        ends, heading = [0.0], [float(self.angle)]
        for piece in self.pieces:
            ends.append(ends[-1] + piece[1])
            heading.append(heading[-1] + (piece[2] if piece[0] == "arc" else 0.0))
        out = np.full(u.shape, heading[-1])
        for k, piece in enumerate(self.pieces):
            inside = (u >= ends[k]) & (u < ends[k + 1])
            turn = piece[2] if piece[0] == "arc" else 0.0
            out[inside] = heading[k] + turn * (u[inside] - ends[k]) / piece[1]
        out[u < 0] = heading[0]
        return out

    def outline(self, span: float) -> np.ndarray:
        """The tube's two walls, shape (m, 2): the left wall forward, then the right wall back."""
        c = self.centreline(extend=span)
        d = np.gradient(c, axis=0)
        nrm = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]
        return np.vstack([c + self.radius * nrm, (c - self.radius * nrm)[::-1]])

    def describe(self, scale: float = 1.0, unit: str = "l") -> str:
        """One line; lengths in ``unit``, ``scale`` of them per rod length (default: rod lengths)."""
        parts = ", ".join(f"{p[0]} {scale * p[1]:.4g} {unit}" + (f" turning {math.degrees(p[2]):.4g} deg"
                                                                 if p[0] == "arc" else "") for p in self.pieces)
        return (f"lumen of radius {scale * self.radius:.4g} {unit} from ({scale * self.start[0]:.4g}, "
                f"{scale * self.start[1]:.4g}) {unit} at {math.degrees(self.angle):.4g} deg: {parts}")


Obstacle = (Wall, Peg, Polygon, Lumen)
