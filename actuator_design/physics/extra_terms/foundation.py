"""An elastic (Winkler) foundation: the rod rests on a bed of springs that pull it back to its axis.

Energy per unit length ½ k y(s)², y(s) = ∫₀ˢ sin θ the deflection from the clamp's axis (c1), so the
bed pushes with −k y per unit length, transverse to the undeformed rod (a soft substrate, a gel).
Scaled as in THEORY §5: k = k_SI ℓ⁴ / B0 (k_SI in N/m², force per length per deflection).

Its Euler–Lagrange equation (with the bending term, tip force f, THEORY §4 conventions) is
θ'' = N(s) cos θ + fx sin θ − fy cos θ with N' = −k y, N(1) = 0: the bed's resultant N couples every
point to every other, so the Hessian is dense. Its shortest length is the beam-on-foundation
wavelength, wavenumber k^(1/4); k ≤ 1e10 keeps it within the tip load's (√|p| ≤ √1e5).
"""
from __future__ import annotations

from actuator_design.physics.parameter import plugin_parameter
from actuator_design.physics.registration import register_term
from actuator_design.physics.term_protocol import EnergyTerm

__all__ = ["Foundation"]

NAME = "foundation"


@register_term
class Foundation(EnergyTerm):
    """½ k y² per unit length: a Winkler foundation of stiffness k (B0/ℓ⁴) under the rod."""

    name = NAME
    periodic_in_theta = True  # it reads positions only
    scaling_declared = True  # ∝ 1/B0 (THEORY §5), independent of the field
    scalar_params = ("k_foundation",)
    parameters = (
        plugin_parameter(NAME, "k_foundation", "elastic foundation stiffness k (spring force per length per "
                         "deflection)", "B0/l^4", lower=0.0, upper=1e10, residual="linear",
                         stiffness_power=-1.0,
                         flag_help="elastic foundation stiffness k >= 0, units of B0/l^4 (adds the foundation)"),
    )

    @classmethod
    def wavenumber(cls, scene):
        return max(0.0, (scene.term_values(NAME) or {}).get("k_foundation", 0.0)) ** 0.25

    @classmethod
    def dense_hessian(cls, scene):
        return True

    def density(self, kin, P):
        return 0.5 * P["k_foundation"] * kin.y ** 2
