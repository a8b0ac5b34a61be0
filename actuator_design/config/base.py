"""Building blocks of the configuration models: the strict base model, quantity fields, tagged unions.

* :class:`StrictModel` rejects unknown keys, naming the key, the allowed ones and the nearest match.
* :func:`Q` is a float field read by :func:`~actuator_design.model.units.parse_quantity` (``"27.5 mm"``)
  in SI units of a dimension, with bounds checked after conversion.
* :func:`tagged` is a ``type:``-tagged union whose tags are remembered for error messages.
* :class:`NumberXY`, :class:`LengthXY`, :class:`ForceXY`, :class:`LineLoadXY`: (x, y) vectors,
  dimensionless or SI.
"""
from __future__ import annotations

import difflib
from typing import Annotated, Union

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationInfo, model_validator
from pydantic_core import PydanticCustomError

from actuator_design.config.errors import UNION_TAGS, error
from actuator_design.model.units import DIMENSIONS, QuantityError, parse_quantity

__all__ = ["StrictModel", "Q", "Angle", "Number", "Positive", "tagged", "interval_text", "NumberXY", "LengthXY",
           "ForceXY", "LineLoadXY"]


def _shown(value, dimension: str) -> str:
    unit = DIMENSIONS[dimension].unit
    if isinstance(value, str) or not unit:
        return str(value)
    return f"{value} {unit}"


def Q(dimension: str, *, gt=None, ge=None, lt=None, le=None, why: str = None):
    """A float field read by :func:`parse_quantity` in SI units of ``dimension``, with bounds.

    Parameters
    ----------
    dimension : str
        A key of :data:`~actuator_design.model.units.DIMENSIONS` (``"length"``, ``"angle"``, ...).
    gt, ge, lt, le : float, optional
        Bounds on the value in SI units; a violation names the bound and the value as written.
    why : str, optional
        The reason for the bounds (a physical plausibility range): a violation then states the
        whole allowed interval with its SI unit and this reason, e.g. ``must be in [0, 3e+06] A/m
        (...), got '1e12 A/m'``.
    """

    def validate(value, info: ValidationInfo):
        try:
            x = parse_quantity(value, dimension, info.field_name or "value")
        except QuantityError as err:
            raise error(err.detail) from None
        for bound, ok, sym in ((gt, lambda b: x > b, ">"), (ge, lambda b: x >= b, ">="),
                               (lt, lambda b: x < b, "<"), (le, lambda b: x <= b, "<=")):
            if bound is not None and not ok(bound):
                if why is not None:
                    raise error(f"must be in {interval_text(dimension, gt, ge, lt, le)} ({why}), "
                                f"got {_shown(value, dimension)!r}")
                raise error(f"must be {sym} {bound:g}, got {_shown(value, dimension)}")
        return x

    return Annotated[float, BeforeValidator(validate)]


def interval_text(dimension: str, gt=None, ge=None, lt=None, le=None) -> str:
    """The interval of the bounds in the SI unit of ``dimension``: ``"[0, 3e+06] A/m"``."""
    lo = f"[{ge:g}" if ge is not None else (f"({gt:g}" if gt is not None else "(-inf")
    hi = f"{le:g}]" if le is not None else (f"{lt:g})" if lt is not None else "inf)")
    unit = DIMENSIONS[dimension].unit
    return f"{lo}, {hi}" + (f" {unit}" if unit else "")


Angle = Q("angle")
Number = Q("dimensionless")
Positive = Q("dimensionless", gt=0)


class StrictModel(BaseModel):
    """Strict base: unknown keys are errors that name the key and list the allowed ones.

    Also the base of other layers that validate YAML sections (study specifications).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _reject_unknown_keys(cls, data):
        if isinstance(data, dict):
            allowed = [f.alias or n for n, f in cls.model_fields.items()]
            for key in data:
                if key not in allowed and key not in cls.model_fields:
                    near = difflib.get_close_matches(str(key), allowed, n=1)
                    hint = f"; did you mean '{near[0]}'?" if near else ""
                    raise PydanticCustomError(
                        "unknown_key", "unknown key (allowed: {allowed}{hint})",
                        {"key": str(key)[:80], "allowed": ", ".join(allowed), "hint": hint})
        return data


def tagged(field_names, *models, bare=None):
    """A ``type:``-tagged union of ``models`` used under ``field_names``.

    Parameters
    ----------
    field_names : tuple of str
        Names of the fields holding this union (their tags are listed in error messages).
    *models : StrictModel subclasses
        Each with a ``type: Literal[...]`` field.
    bare : callable, optional
        Rewrites a non-mapping value (e.g. a number meaning a constant profile).
    """
    tags = [m.model_fields["type"].annotation.__args__[0] for m in models]
    for name in field_names:
        UNION_TAGS.setdefault(name, [])
        UNION_TAGS[name] += [t for t in tags if t not in UNION_TAGS[name]]
    union = Annotated[Union[models], Field(discriminator="type")]
    if bare is not None:
        union = Annotated[union, BeforeValidator(lambda v: v if isinstance(v, dict) else bare(v))]
    return union


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
