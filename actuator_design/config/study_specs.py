"""The ``study:`` sections of the analysis commands: one home for every study schema.

A configuration's ``study: {type: ..., ...}`` holds the flags of one command; each schema below
rejects unknown keys and bounds its values, and the command's flags override what it sets. The
landscape commands (``equilibria``, ``continue``, ``critical``, ``map``) share :class:`StudyBase`
(the scene values a study may set); ``path``, ``phase`` and ``stiffness`` have their own. The
``schedule`` command's keys depend on what is scheduled (a field, coil currents, a magnet's pose):
:data:`SCHEDULE_KEYS`. (``sweep`` studies: :mod:`actuator_design.study.spec`; calibration:
:mod:`actuator_design.calibration.spec`.)
"""
from __future__ import annotations

from typing import Dict, List, Literal, Optional, Tuple, Union

from pydantic import BaseModel, ConfigDict, Field, StrictBool, field_validator

from ..parameters import names as parameter_names

__all__ = ["PARAM_NAMES", "ParamName", "StudyBase", "EquilibriaStudy", "ContinuationStudy", "CriticalStudy",
           "MapStudy", "PathStudy", "PhaseStudy", "StiffnessStudy", "SCHEDULE_KEYS"]

#: Parameters the CLI offers: the lens' built-in ones (plug-in terms register theirs at run time).
PARAM_NAMES = tuple(parameter_names())
ParamName = Literal[PARAM_NAMES]  # type: ignore[valid-type]

#: The keys of ``study: {type: schedule}``, by what is scheduled (``path_tolerance`` for every kind).
SCHEDULE_KEYS = {
    "field": ("waypoints", "rate_weight", "substeps", "rate", "rotation_rate", "optimal_control", "h_rate", "nodes",
              "path_tolerance"),
    "currents": ("waypoints", "substeps", "optimal_control", "nodes", "slew_rate", "path_tolerance"),
    "pose": ("waypoints", "substeps", "stage_speed", "turn_rate", "path_tolerance"),
}


# -- the landscape commands (equilibria, continue, critical, map) ---------------------------------
class StudyBase(BaseModel):
    """Scene values a study may set (flags override them)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, populate_by_name=True)
    h: Optional[float] = Field(None, ge=0)
    phi_deg: Optional[float] = None
    p: Optional[float] = None
    alpha_deg: Optional[float] = None


class EquilibriaStudy(StudyBase):
    type: Literal["equilibria"]
    n_gamma: int = Field(401, ge=11, le=100001)
    method: Literal["shooting", "deflation"] = "shooting"


class ContinuationStudy(StudyBase):
    type: Literal["continuation"]
    param: ParamName
    start: float = Field(alias="from")
    to: float
    ds: float = Field(0.05, gt=0, le=10)
    ds_max: float = Field(0.5, gt=0, le=100)
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


# -- path, phase, stiffness ------------------------------------------------------------------------
class PathStudy(BaseModel):
    """``study: {type: path, ...}`` — the flags of ``actuator-design path``."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    type: Literal["path"] = "path"
    param: Optional[str] = None
    schedule: Optional[Union[List[Union[float, str]], List[Dict[str, Union[float, str]]]]] = None  # numbers or quantities
    start: Optional[float] = Field(None, alias="from")
    to: Optional[float] = None
    back: StrictBool = False
    steps: Optional[int] = Field(None, ge=1, le=100000)
    max_step: Optional[float] = Field(None, gt=0, le=1)
    h: Optional[float] = Field(None, ge=0)
    phi_deg: Optional[float] = None
    p: Optional[float] = None
    alpha_deg: Optional[float] = None


class PhaseStudy(BaseModel):
    """``study: {type: phase, ...}`` — the flags of ``actuator-design phase``."""

    model_config = ConfigDict(extra="forbid")
    type: Literal["phase"] = "phase"
    theta_range: Optional[List[float]] = Field(None, min_length=2, max_length=2)
    dtheta_range: Optional[List[float]] = Field(None, min_length=2, max_length=2)
    h: Optional[float] = Field(None, ge=0)
    phi_deg: Optional[float] = None
    p: Optional[float] = None
    alpha_deg: Optional[float] = None


class StiffnessStudy(BaseModel):
    """``study: {type: stiffness, ...}`` — the flags of ``actuator-design stiffness``."""

    model_config = ConfigDict(extra="forbid")
    type: Literal["stiffness"] = "stiffness"
    field_sweep: Optional[List[float]] = Field(None, min_length=2, max_length=2)
    n: int = Field(41, ge=2, le=100000)
    moment: StrictBool = True
    h: Optional[float] = Field(None, ge=0)
    phi_deg: Optional[float] = None
    p: Optional[float] = None
    alpha_deg: Optional[float] = None
