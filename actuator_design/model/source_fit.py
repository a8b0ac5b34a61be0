"""Fitting a source's field to magpylib: solid-harmonic coefficients, the order, the region.

A source whose axis lies in the plane is axisymmetric about it: its zonal coefficients
(:mod:`actuator_design.physics.harmonic`) are the Legendre projections of magpylib's radial field
on a circle about its centre (Gauss–Legendre quadrature). A cuboid or a diametric cylinder is not:
its tesseral coefficients (:mod:`actuator_design.physics.tesseral`) are the projections of
magpylib's radial field on a sphere about its centre (Gauss–Legendre in cos ϑ × the trapezoidal rule
in φ). The order is the smallest whose tail meets the tolerance on a grid over the part of the
reach where the source is not (graded towards the source beside it), the series is checked there
against magpylib's field and gradient, and where it misses, the region where the fit holds
shrinks. Lengths in units of ℓ, ψ in A/m · ℓ (divided by H0 by the caller).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple, Union

import numpy as np

from actuator_design.physics.harmonic import HarmonicTerm, basis_potentials
from actuator_design.physics.tesseral import TesseralTerm, tesseral_modes, tesseral_potentials
from actuator_design.model.sources import TESSERAL_SHAPES, magpylib_field, radii

__all__ = ["FittedField", "fit_one", "reach_grid", "geometry", "outside_sources", "gradient_fd", "checked_gradient",
           "MAX_ORDER", "MAX_TRAVEL_ORDER", "MAX_TESSERAL_ORDER"]

@dataclass(frozen=True)
class FittedField:
    """The fit of a set of sources: its terms, H0 (A/m) and the errors measured against magpylib."""

    terms: Tuple[Union[HarmonicTerm, TesseralTerm], ...]
    h0: float
    fit_error: float  # max |ĥ_fit − H/H0| at random and edge points of the reach where the fit holds
    gradient_error: float  # max |∇ĥ_fit − ∇(H/H0)| ℓ there (magpylib's by extrapolated differences; NaN: a map's)
    orders: Tuple[int, ...]


MAX_ORDER = 60  # highest Legendre order of a fit
#: highest order of a magnet with travel: its fit holds down to ~1.2 R_v (R_v the sphere holding it)
MAX_TRAVEL_ORDER = 120
#: highest degree of a cuboid's tesseral fit (l, m odd: 465 terms at 59); a diametric cylinder has
#: m = 1 only, and the zonal fits' orders
MAX_TESSERAL_ORDER = 59
_NODES = 240  # Gauss–Legendre nodes of the projections (exact for orders ≪ 2 × 240); even: the
# tesseral projection takes the upper half-sphere's nodes (none at cos ϑ = 0)
#: the second projection, whose differences from the first measure each coefficient's rounding
_CHECK_NODES = _NODES + 32
assert _NODES % 2 == 0 and _CHECK_NODES % 2 == 0


def reach_grid(n_r: int = 48, n_a: int = 96) -> np.ndarray:
    """Points (units of ℓ) covering the disc |r| ≤ 1 the rod can reach, shape (n, 2)."""
    r = np.sqrt(np.linspace(0.0, 1.0, n_r))
    a = np.linspace(0.0, 2 * np.pi, n_a, endpoint=False)
    pts = np.stack([np.outer(r, np.cos(a)).ravel(), np.outer(r, np.sin(a)).ravel()], 1)
    return np.unique(np.round(pts, 14), axis=0)


def _beside_grid(c, rv: float, n_r: int = 48, n_a: int = 97) -> np.ndarray:
    """Points (units of ℓ) of the reach |r| ≤ 1 on circles about a source's centre ``c`` (its
    distance d from the clamp), from next to its body (1.02 R_v) or the nearest point of the reach
    out to the farthest, graded towards the near side, each circle's arc within the reach sampled
    evenly from edge to edge: an exterior series errs most near the source, where the reach's own
    grid is sparsest (there it missed the error of a fit 5-fold, the gradient's 40-fold)."""
    d = math.hypot(*c)
    near = max(1.02 * rv, d - 1.0)
    rho = near + (d + 1.0 - near) * np.linspace(0.0, 1.0, n_r) ** 2
    towards = math.atan2(-c[1], -c[0])  # from the source to the clamp
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_half = np.clip((d * d + rho * rho - 1.0) / (2 * d * rho), -1.0, 1.0) if d > 0 else np.full(n_r, -1.0)
    half = np.arccos(cos_half)
    t = np.linspace(-1.0, 1.0, n_a)
    a = towards + np.outer(half * (1 - 1e-12), t)
    pts = np.stack([c[0] + (rho[:, None] * np.cos(a)).ravel(), c[1] + (rho[:, None] * np.sin(a)).ravel()], 1)
    return pts[np.hypot(pts[:, 0], pts[:, 1]) <= 1.0]


def geometry(src, length: float):
    """(centre, R_v, R_i, kind, distance to the clamp) of a source in units of ℓ: the exterior
    series beside a source, the interior one when the clamp lies inside its source-free ball."""
    c = (src.position[0] / length, src.position[1] / length)
    rv, ri = (r / length for r in radii(src))
    d = math.hypot(*c)
    return c, rv, ri, ("interior" if d < ri else "exterior"), d


def outside_sources(pts: np.ndarray, geo) -> np.ndarray:
    keep = np.ones(len(pts), bool)
    for c, rv, ri, kind, _ in geo:
        rho = np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[1])
        keep &= rho > rv if kind == "exterior" else rho < ri
    return keep


