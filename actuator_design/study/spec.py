"""Validation of a configuration's ``study:`` section (pydantic, unknown keys rejected).

``config.py`` accepts ``study`` as a free mapping; the code that runs it validates it here. Every
failure is a one-line :class:`~actuator_design.config.ConfigError` whose field starts with
``study.``, e.g. ``study.sweep.field.magnitude.n: must be >= 1, got 0``.

A sweep study::

    study:
      type: sweep
      grid: cartesian            # or zip (all value lists of equal length)
      sweep:                     # dotted paths into the config's scene (or solver.<key>)
        field.magnitude: {from: 0 kA/m, to: 30 kA/m, n: 61}
        field.angle: [0 deg, 45 deg, 90 deg]
      analyses: [solve]          # registered analyses; {type: name, <settings>} for settings
      outputs: [solve.tip.*, solve.stable]   # result columns kept (glob patterns); default all
      figures:                   # optional; default: first swept key against the tip angle
        - {x: field.magnitude, y: solve.tip.angle, hue: field.angle}
      max_points: 2000000        # optional; a larger grid is refused before any work
                                 # (default 1 000 000; --max-points overrides)
      chunk_size: 256            # optional: points per task; a solve study walks rays in
                                 # segments of this many points, each from rest (default 256)
"""
from __future__ import annotations

from typing import Any, Dict, List, Literal, Optional, Union

from pydantic import (ConfigDict, Field, StrictFloat, StrictInt, StrictStr, ValidationError, field_validator,
                      model_validator)
from pydantic_core import PydanticCustomError

from actuator_design.analysis import registry
from actuator_design.config import ConfigError
from actuator_design.config import StrictModel as _ConfigStrictModel

__all__ = ["StrictModel", "spec_error", "translate", "validate_spec", "RangeSpec", "FigureSpec",
           "SweepSpec", "analysis_list"]


def spec_error(detail: str, field: Optional[str] = None) -> PydanticCustomError:
    """A validation error raised inside a model; ``field`` names a sub-field (dotted)."""
    return PydanticCustomError("spec", "{detail}", {"detail": detail, "field": field or ""})


