"""The fittable parameters and the measured outputs of a calibration.

The fittable parameters are the physical parameters of the project's one parameter lens
(:func:`actuator_design.physics.parameters.physical_parameters`): name → dimension (for units), scale
(positive parameters are fitted in log scale), the scene types that have it, how the dimensionless
groups scale with it, and a description. This module only names them for the calibration and adds
the measured outputs.
"""
from __future__ import annotations

from typing import Dict, List, Tuple

from actuator_design.physics.parameters import PhysicalParameter, physical_parameters

__all__ = ["FitParameter", "PARAMETERS", "OUTPUT_COMPONENT", "unit_of", "alternatives",
           "field_coefficient_exponent", "group_exponent"]

#: A fittable parameter is a physical parameter of the lens.
FitParameter = PhysicalParameter

#: Fittable parameters: the lens's physical parameters (the same mapping, not a copy).
PARAMETERS: Dict[str, PhysicalParameter] = physical_parameters()

#: Measured output column → (component of the tip vector (θ(1), x(1), y(1)), is a length).
OUTPUT_COMPONENT: Dict[str, Tuple[int, bool]] = {
    "tip_angle": (0, False), "tip_x": (1, True), "tip_y": (2, True), "tip_deflection": (2, True)}


def unit_of(name: str) -> str:
    """SI unit symbol of fitted parameter ``name`` ("" when dimensionless)."""
    return PARAMETERS[name].unit


def field_coefficient_exponent(name: str) -> float:
    """e in c ∝ value^e for the field coefficient c = h/H = √(μ0 χ̄ A ℓ²/(2B)) (THEORY §5):
    ½ for χ̄, −½ for E or B0, 0 for the field's own measurement model and the clamp angle."""
    return group_exponent(name, "h")


def group_exponent(name: str, slot: str) -> float:
    """e in (slot group)/H ∝ value^e: the lens exponent of a rod parameter, 0 for the field's own
    measurement model (it changes H, not the coefficient). h_r/H = μ0 M_r A ℓ²/B: 1 for M_r, −1 for
    E or B0 (THEORY §9)."""
    p = PARAMETERS[name]
    return 0.0 if p.through_field else p.exponent(slot)


def alternatives(name: str, kind: str, rod=None) -> List[str]:
    """The parameters of a ``kind`` scene that set a group fitted parameter ``name`` sets (for h: χ̄
    and the rod's E or B0 on a physical scene; for χ̄: h on a dimensionless one); ``rod`` the
    physical scene's rod (its E or B0 is the one given)."""
    return [n for n, q in PARAMETERS.items() if kind in q.scenes and not q.through_field
            and not (q.stiffness and getattr(rod, n, None) is None)
            and any(q.exponent(slot) for slot, _ in PARAMETERS[name].groups)]
