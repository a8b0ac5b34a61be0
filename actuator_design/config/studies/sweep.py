"""The ``study:`` section of a sweep (pydantic, unknown keys rejected).

The configuration accepts ``study`` as a free mapping; the code that runs it validates it with
:func:`~actuator_design.config.studies.validation.validate_spec`. Every failure is a one-line
:class:`~actuator_design.config.ConfigError` whose field starts with ``study.``, e.g.
``study.sweep.field.magnitude.n: must be >= 1, got 0``. The names in ``analyses:`` are checked
against the analysis registry when the study is planned (:func:`actuator_design.study.plan.analysis_list`).

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

from pydantic import Field, StrictFloat, StrictInt, StrictStr, field_validator, model_validator

from actuator_design.config.studies.validation import StrictModel, spec_error

__all__ = ["RangeSpec", "FigureSpec", "SweepSpec"]


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
