"""Fields of magnets that are not axisymmetric about an axis in the plane, as tesseral solid harmonics.

A cuboid magnet magnetised along an edge (that edge in the rod's plane), or a cylinder standing on
the plane and magnetised across a diameter, is mirror symmetric in the plane z = 0 and in its axis
line and reversed by the mirror across its axis. Outside its circumscribed sphere its potential has
the tesseral expansion (polar axis z, φ measured in the plane from the axis ê, x = (r − c)/R with
components u along ê, v across it, w = z/R):

    ψ = Σ_{l odd} Σ_{m odd ≤ l} a_lm P̄_l^m(cos ϑ) cos mφ / |x|^(l+1)
      = Σ a_lm Q_l^m(w, |x|²) Re((u + i v)^m) / |x|^(2l+1)      (Kelvin's inversion of r^l Y_lm)

with P̄_l^m = √((l−m)!/(l+m)!) P_l^m (∫ P̄² = 2/(2l+1)) and Q_l^m the fully normalised polynomial
part, by the recurrence (every factor O(1), so no factorial overflows)

    Q_m^m = √((2m)!)/(2^m m!),   Q_{m+1}^m = √(2m+1) w Q_m^m,
    Q_l^m = (2l−1)/√((l−m)(l+m)) w Q_{l−1}^m − √((l+m−1)(l−m−1)/((l+m)(l−m))) |x|² Q_{l−2}^m.

Odd m is the reversal across the axis (u → −u), cos mφ the mirror in the axis line (v → −v) and
l − m even the mirror in the plane (w → −w); each term is again a solid harmonic, so the field is
divergence- and curl-free by construction. A diametric cylinder's potential is −M ∂Φ/∂u of its
body's axisymmetric (about z) potential Φ: only m = 1. The coefficients are fitted to magpylib
(:mod:`actuator_design.model.source_fit`); here is their evaluation (CasADi expressions or NumPy).

A coil's field measured over a workspace free of sources (a calibration map,
:mod:`actuator_design.model.coil_map`) has the interior expansion, the regular solid harmonics themselves,

    ψ = Σ a_lm Q_l^m(w, |x|²) Re((u + i v)^m)   (m ≥ 0),   a_l,−m Q_l^m(w, |x|²) Im((u + i v)^m),

with l − |m| even (the field mirror symmetric in the rod's plane: no normal component in it) and
a negative m naming the sine term sin |m|φ.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

import casadi as ca
import numpy as np

__all__ = ["Expansion", "TesseralTerm", "tesseral_modes", "interior_modes", "tesseral_potentials", "tesseral_in_plane", "distance_from"]


def distance_from(centre, x, y) -> np.ndarray:
    """|r − c| in the plane at points (x, y) (units of ℓ), array."""
    return np.hypot(np.asarray(x, float) - centre[0], np.asarray(y, float) - centre[1])


@dataclass(frozen=True)
class Expansion:
    """What every fitted solid-harmonic expansion of one source has (dimensionless: lengths in ℓ,
    ψ in units of H0 ℓ): :class:`TesseralTerm` and :class:`~.harmonic.HarmonicTerm`.

    Attributes
    ----------
    kind : {"exterior", "interior"}
        Outside the sphere holding the source, or inside a ball free of sources.
    centre : (float, float)
        c, units of ℓ (the clamp at the origin).
    axis_angle : float
        Direction of ê in the plane, rad from c1.
    radius : float
        R, the normalising radius, units of ℓ.
    coefficients : tuple of float
        The expansion's coefficients.
    valid_radius : float
        Where the fit holds to its reported error: ρ ≥ valid_radius (exterior) or
        ρ ≤ valid_radius (interior), units of ℓ.
    """

    kind: str
    centre: Tuple[float, float]
    axis_angle: float
    radius: float
    coefficients: Tuple[float, ...]
    valid_radius: float

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Whether the points (units of ℓ) lie where the fit holds; boolean array."""
        rho = distance_from(self.centre, x, y)
        return rho >= self.valid_radius if self.kind == "exterior" else rho <= self.valid_radius


@dataclass(frozen=True)
class TesseralTerm(Expansion):
    """One source's fitted tesseral expansion (module docstring; the attributes of
    :class:`Expansion`): a magnet's outside its circumscribed sphere (``kind`` "exterior",
    ``coefficients`` a_lm), or a calibration map's coil inside a ball free of sources ("interior").

    Attributes
    ----------
    modes : tuple of (int, int)
        (l, m) of each coefficient, |m| ≤ l: l and m odd (a magnet), or l − |m| even with m < 0 the
        sine term (a map).
    """

    modes: Tuple[Tuple[int, int], ...]

    @property
    def order(self) -> int:
        """The highest degree l of the expansion."""
        return max((l for l, _ in self.modes), default=0)

def tesseral_modes(order: int, m_max: Optional[int] = None) -> Tuple[Tuple[int, int], ...]:
    """(l, m), l and m odd, m ≤ min(l, ``m_max``), l ≤ ``order``, sorted by l then m."""
    top_m = order if m_max is None else m_max
    return tuple((l, m) for l in range(1, order + 1, 2) for m in range(1, min(l, top_m) + 1, 2))


def interior_modes(order: int) -> Tuple[Tuple[int, int], ...]:
    """(l, m) of the interior terms mirror symmetric in the plane: 1 ≤ l ≤ ``order``, l − |m| even,
    m = −l, −l + 2, …, l (m < 0 the sine terms), sorted by l then m; l(l + 3)/2 modes up to l."""
    return tuple((l, m) for l in range(1, order + 1) for m in range(-l, l + 1, 2))


