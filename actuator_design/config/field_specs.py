"""Configuration models of vectors and applied fields, dimensionless and physical (THEORY §3, §5).

Dimensionless fields have unit strength (the scene's ``h`` sets it); physical ones carry the field
scale H0 (A/m): the magnitude of a uniform field, m/(4π ℓ³) for a dipole of moment m, or the
``scale`` of an expression field whose ``hx``, ``hy`` are expressions in x, y in units of ℓ.
"""
from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import StrictStr, field_validator, model_validator

from actuator_design.config.base import (Angle, ForceXY, LengthXY, LineLoadXY, Number, NumberXY, Q,
                                         StrictModel, tagged)
from actuator_design.config.errors import error
from actuator_design.config.profile_specs import GRID
from actuator_design.config.source_specs import (PhysicalCoilMap, PhysicalCoils, PhysicalMagnet,
                                                 PhysicalMagnets)
from actuator_design.model.expressions import Expression, ExpressionError
from actuator_design.model.scene import DipoleField, ExpressionField, SourceField, UniformField
from actuator_design.physics.fields import field_model

__all__ = ["NumberXY", "LengthXY", "ForceXY", "LineLoadXY", "UniformSpec", "DipoleSpec",
           "ExpressionSpec", "PhysicalUniform", "PhysicalDipole", "PhysicalExpression",
           "PhysicalMagnet", "PhysicalMagnets", "PhysicalCoils", "DimensionlessField", "PhysicalField", "max_shape_on_rod", "is_non_uniform"]

_HALF_PI = 0.5 * math.pi


# -- fields --------------------------------------------------------------------------------------
class _ExpressionFieldBase(StrictModel):
    type: Literal["expression"]
    hx: StrictStr
    hy: StrictStr

    @field_validator("hx", "hy")
    @classmethod
    def _parse(cls, text):
        try:
            Expression(text, ("x", "y"))
        except ExpressionError as err:
            raise error(str(err)) from None
        return text


def _check_dipole_position(x0: float, y0: float, where: str = "position") -> None:
    if not (math.isfinite(x0) and math.isfinite(y0)):
        raise error(f"must be finite in rod lengths, got ({x0:g}, {y0:g})", where)
    if y0 == 0 and 0 <= x0 <= 1:
        raise error("the dipole lies on the undeformed rod, where its field is singular", where)


class UniformSpec(StrictModel):
    """Dimensionless uniform field at ``angle`` (strength: the scene's ``h``)."""

    type: Literal["uniform"]
    angle: Angle = 0.0

    def to_field(self) -> UniformField:
        return UniformField(phi=self.angle)


class DipoleSpec(StrictModel):
    """Dimensionless point dipole at ``position`` (units of ℓ), moment direction ``moment_angle``."""

    type: Literal["dipole"]
    position: NumberXY
    moment_angle: Angle = _HALF_PI

    @model_validator(mode="after")
    def _check(self):
        _check_dipole_position(self.position.x, self.position.y)
        return self

    def to_field(self) -> DipoleField:
        return DipoleField(x0=self.position.x, y0=self.position.y, moment_angle=self.moment_angle)


class ExpressionSpec(_ExpressionFieldBase):
    """Dimensionless field shape (hx, hy) as expressions in x, y (units of ℓ)."""

    def to_field(self) -> ExpressionField:
        return ExpressionField(hx=self.hx, hy=self.hy)


class PhysicalUniform(StrictModel):
    """Uniform field of strength ``magnitude`` (A/m or T) at ``angle`` to the rod axis."""

    type: Literal["uniform"]
    magnitude: Q("magnetic_field", ge=0)
    angle: Angle = 0.0

    def to_field(self, length: float):
        return UniformField(phi=self.angle), self.magnitude


class PhysicalDipole(StrictModel):
    """Point dipole (small permanent magnet): moment (A m²), position (m), moment direction."""

    type: Literal["dipole"]
    moment: Q("magnetic_moment", gt=0)
    position: LengthXY
    moment_angle: Angle = _HALF_PI

    def to_field(self, length: float, where: str = "position"):
        with np.errstate(all="ignore"):
            x0, y0 = (float(np.float64(v) / length) for v in (self.position.x, self.position.y))
            h0 = float(np.float64(self.moment) / (4.0 * math.pi * np.float64(length) ** 3))
        _check_dipole_position(x0, y0, where)
        return DipoleField(x0=x0, y0=y0, moment_angle=self.moment_angle), h0


class PhysicalExpression(_ExpressionFieldBase):
    """Field H0 · (hx, hy)(x/ℓ, y/ℓ): expressions in x, y in units of the rod length."""

    scale: Q("magnetic_field", gt=0)

    def to_field(self, length: float):
        return ExpressionField(hx=self.hx, hy=self.hy), self.scale


DimensionlessField = tagged(("field",), UniformSpec, DipoleSpec, ExpressionSpec)
PhysicalField = tagged(("field",), PhysicalUniform, PhysicalDipole, PhysicalExpression, PhysicalMagnet,
                       PhysicalMagnets, PhysicalCoils, PhysicalCoilMap)


def is_non_uniform(field_spec) -> bool:
    """A dipole or expression field: every node interacts with every other (dense Hessian)."""
    return isinstance(field_spec, (DipoleSpec, ExpressionSpec, PhysicalDipole, PhysicalExpression, PhysicalMagnet,
                                   PhysicalMagnets, PhysicalCoils, PhysicalCoilMap))


def max_shape_on_rod(field) -> float:
    """max |ĥ| along the undeformed rod (x = s, y = 0), for the saturation check."""
    x, y = GRID, np.zeros_like(GRID)
    if isinstance(field, UniformField):
        return 1.0
    if isinstance(field, SourceField):
        hx, hy = field_model(field).evaluate(x, y, {})
    elif isinstance(field, DipoleField):
        rx, ry = x - field.x0, y - field.y0
        r = np.hypot(rx, ry)
        mx, my = math.cos(field.moment_angle), math.sin(field.moment_angle)
        md = (mx * rx + my * ry) / r
        hx, hy = (3 * md * rx / r - mx) / r**3, (3 * md * ry / r - my) / r**3
    else:
        with np.errstate(all="ignore"):
            hx, hy = (np.broadcast_to(Expression(t, ("x", "y")).evaluate({"x": x, "y": y}), x.shape)
                      for t in (field.hx, field.hy))
    return float(np.nanmax(np.hypot(hx, hy)))