def _basis(potentials):
    """CasADi function (x, y) → (2, k), (4, k): the field −∇ψ_j of each of the k unit-coefficient
    ``potentials(x, y)`` and its gradient (rows ∂h_x/∂x, ∂h_y/∂x, ∂h_x/∂y, ∂h_y/∂y)."""
    import casadi as ca

    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    r = ca.vertcat(x, y)
    h = -ca.jacobian(ca.vertcat(*potentials(x, y)), r).T  # (2, k)
    g = ca.jacobian(ca.vec(h), r)  # (2 k, 2): rows ∂h_x/∂·, ∂h_y/∂· per term
    g = ca.horzcat(g[0::2, 0], g[1::2, 0], g[0::2, 1], g[1::2, 1]).T  # (4, k)
    return ca.Function("basis", [x, y], [h, g])


def _basis_values(fn, pts: np.ndarray):
    """Basis fields and their gradients at points, shapes (n, 2, k) and (n, 4, k)."""
    h, g = fn.map(len(pts))(pts[:, 0], pts[:, 1])
    n = len(pts)
    return (np.asarray(h, float).reshape(2, n, -1).transpose(1, 0, 2),
            np.asarray(g, float).reshape(4, n, -1).transpose(1, 0, 2))


def _project_zonal(src, c, kind: str, rho_s: float, top: int, length: float, nodes: int = _NODES):
    """a_1..a_top of a zonal expansion: Legendre projections of magpylib's radial field on the
    circle of radius ``rho_s`` about ``c`` (units of ℓ; ψ in A/m · ℓ), by ``nodes`` Gauss nodes."""
    e = np.array([math.cos(src.axis_angle), math.sin(src.axis_angle)])
    n = np.array([-e[1], e[0]])
    t, w = np.polynomial.legendre.leggauss(nodes)
    radial = np.outer(t, e) + np.outer(np.sqrt(1.0 - t * t), n)
    pts = np.asarray(c) + rho_s * radial
    H = magpylib_field([src], np.column_stack([pts * length, np.zeros(len(pts))]))[:, :2]
    h_rho = np.sum(H * radial, 1)
    P = np.polynomial.legendre.legvander(t, top)  # P_l(t), l = 0..top
    proj = (2 * np.arange(top + 1) + 1) / 2.0 * ((w * h_rho) @ P)
    ls = np.arange(1, top + 1)
    return proj[1:] * rho_s / (ls + 1) if kind == "exterior" else -proj[1:] * rho_s / ls


