"""The ``study:`` sections of the landscape commands that name a parameter of the lens
(``continue``, ``critical``, ``map``): apart from :mod:`.commands` because the parameter names
load the lens (and CasADi), which ``equilibria`` and the others do not need at start-up."""
from __future__ import annotations

from typing import Literal, Optional, Tuple

from pydantic import Field, field_validator

from actuator_design.physics.parameters import names as parameter_names
from actuator_design.config.studies.commands import StudyBase

__all__ = ["PARAM_NAMES", "ParamName", "ContinuationStudy", "CriticalStudy", "MapStudy"]

#: Parameters the CLI offers: the lens' built-in ones (plug-in terms register theirs at run time).
PARAM_NAMES = tuple(parameter_names())
ParamName = Literal[PARAM_NAMES]  # type: ignore[valid-type]


class ContinuationStudy(StudyBase):
    type: Literal["continuation"]
    param: ParamName
    start: float = Field(alias="from")
    to: float
    ds: float = Field(0.05, gt=0, le=10)
    #: the largest arclength step; None: 0.5, or 1/400 of a wider window (continuation.follow.default_ds_max)
    ds_max: Optional[float] = Field(None, gt=0, le=100)
    max_points: int = Field(2000, ge=2, le=10**6)
    switch: bool = False
    straight: bool = False
    stop_at_touch: bool = False


class CriticalStudy(StudyBase):
    type: Literal["critical"]
    param: ParamName
    window: Tuple[float, float]
    n_samples: int = Field(5, ge=2, le=200)

    @field_validator("window")
    @classmethod
    def _increasing(cls, w):
        if not w[0] < w[1]:
            raise ValueError("must be increasing [a, b] with a < b")
        return w


class MapStudy(StudyBase):
    type: Literal["map"]
    x_param: ParamName = "h2"
    x_range: Tuple[float, float] = (0.0, 20.0)
    y_param: ParamName = "p"
    y_range: Tuple[float, float] = (0.0, 60.0)
    n: Tuple[int, int] = (50, 50)
    n_gamma: int = Field(161, ge=11, le=100001)
    workers: Optional[int] = Field(None, ge=1, le=1024)
    curves: bool = True
