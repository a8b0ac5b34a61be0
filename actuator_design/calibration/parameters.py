"""The fittable parameters and the measured outputs of a calibration.

One small table, kept apart so that it can later be folded into the project-wide parameter lens
(issue 11): name → physical dimension (for units), scale (positive parameters are fitted in log
scale), the scene types it applies to, and a description.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Tuple

from ..units import DIMENSIONS

__all__ = ["FitParameter", "PARAMETERS", "OUTPUT_COMPONENT", "SLOTS", "unit_of"]


@dataclass(frozen=True)
class FitParameter:
    """A fittable parameter: dimension (a key of ``units.DIMENSIONS``), log scale, scene types."""

    dimension: str
    log: bool  # positive parameter, fitted in log scale
    scenes: Tuple[str, ...]
    description: str


#: Fittable parameters: dimension (for units), scale, scene types, meaning.
PARAMETERS: Dict[str, FitParameter] = {
    "chi_bar": FitParameter("dimensionless", True, ("physical",),
                            "orientational susceptibility χ̄"),
    "youngs_modulus": FitParameter("pressure", True, ("physical",), "Young's modulus E (B0 = E I)"),
    "bending_stiffness": FitParameter("bending_stiffness", True, ("physical",),
                                      "bending stiffness B0"),
    "h": FitParameter("dimensionless", True, ("dimensionless",), "field group h (THEORY §5)"),
    "clamp_angle": FitParameter("angle", False, ("physical", "dimensionless"), "clamp angle θ0"),
    "field_scale": FitParameter("dimensionless", True, ("physical", "dimensionless"),
                                "factor on the measured field"),
    "field_offset": FitParameter("magnetic_field", False, ("physical", "dimensionless"),
                                 "offset added to the measured field"),
    "field_angle_offset": FitParameter("angle", False, ("physical", "dimensionless"),
                                       "offset added to the field angle"),
}

#: Measured output column → (component of the tip vector (θ(1), x(1), y(1)), is a length).
OUTPUT_COMPONENT: Dict[str, Tuple[int, bool]] = {
    "tip_angle": (0, False), "tip_x": (1, True), "tip_y": (2, True), "tip_deflection": (2, True)}

#: NLP parameter slots a fit may change (when the scene structure has them).
SLOTS = ("h", "phi", "fx", "fy", "qx", "qy", "m_tip", "theta0")


def unit_of(name: str) -> str:
    """SI unit symbol of fitted parameter ``name`` ("" when dimensionless)."""
    return DIMENSIONS[PARAMETERS[name].dimension].unit