def _sqrt(v):
    return ca.sqrt(v) if isinstance(v, (ca.SX, ca.MX)) else np.sqrt(v)


def _local(centre, axis_angle: float, radius: float, x, y):
    """(u, v): (r − c)/R along the axis ê and across it."""
    ex, ey = math.cos(axis_angle), math.sin(axis_angle)
    dx, dy = (x - centre[0]) / radius, (y - centre[1]) / radius
    return ex * dx + ey * dy, -ey * dx + ex * dy


def _q_mm(m: int) -> float:
    """Q_m^m = √((2m)!)/(2^m m!), in logarithms (no factorial overflows)."""
    return math.exp(0.5 * math.lgamma(2 * m + 1) - m * math.log(2.0) - math.lgamma(m + 1))


def _in_plane_step(l: int, m: int) -> float:
    """−b: Q_{l+2}^m = −b |x|² Q_l^m where w = 0."""
    return -math.sqrt((l + 1 + m) * (l + 1 - m) / ((l + 2 + m) * (l + 2 - m)))


def _by_order(modes, values=None) -> dict:
    """{m: {l: value}} (value: True when ``values`` is None), m signed (negative: the sine term)."""
    out = {}
    for k, (l, m) in enumerate(modes):
        out.setdefault(m, {})[l] = True if values is None else values[k]
    return out


def _angular(by_m: dict, u, v):
    """(|m|, signed m, Re or Im of (u + i v)^|m|) for every signed m of ``by_m``, by increasing |m|."""
    re, im = 1.0, 0.0
    for m in range(0, max((abs(k) for k in by_m), default=-1) + 1):
        if m > 0:
            re, im = re * u - im * v, re * v + im * u
        for signed, part in (((0, re),) if m == 0 else ((m, re), (-m, im))):
            if signed in by_m:
                yield m, signed, part


def tesseral_potentials(centre, axis_angle: float, radius: float, modes, x, y, z=0.0,
                        kind: str = "exterior") -> list:
    """The unit-coefficient potentials of ``modes`` at (x, y, z) (CasADi scalars, numbers or NumPy
    arrays, units of ℓ): exterior P̄_l^m(cos ϑ) cos mφ / |x|^(l+1), or interior |x|^l P̄_l^m(cos ϑ)
    (cos or sin) |m|φ, by the recurrence of the module docstring. In the plane (``z`` the number 0) a
    mode with l − |m| odd is 0."""
    u, v = _local(centre, axis_angle, radius, x, y)
    in_plane = isinstance(z, (int, float)) and z == 0
    w = 0.0 if in_plane else z / radius
    q = u * u + v * v + w * w
    top = max((l for l, _ in modes), default=0)
    inv_r = [1.0] * (top + 1)
    if kind == "exterior":
        inv_q = 1 / q
        inv_r = [_sqrt(inv_q)]  # 1/|x|^(2l+1), l = 0..top
        for _ in range(top):
            inv_r.append(inv_r[-1] * inv_q)
    wanted = _by_order(modes)
    values = {}
    for m, signed, part in _angular(wanted, u, v):
        q_cur, q_prev = _q_mm(m), 0.0
        step = 2 if in_plane else 1  # in the plane every second Q_l^m vanishes with w
        for l in range(m, max(wanted[signed]) + 1, step):
            if l in wanted[signed]:
                values[(l, signed)] = q_cur * part * inv_r[l]
            if in_plane:
                q_cur = _in_plane_step(l, m) * q * q_cur
            else:
                a = (2 * l + 1) / math.sqrt((l + 1 - m) * (l + 1 + m))
                b = math.sqrt((l + m) * (l - m) / ((l + 1 + m) * (l + 1 - m)))
                q_prev, q_cur = q_cur, a * w * q_cur - b * q * q_prev
    return [values.get(mode, 0.0) for mode in modes]


def tesseral_in_plane(term: TesseralTerm, x, y):
    """ψ of a tesseral term in the plane z = 0, nested (two operations a term): with l = |m| + 2k,
    Q_l^m(0, q) = κ_lm q^k (κ by the recurrence's w = 0 form), so

        exterior  ψ = Σ_m Re((u + i v)^m) q^(−m−1/2) Σ_k a_lm κ_lm q^(−k),
        interior  ψ = Σ_m (Re or Im)((u + i v)^|m|) Σ_k a_lm κ_lm q^k,

    the inner sums by Horner's rule in 1/q or q (CasADi scalars, numbers or arrays, units of ℓ)."""
    u, v = _local(term.centre, term.axis_angle, term.radius, x, y)
    q = u * u + v * v
    exterior = term.kind == "exterior"
    inv_q = 1 / q if exterior else None
    by_m = _by_order(term.modes, term.coefficients)
    psi, scale, scaled = 0.0, _sqrt(inv_q) if exterior else 1.0, 0  # scale = q^(−m−1/2) (exterior)
    for m, signed, part in _angular(by_m, u, v):
        while exterior and scaled < m:
            scale, scaled = scale * inv_q, scaled + 1
        kappa, weights = _q_mm(m), []  # a_lm κ_lm for k = 0, 1, ...
        for l in range(m, max(by_m[signed]) + 1, 2):
            weights.append(by_m[signed].get(l, 0.0) * kappa)
            kappa *= _in_plane_step(l, m)
        inner = weights[-1]
        for wk in reversed(weights[:-1]):
            inner = inner * (inv_q if exterior else q) + wk
        psi = psi + part * scale * inner
    return psi
