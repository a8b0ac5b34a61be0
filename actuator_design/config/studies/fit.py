"""The ``study:`` section of a fit: parameters with initial values and bounds, uncertainties.

A configuration's ``study:`` section of ``type: fit`` names the parameters to fit::

    study:
      type: fit
      parameters:                       # initial value and bounds, with units
        chi_bar: {initial: 0.3, bounds: [0.01, 5]}
        clamp_angle: {initial: 0 deg, bounds: [-5 deg, 5 deg]}
      uncertainty: {tip_angle: 0.5 deg} # optional: σ of each measured column (weights)
      confidence: 0.95
      min_p_value: 0.001                # optional: the χ² goodness-of-fit test
                                        # (:mod:`actuator_design.calibration.goodness`)

Every error is one line naming the field (``study.parameters.chi_bar.bounds``, …). The size limits of
a fit's data are in :mod:`actuator_design.calibration.limits`.
"""
from __future__ import annotations

import math
from typing import Dict, List, Literal, Optional, Tuple, Union

from pydantic import Field, StrictFloat, StrictInt, StrictStr, model_validator

from actuator_design.calibration.parameters import OUTPUT_COMPONENT, PARAMETERS
from actuator_design.config.studies.validation import StrictModel, spec_error
from actuator_design.model.units import QuantityError, parse_quantity

__all__ = ["ParameterSpec", "FitSpec", "DEFAULT_MIN_P_VALUE"]

#: An honest fit fails the χ² goodness-of-fit test 1 time in 1000 (``study.min_p_value``).
DEFAULT_MIN_P_VALUE = 1e-3

Value = Union[StrictInt, StrictFloat, StrictStr]


class ParameterSpec(StrictModel):
    """One fitted parameter: initial value (default: the scene's value) and bounds, with units."""

    initial: Optional[Value] = None
    bounds: Optional[List[Value]] = None


class FitSpec(StrictModel):
    """The ``study:`` section of a fit (see the module docstring)."""

    type: Literal["fit"]
    parameters: Dict[str, ParameterSpec]
    uncertainty: Dict[str, Value] = {}
    confidence: StrictFloat = Field(default=0.95, gt=0.5, lt=1.0)
    reference_field: Optional[Value] = None
    ignore_columns: List[StrictStr] = []
    curve_points: StrictInt = Field(default=101, ge=2, le=10_000)
    identifiability_tol: StrictFloat = Field(default=1e-6, gt=0.0, lt=1.0)
    max_nfev: StrictInt = Field(default=200, ge=1)
    min_p_value: StrictFloat = Field(default=DEFAULT_MIN_P_VALUE, gt=0.0, lt=0.5)

    @model_validator(mode="after")
    def _check(self):
        if not self.parameters:
            raise spec_error("name at least one parameter to fit (allowed: "
                             f"{', '.join(PARAMETERS)})", "parameters")
        if "youngs_modulus" in self.parameters and "bending_stiffness" in self.parameters:
            raise spec_error("fit either youngs_modulus or bending_stiffness, not both",
                             "parameters.bending_stiffness")
        for name, p in self.parameters.items():
            where = f"parameters.{name}"
            if name not in PARAMETERS:
                raise spec_error(f"unknown parameter (allowed: {', '.join(PARAMETERS)})", where)
            info = PARAMETERS[name]
            init = None if p.initial is None else _quantity(p.initial, info.dimension,
                                                            f"{where}.initial")
            if p.bounds is not None:
                if len(p.bounds) != 2:
                    raise spec_error(f"expected [lower, upper], got {p.bounds!r}", f"{where}.bounds")
                lo, hi = (_quantity(b, info.dimension, f"{where}.bounds") for b in p.bounds)
                if not lo < hi:
                    raise spec_error(f"lower bound must be < upper bound, got {p.bounds!r}",
                                     f"{where}.bounds")
                if info.log and lo <= 0:
                    raise spec_error(f"{name} is positive: its lower bound must be > 0, got "
                                     f"{p.bounds[0]!r}", f"{where}.bounds")
                if init is not None and not lo <= init <= hi:
                    raise spec_error(f"initial value {p.initial!r} lies outside the bounds "
                                     f"{p.bounds!r}", f"{where}.initial")
            if info.log and init is not None and init <= 0:
                raise spec_error(f"{name} is positive: must be > 0, got {p.initial!r}",
                                 f"{where}.initial")
        for name, v in self.uncertainty.items():
            if name not in OUTPUT_COMPONENT:
                raise spec_error(f"not a measured output (allowed: {', '.join(OUTPUT_COMPONENT)})",
                                 f"uncertainty.{name}")
        return self

    def bounds_of(self, name: str) -> Tuple[float, float]:
        """(lower, upper) bounds of parameter ``name`` in SI units (±inf, or 0 for positive ones)."""
        p, info = self.parameters[name], PARAMETERS[name]
        if p.bounds is None:
            return (0.0 if info.log else -math.inf), math.inf
        return tuple(parse_quantity(b, info.dimension) for b in p.bounds)


def _quantity(value, dimension, where) -> float:
    try:
        return parse_quantity(value, dimension, where.rsplit(".", 1)[-1])
    except QuantityError as err:
        raise spec_error(err.detail, where) from None