def _project_tesseral(src, c, rho_s: float, modes, length: float, nodes: int = _NODES) -> np.ndarray:
    """a_lm of a tesseral exterior expansion (:class:`TesseralTerm`): projections of magpylib's radial
    field H_r on the sphere of radius ``rho_s`` (units of ℓ) about ``c`` onto P̄_l^m(cos ϑ) cos mφ,
    whose norm is 2π/(2l+1); H_r = Σ (l+1)/ρ_s a_lm P̄ cos mφ there. The upper half-sphere suffices:
    the integrands are even in z (module docstring of :mod:`.physics.tesseral`); ``nodes`` (even)
    Gauss nodes in cos ϑ, twice as many in φ."""
    t, w = np.polynomial.legendre.leggauss(nodes)
    t, w = t[t > 0], 2.0 * w[t > 0]
    phi = (np.arange(2 * nodes) + 0.5) * (2 * np.pi / (2 * nodes))
    T, F = np.meshgrid(t, phi, indexing="ij")
    weight = (np.outer(w, np.full(len(phi), 2 * np.pi / len(phi)))).ravel()
    sin = np.sqrt(1.0 - T * T).ravel()
    a = src.axis_angle
    radial = np.column_stack([sin * np.cos(F.ravel() + a), sin * np.sin(F.ravel() + a), T.ravel()])
    pts = np.column_stack([c[0] + rho_s * radial[:, 0], c[1] + rho_s * radial[:, 1], rho_s * radial[:, 2]])
    h_radial = np.sum(magpylib_field([src], pts * length) * radial, 1)
    proj = np.zeros(len(modes))
    for k in range(0, len(pts), 4096):  # bounded memory: k points × every mode at a time
        sl = slice(k, k + 4096)
        Y = np.array(tesseral_potentials(c, a, rho_s, modes, pts[sl, 0], pts[sl, 1], pts[sl, 2]))
        proj += Y @ (weight[sl] * h_radial[sl])
    ls = np.array([l for l, _ in modes], float)
    return proj * (2 * ls + 1) / (2 * np.pi) * rho_s / (ls + 1)


def fit_one(src, length: float, h0_guess: float, tol: float):
    """The fit of one source (dimensionless, ψ in A/m · ℓ; divided by H0 by the caller): its
    HarmonicTerm (zonal) or TesseralTerm (a cuboid, a diametric cylinder), and its order."""
    c, rv, ri, kind, d = geometry(src, length)
    tesseral = getattr(src, "shape", "") in TESSERAL_SHAPES
    m_max = 1 if getattr(src, "shape", "") == "diametric_cylinder" else None  # −M ∂Φ/∂u: m = 1 only
    top = MAX_TESSERAL_ORDER if tesseral and m_max is None else MAX_ORDER
    if getattr(src, "travel", ()):  # a moving magnet: projected next to its body (exterior), to the
        # orders that reach it (nearer, the body's high orders alias onto the projection)
        kind, rho_s, top = "exterior", 1.2 * rv, (MAX_TESSERAL_ORDER if tesseral and m_max is None else
                                                  MAX_TRAVEL_ORDER)
    elif kind == "exterior":
        rho_s = max(d - 1.0, 1.05 * rv)
    else:
        rho_s = min(d + 1.0, 0.95 * ri)
    if tesseral:
        modes = tesseral_modes(top, m_max)
        a, again = (_project_tesseral(src, c, rho_s, modes, length, n) for n in (_NODES, _CHECK_NODES))
        degree = np.array([l for l, _ in modes])

        def potentials(x, y):
            return tesseral_potentials(c, src.axis_angle, rho_s, modes, x, y)
    else:
        a, again = (_project_zonal(src, c, kind, rho_s, top, length, n) for n in (_NODES, _CHECK_NODES))
        degree = np.arange(1, top + 1)

        def potentials(x, y):
            return basis_potentials(kind, c, src.axis_angle, rho_s, top, x, y)
    # a coefficient that two quadratures do not agree on to half its size is rounding (an exact
    # dipole's higher orders): zeroed, or its noise, amplified next to the body, sets the order
    a = np.where(np.abs(a - again) > 0.5 * np.abs(a), 0.0, a)
    # the smallest order meeting the tolerance on the part of the reach where the source is not
    if getattr(src, "travel", ()):
        grid = _travel_grid(src, c, rv, length)
    else:
        grid = _beside_grid(c, rv) if kind == "exterior" else reach_grid()
    rho = np.hypot(grid[:, 0] - c[0], grid[:, 1] - c[1])
    inside = rho > 1.02 * rv if kind == "exterior" else rho < 0.98 * ri
    grid, rho = grid[inside], rho[inside]
    Htrue = magpylib_field([src], np.column_stack([grid * length, np.zeros(len(grid))]))[:, :2]
    B, G = _basis_values(_basis(potentials), grid)
    # per degree l = 1..top, the field (and gradient) of its terms
    by_degree = np.zeros((len(a), top))
    by_degree[np.arange(len(a)), degree - 1] = a
    B, G = B @ by_degree, G @ by_degree
    # the truncation error of order L: the field (and gradient) of the degrees above L, and what
    # even the highest order misses against magpylib
    miss = np.linalg.norm(B.sum(2) - Htrue, axis=1) / h0_guess
    tail_h = np.cumsum(B[:, :, ::-1], axis=2)[:, :, ::-1] / h0_guess  # Σ_{l ≥ L}
    tail_g = np.cumsum(G[:, :, ::-1], axis=2)[:, :, ::-1] / h0_guess
    order, valid = top, None
    if miss.max() <= tol:
        for L in range(1, top):
            if (np.linalg.norm(tail_h[:, :, L], axis=1).max() <= 0.1 * tol
                    and np.abs(tail_g[:, :, L]).max() <= tol):
                order = L
                break
    # the series is checked against magpylib's field and its gradient (by differences; the
    # projection's own error is not in the tails), and where it misses either, the region where it
    # holds shrinks to where both are met
    g_true, g_err = checked_gradient([src], grid, length)
    g_miss = np.abs(G[:, :, :order].sum(2) - g_true.transpose(0, 2, 1).reshape(len(grid), 4)).max(axis=1)
    miss = np.maximum(miss, np.maximum(g_miss - g_err, 0.0) / h0_guess)  # less the differences' own error
    if miss.max() > tol:
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
    if tesseral:
        keep = degree <= order
        term = TesseralTerm(kind, c, float(src.axis_angle), float(rho_s), tuple(float(v) for v in a[keep]),
                            float(valid), tuple(m for m, k in zip(modes, keep) if k))
        return term, int(degree[keep].max())
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


