"""Fields of magnets and coils as zonal solid harmonics: exact derivatives, div- and curl-free.

A magnet or coil whose symmetry axis lies in the rod's plane (z = 0) has, outside its sources, a
magnetic scalar potential ψ (H = −∇ψ) that is harmonic and axisymmetric about the axis. About the
source's centre c, with ρ = |r − c| and cos ϑ = (r − c)·ê/ρ (ê the axis, in the plane):

    exterior (ρ > R_v, the sphere holding every source):  ψ = Σ_l a_l (R/ρ)^(l+1) P_l(cos ϑ)
    interior (ρ < R_i, the ball free of sources):        ψ = Σ_l a_l (ρ/R)^l P_l(cos ϑ)

Every term is a solid harmonic in three dimensions, so the represented field is divergence- and
curl-free by construction (THEORY §3: the applied field of a current-free region); in the plane
z = 0 its normal component vanishes by the symmetry z → −z. The coefficients are fitted to
magpylib (:mod:`actuator_design.model.field_sources`), which stays the source of truth; here is only
their evaluation as CasADi expressions (exact gradients and Hessians for the NLP) and the region
where a fit holds. The recurrences (ϱ = ρ/R, u = (r − c)·ê/R, q = ϱ²) are Legendre's three-term
recurrence multiplied out, so no square root is taken in the interior form:

    interior  R_l = ϱ^l P_l:        (l+1) R_{l+1} = (2l+1) u R_l − l q R_{l−1},  R_0 = 1, R_1 = u
    exterior  I_l = ϱ^−(l+1) P_l:  (l+1) I_{l+1} = ((2l+1) u I_l − l I_{l−1}) / q,  I_0 = 1/ϱ, I_1 = u/ϱ³

A magnet that is not axisymmetric about an axis in the plane (a cuboid, a diametric cylinder) has
the tesseral expansion of :mod:`.tesseral`; :func:`potential` and :func:`field_function` take both.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Union

import casadi as ca

from actuator_design.physics.tesseral import Expansion, TesseralTerm, tesseral_in_plane, tesseral_potentials

__all__ = ["HarmonicTerm", "TesseralTerm", "basis_potentials", "potential", "field_function"]


@dataclass(frozen=True)
class HarmonicTerm(Expansion):
    """One source's fitted zonal expansion (the attributes of :class:`~.tesseral.Expansion`;
    ``coefficients`` a_1, a_2, ...: a_0 carries no field; ``radius`` the sphere they were projected
    on)."""

    @property
    def order(self) -> int:
        """The highest Legendre degree l of the expansion."""
        return len(self.coefficients)


def basis_potentials(kind: str, centre, axis_angle: float, radius: float, order: int, x, y, z=0.0) -> list:
    """The unit-coefficient potentials [ψ_1, ..., ψ_order] of a zonal expansion at (x, y, z) (CasADi
    scalars or numbers, units of ℓ), by the recurrences of the module docstring."""
    ex, ey = math.cos(axis_angle), math.sin(axis_angle)
    dx, dy, dz = (x - centre[0]) / radius, (y - centre[1]) / radius, z / radius
    u = ex * dx + ey * dy
    q = dx * dx + dy * dy + dz * dz
    out = []
    if kind == "interior":
        prev, cur = 1.0, u
        for l in range(1, order + 1):
            out.append(cur)
            prev, cur = cur, ((2 * l + 1) * u * cur - l * q * prev) / (l + 1)
        return out
    inv_q = 1 / q
    prev = ca.sqrt(inv_q) if isinstance(q, (ca.SX, ca.MX)) else math.sqrt(inv_q)
    cur = u * prev * inv_q
    for l in range(1, order + 1):
        out.append(cur)
        prev, cur = cur, ((2 * l + 1) * u * cur - l * prev) * inv_q / (l + 1)
    return out


def potential(term, x, y, z=0.0):
    """ψ of one term (:class:`HarmonicTerm` or :class:`TesseralTerm`) at (x, y, z) (CasADi scalars or
    numbers, units of ℓ)."""
    if isinstance(term, TesseralTerm) and isinstance(z, (int, float)) and z == 0:
        return tesseral_in_plane(term, x, y)
    if isinstance(term, TesseralTerm):
        basis = tesseral_potentials(term.centre, term.axis_angle, term.radius, term.modes, x, y, z, term.kind)
    else:
        basis = basis_potentials(term.kind, term.centre, term.axis_angle, term.radius, len(term.coefficients),
                                 x, y, z)
    return sum((a * b for a, b in zip(term.coefficients, basis)), 0)


def field_function(terms: Sequence[Union[HarmonicTerm, TesseralTerm]], with_z: bool = False) -> ca.Function:
    """ĥ = −∇ψ summed over ``terms`` as a CasADi function of scalars (x, y) → (hx, hy), or with
    ``with_z`` of (x, y, z) → (hx, hy, hz) (for checks off the plane)."""
    x, y, z = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("z")
    psi = sum((potential(t, x, y, z if with_z else 0.0) for t in terms), ca.SX(0))
    r = ca.vertcat(x, y, z) if with_z else ca.vertcat(x, y)
    h = -ca.gradient(psi, r)
    ins = [x, y, z] if with_z else [x, y]
    return ca.Function("harmonic_field", ins, [h[i] for i in range(h.numel())])
