"""A dead distributed load whose intensity varies linearly along the rod: q(s) = (1 − s) q_root +
s q_tip (the weight of a tapered rod, a pressure growing with depth).

Energy per unit length −q(s)·r(s), scaled as the uniform distributed load (THEORY §5:
q = q_SI ℓ³ / B0). Its Euler–Lagrange equation (with bending) is θ'' = Qx sin θ − Qy cos θ with the
resultant of the load beyond s, Q(s) = ∫ₛ¹ q = q_root (1 − s)²/2 + q_tip (1 − s²)/2. Linear in the
positions, so its Hessian is diagonal (banded); wavenumber max|q|^(1/3) and
the range |q| ≤ 1e5 like the uniform load.
"""
from __future__ import annotations

import math

from actuator_design.physics.parameter import plugin_parameter
from actuator_design.physics.registration import register_term
from actuator_design.physics.term_protocol import EnergyTerm

__all__ = ["TaperedLoad"]

NAME = "tapered_load"
_SLOTS = ("q_root_x", "q_root_y", "q_tip_x", "q_tip_y")


@register_term
class TaperedLoad(EnergyTerm):
    """−((1 − s) q_root + s q_tip)·r(s) per unit length: a linearly varying dead load (B0/ℓ³)."""

    name = NAME
    periodic_in_theta = True  # it reads positions only
    scaling_declared = True  # ∝ 1/B0 (THEORY §5), independent of the field
    scalar_params = _SLOTS
    node_fields = {"arclength": lambda scene, s: s}
    parameters = tuple(
        plugin_parameter(NAME, slot, f"tapered load: {'clamp' if 'root' in slot else 'tip'} intensity, "
                         f"{slot[-1]} component", "B0/l^3", lower=-1e5, upper=1e5, residual="linear",
                         stiffness_power=-1.0) for slot in _SLOTS)

    @classmethod
    def wavenumber(cls, scene):
        v = scene.term_values(NAME) or {}
        return max(math.hypot(v.get("q_root_x", 0.0), v.get("q_root_y", 0.0)),
                   math.hypot(v.get("q_tip_x", 0.0), v.get("q_tip_y", 0.0))) ** (1.0 / 3.0)

    def density(self, kin, P):
        s = kin.fields["arclength"]
        qx = (1 - s) * P["q_root_x"] + s * P["q_tip_x"]
        qy = (1 - s) * P["q_root_y"] + s * P["q_tip_y"]
        return -(qx * kin.x + qy * kin.y)
