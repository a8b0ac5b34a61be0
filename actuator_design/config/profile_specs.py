"""Configuration models of the profiles of arc length s ∈ [0, 1]: fibre angle α(s) (rad) and relative
bending stiffness b(s) > 0.

A profile is ``{type: constant, value}``, ``{type: table, s, values}`` (linear interpolation, s from
0 to 1 strictly increasing; fibre tables may give ``values_deg``) or ``{type: expression,
expression: "0.3*sin(pi*s)"}``; a bare value means constant. An expression is checked finite (and
positive, for stiffness) on a dense grid here, and on the solver's own quadrature points by
:func:`actuator_design.config.checks.check_profiles_on_mesh`.
"""
from __future__ import annotations

import math
from typing import Annotated, ClassVar, List, Literal, Optional

import numpy as np
from pydantic import AfterValidator, StrictStr, field_validator, model_validator

from actuator_design.config.base import Angle, Number, Positive, StrictModel, tagged
from actuator_design.config.errors import error
from actuator_design.model.expressions import Expression, ExpressionError
from actuator_design.model.profiles import Profile, constant_profile, expression_profile, table_profile
from actuator_design.model.units import angle_range_problem

__all__ = ["FibreConstant", "FibreTable", "FibreExpression", "StiffnessConstant", "StiffnessTable",
           "StiffnessExpression", "FibreProfile", "StiffnessProfile", "GRID",
           "profile_problem", "profile_or"]

#: Arc lengths at which expression profiles are checked, shape (201,).
GRID = np.linspace(0.0, 1.0, 201)


def profile_problem(profile: Profile, s: np.ndarray, positive: bool) -> Optional[str]:
    """Why ``profile`` is not finite (and > 0 when ``positive``) at the arc lengths ``s``, or None."""
    try:
        with np.errstate(all="ignore"):
            v = profile(s)
    except Exception as err:  # e.g. an overflow inside a numpy function
        return f"cannot evaluate on s in [0, 1]: {err}"
    bad = ~np.isfinite(v) | ((v <= 0) if positive else False)
    if not np.any(bad):
        return None
    k = int(np.argmax(bad))
    need = "finite and > 0" if positive else "finite"
    return f"must be {need} on [0, 1], got {v[k]:g} at s = {s[k]:.17g}"


class _TableBase(StrictModel):
    type: Literal["table"]
    s: List[Number]

    @field_validator("s")
    @classmethod
    def _check_nodes(cls, s):
        if len(s) < 2:
            raise error(f"needs at least 2 nodes, got {len(s)}")
        if s[0] != 0 or s[-1] != 1:
            raise error(f"must start at 0 and end at 1 (arc length s in [0, 1]), got {s}")
        if any(b <= a for a, b in zip(s, s[1:])):
            raise error(f"must be strictly increasing, got {s}")
        return s

    def _check_length(self, name: str, values) -> None:
        if len(values) != len(self.s):
            raise error(f"must have as many entries as s ({len(self.s)}), got {len(values)}", name)


class _ExpressionBase(StrictModel):
    type: Literal["expression"]
    expression: StrictStr
    positive_only: ClassVar[bool] = False

    @field_validator("expression")
    @classmethod
    def _parse(cls, text):
        try:
            Expression(text, ("s",))
        except ExpressionError as err:
            raise error(str(err)) from None
        problem = profile_problem(Profile(kind="expression", expression=text), GRID, cls.positive_only)
        if problem is not None:
            raise error(f"{text[:60]!r} {problem}")
        return text

    def to_profile(self) -> Profile:
        return expression_profile(self.expression)


def _degrees_in_range(value: float) -> float:
    problem = angle_range_problem(value, "deg")  # reported in degrees, the unit it was given in
    if problem is not None:
        raise error(problem)
    return value


#: An angle given as a plain number of degrees (``values_deg``), within ±MAX_ANGLE_DEG.
Degrees = Annotated[Number, AfterValidator(_degrees_in_range)]


class FibreConstant(StrictModel):
    """Constant fibre angle α, rad (``"30 deg"`` allowed)."""

    type: Literal["constant"]
    value: Angle = 0.0

    def to_profile(self) -> Profile:
        return constant_profile(self.value)


class FibreTable(_TableBase):
    """Fibre angles at nodes s (rad: numbers or angle strings; or ``values_deg`` in degrees)."""

    values: Optional[List[Angle]] = None
    values_deg: Optional[List[Degrees]] = None

    @model_validator(mode="after")
    def _check(self):
        if (self.values is None) == (self.values_deg is None):
            raise error("give exactly one of values (rad) and values_deg", "values")
        self._check_length(*(("values", self.values) if self.values is not None
                             else ("values_deg", self.values_deg)))
        return self

    def to_profile(self) -> Profile:
        vals = self.values if self.values is not None else [math.radians(v) for v in self.values_deg]
        return table_profile(self.s, vals)


class FibreExpression(_ExpressionBase):
    """Fibre angle α(s) in rad as an expression in s."""


class StiffnessConstant(StrictModel):
    """Constant relative bending stiffness b > 0."""

    type: Literal["constant"]
    value: Positive = 1.0

    def to_profile(self) -> Profile:
        return constant_profile(self.value)


class StiffnessTable(_TableBase):
    """Relative bending stiffness b > 0 at nodes s."""

    values: List[Positive]

    @model_validator(mode="after")
    def _check(self):
        self._check_length("values", self.values)
        return self

    def to_profile(self) -> Profile:
        return table_profile(self.s, self.values)


class StiffnessExpression(_ExpressionBase):
    """Relative bending stiffness b(s) > 0 as an expression in s."""

    positive_only: ClassVar[bool] = True


def profile_or(spec, default: float):
    """The :class:`~actuator_design.model.profiles.Profile` of a profile ``spec``, or the constant
    ``default`` when none is given."""
    return constant_profile(default) if spec is None else spec.to_profile()


def constant_spec(value):
    """A bare number as the spec of a constant profile."""
    return {"type": "constant", "value": value}


FibreProfile = tagged(("fibres",), FibreConstant, FibreTable, FibreExpression, bare=constant_spec)
StiffnessProfile = tagged(("stiffness", "stiffness_profile"), StiffnessConstant, StiffnessTable,
                          StiffnessExpression, bare=constant_spec)