class StrictModel(_ConfigStrictModel):
    """Strict base: unknown keys are errors naming the key and the allowed ones (config's rule)."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def _dotted(parts) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def translate(err: ValidationError, prefix: str = "study") -> ConfigError:
    """The first error of ``err`` as a :class:`ConfigError` whose field is ``prefix.<path>``."""
    e = err.errors()[0]
    loc = [prefix] + [p for p in e["loc"] if p not in ("function-after", "function-before")]
    kind, ctx, value = e["type"], e.get("ctx") or {}, e.get("input")
    # pydantic puts the member type of a union in the location ('list[any]', 'RangeSpec'): drop it
    loc = [p for p in loc if not (isinstance(p, str) and (("[" in p and p.endswith("]"))
                                                          or p in _UNION_MEMBERS))]
    if kind == "spec":
        loc += [ctx["field"]] if ctx.get("field") else []
        detail = ctx["detail"]
    elif kind == "unknown_key":
        loc.append(ctx["key"])
        detail = f"unknown key (allowed: {ctx['allowed']}{ctx['hint']})"
    elif kind == "missing":
        detail = "required (missing)"
    elif kind == "literal_error":
        detail = f"must be one of {ctx.get('expected')}, got {value!r}"
    elif kind in ("model_attributes_type", "model_type", "dict_type"):
        detail = f"expected a mapping of keys to values, got {value!r}"
    else:
        msg = e["msg"].removeprefix("Value error, ")
        detail = f"{msg[:1].lower()}{msg[1:]}, got {value!r}"
    return ConfigError(_dotted(loc), detail)


def validate_spec(model, data, prefix: str = "study"):
    """``model.model_validate(data)`` with errors translated to :class:`ConfigError`."""
    if not isinstance(data, dict):
        raise ConfigError(prefix, f"expected a mapping with a 'type' key, got {data!r}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise translate(err, prefix) from None


# -- sweeps ----------------------------------------------------------------------------------------
Scalar = Union[StrictInt, StrictFloat, StrictStr]


class RangeSpec(StrictModel):
    """``{from, to, n}``: ``n`` evenly spaced values (``spacing: log`` for geometric spacing),
    in the unit of ``from``."""

    start: Scalar = Field(alias="from")
    stop: Scalar = Field(alias="to")
    n: StrictInt = Field(ge=1, le=10_000_000)
    spacing: Literal["linear", "log"] = "linear"


class FigureSpec(StrictModel):
    """One figure: result column ``y`` against swept key ``x``, one line per value of ``hue``."""

    x: StrictStr
    y: StrictStr
    hue: Optional[StrictStr] = None


_UNION_MEMBERS = {"RangeSpec", "str", "int", "float", "dict[str,any]"}


class SweepSpec(StrictModel):
    """The ``study:`` section of a sweep (see the module docstring)."""

    type: Literal["sweep"]
    grid: Literal["cartesian", "zip"] = "cartesian"
    sweep: Dict[str, Union[RangeSpec, List[Any]]]
    analyses: List[Union[StrictStr, Dict[str, Any]]] = ["solve"]
    outputs: Optional[List[StrictStr]] = None
    figures: Optional[List[FigureSpec]] = None
    chunk_size: Optional[StrictInt] = Field(default=None, ge=1, le=100_000)
    max_points: Optional[StrictInt] = Field(default=None, ge=1)

    @field_validator("sweep", mode="before")
    @classmethod
    def _check_values(cls, sweep):
        if isinstance(sweep, dict):
            for key, values in sweep.items():
                if not isinstance(values, (list, dict)):
                    raise spec_error(f"expected a list of values or {{from, to, n}}, got {values!r}",
                                     str(key))
        return sweep

    @field_validator("sweep")
    @classmethod
    def _check_sweep(cls, sweep):
        if not sweep:
            raise spec_error("give at least one scene value to sweep, e.g. "
                             "'field.magnitude: {from: 0 kA/m, to: 10 kA/m, n: 11}'")
        for key, values in sweep.items():
            parts = key.split(".")
            if not all(parts):
                raise spec_error(f"'{key}' is not a dotted path such as field.magnitude", key)
            if isinstance(values, list) and not values:
                raise spec_error("needs at least one value", key)
        return sweep

    @field_validator("analyses")
    @classmethod
    def _check_analyses(cls, analyses):
        if not analyses:
            raise spec_error("name at least one analysis, e.g. [solve]")
        return analyses

    @model_validator(mode="after")
    def _check(self):
        if self.grid == "zip":
            lengths = {k: (v.n if isinstance(v, RangeSpec) else len(v)) for k, v in self.sweep.items()}
            first = next(iter(lengths))
            for k, n in lengths.items():
                if n != lengths[first]:
                    raise spec_error(f"grid: zip needs equally many values for every key: "
                                     f"{first} has {lengths[first]}, {k} has {n}", f"sweep.{k}")
        keys = list(self.sweep)
        for i, fig in enumerate(self.figures or []):
            for attr in ("x", "hue"):
                v = getattr(fig, attr)
                if v is not None and v not in keys:
                    raise spec_error(f"must be a swept key ({', '.join(keys)}), got '{v}'",
                                     f"figures[{i}].{attr}")
        return self


def analysis_list(spec: SweepSpec) -> List[Dict[str, Any]]:
    """The analyses as ``[{"type": name, **settings}]``, names checked against the registry.

    Raises
    ------
    ConfigError
        ``study.analyses[i]``: unknown analysis or malformed entry.
    """
    known = registry.names()
    out = []
    for i, item in enumerate(spec.analyses):
        where = f"study.analyses[{i}]"
        if isinstance(item, str):
            entry = {"type": item}
        elif isinstance(item.get("type"), str):
            entry = dict(item)
        else:
            raise ConfigError(where, "expected an analysis name or a mapping {type: <name>, "
                                     f"<settings>}}, got {item!r}")
        if entry["type"] not in known:
            raise ConfigError(f"{where}", f"unknown analysis '{entry['type']}' (allowed: "
                                          f"{', '.join(known)})")
        if any(e["type"] == entry["type"] for e in out):
            raise ConfigError(where, f"analysis '{entry['type']}' is listed twice")
        out.append(entry)
    return out
