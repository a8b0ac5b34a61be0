"""Magnets and coils as field sources: magpylib builds them, zonal harmonics represent them.

magpylib (https://magpylib.readthedocs.io) is the source of truth for every magnet and coil field;
nothing here writes a magnet formula. Each source — a cylinder or sphere magnet magnetised along
its axis, a current loop, a solenoid, a Helmholtz or a Maxwell pair — has its symmetry axis in the
rod's plane, so its field over the rod's reach is the gradient of an axisymmetric harmonic
potential. Its coefficients (:mod:`actuator_design.physics.harmonic`) are the Legendre projections of
magpylib's radial field on a circle about the source's centre (Gauss–Legendre quadrature), the
order is the smallest that meets the tolerance on a grid over the reach, and the fit is then
checked against magpylib at random points of the reach: that error is reported with the scene.

Units: SI in (m, A/m, A); the fitted field is dimensionless, positions in units of the rod length ℓ
and the field in units of H0, the largest |H| over the part of the reach disc (|r| ≤ ℓ) outside
every source (THEORY §5: H0 sets the groups h, h_pos and h_r).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import List, Tuple

import numpy as np

from .physics.harmonic import HarmonicTerm, field_function

__all__ = ["MagnetSource", "CoilSource", "FittedField", "fit_sources", "source_field", "magpylib_field", "magpylib_objects",
           "FIT_TOLERANCE"]

#: Default fit tolerance per source, relative to H0 (the total over a few sources stays ≤ 1e-6).
FIT_TOLERANCE = 1e-7
MAX_ORDER = 60  # highest Legendre order of a fit
#: highest order of a magnet with travel: its fit holds down to ~1.2 R_v (R_v the sphere holding it)
MAX_TRAVEL_ORDER = 120
_NODES = 240  # Gauss–Legendre nodes of the projection (exact for orders ≪ 2 × 240)
_MAX_LOOPS = 2000  # bounds the work of a solenoid: one magpylib loop per turn


@dataclass(frozen=True)
class MagnetSource:
    """A permanent magnet magnetised along its axis (SI).

    shape : "cylinder" or "sphere"; diameter, height (cylinder only) in m; position (x, y) of its
    centre in m (the clamp at the origin, the rod along +x, the magnet centred in the rod's plane);
    axis_angle : direction of its axis and magnetisation, rad from the rod axis; magnetization : M, A/m
    (a remanence B_r in tesla is M = B_r/μ0). travel : how far its stage can move it, for a design
    over its pose (:mod:`actuator_design.analysis.pose_design`): ((x_lo, x_hi), (y_lo, y_hi),
    (angle_lo, angle_hi)) in m and rad, ``None`` for a coordinate held; empty: the magnet is fixed. A
    magnet with travel is fitted down to its own body (not only over the rod's reach from where it
    is), so that its fitted field, moved rigidly, holds wherever the stage takes it.
    """

    shape: str
    diameter: float
    height: float
    position: Tuple[float, float]
    axis_angle: float
    magnetization: float
    travel: Tuple = ()


@dataclass(frozen=True)
class CoilSource:
    """Coaxial circular windings (SI): kind "loop" (``turns`` turns at one place), "solenoid"
    (``turns`` loops spread evenly over ``length``), "helmholtz" or "maxwell" (two windings of
    ``turns`` turns ``spacing`` apart, currents equal or opposite). ``current`` in A per turn.
    Hardware, for a design over currents (:mod:`actuator_design.analysis.current_design`):
    ``max_current`` (A, the driver's limit; inf: not given) and ``resistance`` (Ω of the whole
    coil; nan: not given)."""

    kind: str
    radius: float
    position: Tuple[float, float]
    axis_angle: float
    current: float
    turns: int = 1
    length: float = 0.0
    spacing: float = 0.0
    max_current: float = math.inf
    resistance: float = math.nan


def _loops(src: CoilSource) -> List[Tuple[float, float]]:
    """(axial offset m, ampere-turns) of each loop of a coil."""
    if src.kind == "loop":
        return [(0.0, src.current * src.turns)]
    if src.kind == "solenoid":
        n = src.turns
        offs = np.linspace(-0.5 * src.length, 0.5 * src.length, n) if n > 1 else np.zeros(1)
        return [(float(o), src.current) for o in offs]
    sign = -1.0 if src.kind == "maxwell" else 1.0
    return [(-0.5 * src.spacing, src.current * src.turns), (0.5 * src.spacing, sign * src.current * src.turns)]


def _radii(src) -> Tuple[float, float]:
    """(R_v, R_i), m: the sphere about the centre holding every source, the ball free of them."""
    if isinstance(src, MagnetSource):
        h = 0.0 if src.shape == "sphere" else 0.5 * src.height
        r = math.hypot(0.5 * src.diameter, h)
        return r, (0.0 if src.shape == "cylinder" else 0.5 * src.diameter)
    d = [math.hypot(src.radius, off) for off, _ in _loops(src)]
    return max(d), min(d)


def magpylib_objects(src):
    """The magpylib sources of one source, placed and oriented (its axis along the local z)."""
    import magpylib as magpy
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_euler("yz", [90.0, math.degrees(src.axis_angle)], degrees=True)  # z → axis
    pos = np.array([src.position[0], src.position[1], 0.0])
    axis = rot.apply([0.0, 0.0, 1.0])
    if isinstance(src, MagnetSource):
        if src.shape == "sphere":
            obj = magpy.magnet.Sphere(diameter=src.diameter, magnetization=(0, 0, src.magnetization))
        else:
            obj = magpy.magnet.Cylinder(dimension=(src.diameter, src.height),
                                        magnetization=(0, 0, src.magnetization))
        obj.orientation = rot
        obj.position = pos
        return [obj]
    out = []
    for off, amp_turns in _loops(src):
        loop = magpy.current.Circle(diameter=2 * src.radius, current=amp_turns)
        loop.orientation = rot
        loop.position = pos + off * axis
        out.append(loop)
    return out


def magpylib_field(sources, points_m: np.ndarray) -> np.ndarray:
    """H (A/m), shape (n, 3), of ``sources`` at ``points_m`` (shape (n, 3), m), by magpylib."""
    import magpylib as magpy

    objs = [o for s in sources for o in magpylib_objects(s)]
    return np.asarray(magpy.getH(objs, np.asarray(points_m, float), sumup=True), float).reshape(-1, 3)


@dataclass(frozen=True)
class FittedField:
    """The fit of a set of sources: its terms, H0 (A/m) and the errors measured against magpylib."""

    terms: Tuple[HarmonicTerm, ...]
    h0: float
    fit_error: float  # max |ĥ_fit − H/H0| at random points of the reach where the fit holds
    gradient_error: float  # max |∇ĥ_fit − ∇(H/H0)| ℓ there (magpylib's by 4th-order differences)
    orders: Tuple[int, ...]


def _reach_grid(n_r: int = 48, n_a: int = 96) -> np.ndarray:
    """Points (units of ℓ) covering the disc |r| ≤ 1 the rod can reach, shape (n, 2)."""
    r = np.sqrt(np.linspace(0.0, 1.0, n_r))
    a = np.linspace(0.0, 2 * np.pi, n_a, endpoint=False)
    pts = np.stack([np.outer(r, np.cos(a)).ravel(), np.outer(r, np.sin(a)).ravel()], 1)
    return np.unique(np.round(pts, 14), axis=0)


def _geometry(src, length: float):
    """(centre, R_v, R_i, kind, distance to the clamp) of a source in units of ℓ: the exterior
    series beside a source, the interior one when the clamp lies inside its source-free ball."""
    c = (src.position[0] / length, src.position[1] / length)
    rv, ri = (r / length for r in _radii(src))
    d = math.hypot(*c)
    return c, rv, ri, ("interior" if d < ri else "exterior"), d


def _outside_sources(pts: np.ndarray, geo) -> np.ndarray:
    keep = np.ones(len(pts), bool)
    for c, rv, ri, kind, _ in geo:
        rho = np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[1])
        keep &= rho > rv if kind == "exterior" else rho < ri
    return keep


def _basis(kind: str, c, axis_angle: float, R: float, order: int):
    """CasADi function (x, y) → (2, order), (4, order): the field −∇ψ_l of each unit-coefficient
    term and its gradient (rows ∂h_x/∂x, ∂h_y/∂x, ∂h_x/∂y, ∂h_y/∂y)."""
    import casadi as ca

    from .physics.harmonic import basis_potentials

    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    r = ca.vertcat(x, y)
    h = -ca.jacobian(ca.vertcat(*basis_potentials(kind, c, axis_angle, R, order, x, y)), r).T  # (2, order)
    g = ca.jacobian(ca.vec(h), r)  # (2 order, 2): rows ∂h_x/∂·, ∂h_y/∂· per order
    g = ca.horzcat(g[0::2, 0], g[1::2, 0], g[0::2, 1], g[1::2, 1]).T  # (4, order)
    return ca.Function("basis", [x, y], [h, g])


def _basis_values(fn, pts: np.ndarray):
    """Basis fields and their gradients at points, shapes (n, 2, order) and (n, 4, order)."""
    h, g = fn.map(len(pts))(pts[:, 0], pts[:, 1])
    n = len(pts)
    return (np.asarray(h, float).reshape(2, n, -1).transpose(1, 0, 2),
            np.asarray(g, float).reshape(4, n, -1).transpose(1, 0, 2))


def _fit_one(src, length: float, h0_guess: float, tol: float) -> Tuple[HarmonicTerm, int]:
    """The zonal fit of one source (dimensionless, ψ in A/m · ℓ; divided by H0 by the caller)."""
    c, rv, ri, kind, d = _geometry(src, length)
    e = np.array([math.cos(src.axis_angle), math.sin(src.axis_angle)])
    n = np.array([-e[1], e[0]])
    top = MAX_ORDER
    if getattr(src, "travel", ()):  # a moving magnet: projected next to its body (exterior), to the
        # orders that reach it (nearer, the body's high orders alias onto the projection)
        kind, rho_s, top = "exterior", 1.2 * rv, MAX_TRAVEL_ORDER
    elif kind == "exterior":
        rho_s = max(d - 1.0, 1.05 * rv)
    else:
        rho_s = min(d + 1.0, 0.95 * ri)
    t, w = np.polynomial.legendre.leggauss(_NODES)
    sin = np.sqrt(1.0 - t * t)
    pts = np.asarray(c) + rho_s * (np.outer(t, e) + np.outer(sin, n))
    radial = np.outer(t, e) + np.outer(sin, n)
    H = magpylib_field([src], np.column_stack([pts * length, np.zeros(len(pts))]))[:, :2]
    h_rho = np.sum(H * radial, 1)
    P = np.polynomial.legendre.legvander(t, top)  # P_l(t), l = 0..top
    proj = (2 * np.arange(top + 1) + 1) / 2.0 * ((w * h_rho) @ P)
    ls = np.arange(1, top + 1)
    a = proj[1:] * rho_s / (ls + 1) if kind == "exterior" else -proj[1:] * rho_s / ls
    # the smallest order meeting the tolerance on the part of the reach where the source is not
    grid = _reach_grid() if not getattr(src, "travel", ()) else _travel_grid(src, c, rv, length)
    rho = np.hypot(grid[:, 0] - c[0], grid[:, 1] - c[1])
    inside = rho > 1.02 * rv if kind == "exterior" else rho < 0.98 * ri
    grid, rho = grid[inside], rho[inside]
    Htrue = magpylib_field([src], np.column_stack([grid * length, np.zeros(len(grid))]))[:, :2]
    B, G = _basis_values(_basis(kind, c, src.axis_angle, rho_s, top), grid)
    # the truncation error of order L: the field (and gradient) of the terms above L, and what
    # even the highest order misses against magpylib
    miss = np.linalg.norm(np.einsum("nil,l->ni", B, a) - Htrue, axis=1) / h0_guess
    tail_h = np.cumsum((B * a)[:, :, ::-1], axis=2)[:, :, ::-1] / h0_guess  # Σ_{l ≥ L}
    tail_g = np.cumsum((G * a)[:, :, ::-1], axis=2)[:, :, ::-1] / h0_guess
    order, valid = top, None
    if miss.max() <= tol:
        for L in range(1, top):
            if (np.linalg.norm(tail_h[:, :, L], axis=1).max() <= 0.1 * tol
                    and np.abs(tail_g[:, :, L]).max() <= tol):
                order = L
                break
    else:  # even the highest order misses near the sources: the region where it holds shrinks to
        # where the field and its gradient (magpylib's by differences) are met
        g_true = _gradient_fd([src], grid, length, delta=2.5e-4).transpose(0, 2, 1).reshape(len(grid), 4)
        miss = np.maximum(miss, np.abs(np.einsum("nil,l->ni", G, a) - g_true).max(axis=1) / h0_guess)
        rings = np.sort(np.unique(np.round(rho, 12)))
        ok = [r for r in rings if np.all(miss[(rho >= r) if kind == "exterior" else (rho <= r)] <= tol)]
        if not ok:
            raise ValueError(f"no fit of this source (centre {d:.3g} rod lengths from the clamp) meets the "
                             f"fit_tolerance {tol:g} anywhere in the rod's reach: the best misses magpylib by "
                             f"{miss.min():.2g} of the field scale (far sources: magpylib's own rounding; "
                             "raise fit_tolerance, or use a uniform field)")
        valid = min(ok) if kind == "exterior" else max(ok)
    if valid is None and getattr(src, "travel", ()):  # checked all round the magnet, down to its body
        valid = 1.02 * rv
    if valid is None:  # where it was checked: the part of the reach outside the sources
        # (less a hair: a straight rod pointing at the centre ends exactly at d − 1)
        valid = max(1.02 * rv, d - 1.0 - 1e-9) if kind == "exterior" else min(0.98 * ri, d + 1.0 + 1e-9)
    term = HarmonicTerm(kind, c, float(src.axis_angle), float(rho_s), tuple(float(v) for v in a[:order]),
                        float(valid))
    return term, order


def _travel_grid(src, c, rv: float, length: float, n_r: int = 48, n_a: int = 96) -> np.ndarray:
    """Points (units of ℓ) all round a moving magnet's centre ``c``, from next to its body (1.02 R_v)
    out to the farthest the clamp's reach gets from it anywhere in its travel (the clamp's distance
    plus ℓ), shape (n_r n_a, 2): the fit of a magnet that moves is checked where the rod can be
    relative to it, graded towards the body where the field varies fastest."""
    xs = src.travel[0] or (src.position[0], src.position[0])
    ys = src.travel[1] or (src.position[1], src.position[1])
    far = max(math.hypot(x, y) for x in xs for y in ys) / length + 1.0
    r = 1.02 * rv + (far - 1.02 * rv) * np.linspace(0.0, 1.0, n_r) ** 2
    a = np.linspace(0.0, 2 * np.pi, n_a, endpoint=False)
    return np.asarray(c) + np.stack([np.outer(r, np.cos(a)).ravel(), np.outer(r, np.sin(a)).ravel()], 1)


def _gradient_fd(sources, pts: np.ndarray, length: float, delta: float = 1e-3) -> np.ndarray:
    """∂H_i/∂r_j (A/m per ℓ) at ``pts`` (ℓ) by 4th-order central differences of magpylib, (n, 2, 2)."""
    out = np.zeros((len(pts), 2, 2))
    for j in range(2):
        step = np.zeros(2)
        step[j] = delta
        vals = [magpylib_field(sources, np.column_stack([(pts + k * step) * length, np.zeros(len(pts))]))[:, :2]
                for k in (-2, -1, 1, 2)]
        out[:, :, j] = (vals[0] - 8 * vals[1] + 8 * vals[2] - vals[3]) / (12 * delta)
    return out


@functools.lru_cache(maxsize=32)
def fit_sources(sources: Tuple, length: float, tol: float = FIT_TOLERANCE, checks: int = 400) -> FittedField:
    """Fit every source and measure the total's error against magpylib at ``checks`` random points.

    Parameters
    ----------
    sources : tuple of MagnetSource or CoilSource
    length : float
        ℓ, m.
    tol : float
        Fit tolerance per source relative to H0.
    checks : int
        Random points (fixed seed) of the reach where the fit holds, for the reported errors.

    Raises
    ------
    ValueError
        When the rod's reach has no point outside the sources, the field there is zero, or a source
        cannot be fitted anywhere in the reach.
    """
    import casadi as ca

    geo = [_geometry(s, length) for s in sources]
    grid = _reach_grid()
    grid = grid[_outside_sources(grid, geo)]
    if len(grid) == 0:
        raise ValueError("the rod's reach lies inside the sources: no point of it is outside every magnet and coil")
    H = magpylib_field(sources, np.column_stack([grid * length, np.zeros(len(grid))]))
    h0 = float(np.max(np.linalg.norm(H[:, :2], axis=1)))
    if not (h0 > 0 and math.isfinite(h0)):
        raise ValueError("the sources give no field in the rod's plane over its reach")
    fits = [_fit_one(s, length, h0, tol) for s in sources]
    terms = tuple(HarmonicTerm(t.kind, t.centre, t.axis_angle, t.radius,
                               tuple(v / h0 for v in t.coefficients), t.valid_radius) for t, _ in fits)
    # the reported errors: random points of the reach where every fit holds
    rng = np.random.default_rng(20261204)
    pts = rng.uniform(-1.0, 1.0, (8 * checks, 2))
    pts = pts[(np.hypot(pts[:, 0], pts[:, 1]) <= 1.0)]
    pts = pts[np.all([t.contains(pts[:, 0], pts[:, 1]) for t in terms], axis=0)][:checks]
    f = field_function(terms)
    xs, ys = ca.SX.sym("x"), ca.SX.sym("y")
    hx, hy = f(xs, ys)
    J = ca.Function("J", [xs, ys], [ca.vertcat(hx, hy), ca.jacobian(ca.vertcat(hx, hy), ca.vertcat(xs, ys))])
    Jm = J.map(len(pts))
    h_fit, g_fit = (np.asarray(v, float) for v in Jm(pts[:, 0], pts[:, 1]))
    h_fit = h_fit.T
    g_fit = g_fit.reshape(2, len(pts), 2).transpose(1, 0, 2)
    h_true = magpylib_field(sources, np.column_stack([pts * length, np.zeros(len(pts))]))[:, :2] / h0
    g_true = _gradient_fd(sources, pts, length) / h0
    fit_error = float(np.max(np.linalg.norm(h_fit - h_true, axis=1)))
    grad_error = float(np.max(np.abs(g_fit - g_true)))
    return FittedField(terms, h0, fit_error, grad_error, tuple(o for _, o in fits))


def source_field(sources, length: float, tol: float = FIT_TOLERANCE):
    """The scene field of ``sources`` for a rod of ``length`` (m), and its H0 (A/m).

    Returns
    -------
    (SourceField, float)
    """
    from .scene import SourceField

    sources = tuple(sources)
    fit = fit_sources(sources, float(length), float(tol))
    return SourceField(terms=fit.terms, sources=sources, length=float(length), fit_error=fit.fit_error,
                       gradient_error=fit.gradient_error, fit_tolerance=float(tol)), fit.h0
