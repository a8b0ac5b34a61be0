"""Vectors of configuration models: dimensionless or SI (x, y) components."""
from __future__ import annotations

from actuator_design.config.base import Number, Q, StrictModel

__all__ = ["NumberXY", "LengthXY", "ForceXY", "LineLoadXY"]


class NumberXY(StrictModel):
    """Dimensionless (x, y) components."""

    x: Number = 0.0
    y: Number = 0.0


class LengthXY(StrictModel):
    """Position (x, y), m; the clamp is at the origin, the rod along +x."""

    x: Q("length") = 0.0
    y: Q("length") = 0.0


class ForceXY(StrictModel):
    """Force (x, y), N."""

    x: Q("force") = 0.0
    y: Q("force") = 0.0


class LineLoadXY(StrictModel):
    """Force per unit length (x, y), N/m."""

    x: Q("force_per_length") = 0.0
    y: Q("force_per_length") = 0.0