def gradient_fd(sources, pts: np.ndarray, length: float, delta=1e-3) -> np.ndarray:
    """∂H_i/∂r_j (A/m per ℓ) at ``pts`` (ℓ) by 4th-order central differences of magpylib, (n, 2, 2);
    ``delta`` (ℓ) a step for all points or one per point, shape (n,)."""
    delta = np.broadcast_to(np.asarray(delta, float), (len(pts),))
    out = np.zeros((len(pts), 2, 2))
    for j in range(2):
        step = np.zeros((len(pts), 2))
        step[:, j] = delta
        vals = [magpylib_field(sources, np.column_stack([(pts + k * step) * length, np.zeros(len(pts))]))[:, :2]
                for k in (-2, -1, 1, 2)]
        out[:, :, j] = (vals[0] - 8 * vals[1] + 8 * vals[2] - vals[3]) / (12 * delta[:, None])
    return out


def checked_gradient(sources, pts: np.ndarray, length: float):
    """magpylib's gradient at ``pts`` (ℓ) by differences with a step of at most 2.5e-4 ℓ and an
    eighth of the point's clearance from every source (their spheres, or a coil's source-free
    ball), extrapolated from that step and its half (Richardson: 4th order to 6th), and a bound on
    its own error (the change on halving the step: truncation and magpylib's rounding, which does
    not shrink with the step), shapes (n, 2, 2) and (n,), A/m per ℓ."""
    clearance = np.full(len(pts), np.inf)
    for s in sources:
        c, rv, ri, kind, _ = geometry(s, length)
        rho = np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[1])
        clearance = np.minimum(clearance, rho - rv if kind == "exterior" else ri - rho)
    delta = np.minimum(2.5e-4, np.maximum(clearance, 1e-9) / 8)
    coarse, fine = gradient_fd(sources, pts, length, delta), gradient_fd(sources, pts, length, 0.5 * delta)
    return fine + (fine - coarse) / 15, np.abs(coarse - fine).max(axis=(1, 2))
