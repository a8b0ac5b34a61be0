"""The ``study:`` sections of the analysis commands: one home for every study schema.

A configuration's ``study: {type: ..., ...}`` holds the flags of one command; each schema below
rejects unknown keys and bounds its values, and the command's flags override what it sets. The
landscape commands (``equilibria``, ``continue``, ``critical``, ``map``) share :class:`StudyBase`
(the scene values a study may set); ``path``, ``phase`` and ``stiffness`` have their own. The
``schedule`` command's keys depend on what is scheduled (a field, coil currents, a magnet's pose):
:data:`SCHEDULE_KEYS`; the ``design`` command's: :data:`DESIGN_KEYS`. (``sweep`` studies:
:mod:`.sweep`; fits: :mod:`.fit`; the landscape commands that name a parameter: :mod:`.parameters`.)
"""
from __future__ import annotations

from typing import Dict, List, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, StrictBool

__all__ = ["StudyBase", "EquilibriaStudy", "PathStudy", "PhaseStudy", "StiffnessStudy", "SCHEDULE_KEYS",
           "DESIGN_KEYS"]

#: The keys of ``study: {type: schedule}``, by what is scheduled (``path_tolerance`` for every kind).
SCHEDULE_KEYS = {
    "field": ("waypoints", "rate_weight", "substeps", "rate", "rotation_rate", "optimal_control", "h_rate", "nodes",
              "path_tolerance"),
    "currents": ("waypoints", "substeps", "optimal_control", "nodes", "slew_rate", "path_tolerance"),
    "pose": ("waypoints", "substeps", "stage_speed", "turn_rate", "path_tolerance"),
}

#: The keys of ``study: {type: design}`` that say what to design for; the others are the fields of
#: :class:`~actuator_design.inverse.settings.DesignSettings`, which validates them on construction.
DESIGN_KEYS = ("target", "targets", "target_units", "vary", "stiffness", "force", "rate", "rotation_rate")


# -- the landscape commands (equilibria; continue, critical and map: .parameters) ------------
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


# -- path, phase, stiffness ------------------------------------------------------------------------
class PathStudy(StudyBase):
    """``study: {type: path, ...}`` — the flags of ``actuator-design path`` (and the scene values of
    :class:`StudyBase`)."""

    type: Literal["path"] = "path"
    param: Optional[str] = None
    schedule: Optional[Union[List[Union[float, str]], List[Dict[str, Union[float, str]]]]] = None  # numbers or quantities
    start: Optional[float] = Field(None, alias="from")
    to: Optional[float] = None
    back: StrictBool = False
    steps: Optional[int] = Field(None, ge=1, le=100000)
    max_step: Optional[float] = Field(None, gt=0, le=1)


class PhaseStudy(StudyBase):
    """``study: {type: phase, ...}`` — the flags of ``actuator-design phase`` (and the scene values
    of :class:`StudyBase`)."""

    type: Literal["phase"] = "phase"
    theta_range: Optional[List[float]] = Field(None, min_length=2, max_length=2)
    dtheta_range: Optional[List[float]] = Field(None, min_length=2, max_length=2)


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
