"""The ``type: dimensionless`` scene: the groups of THEORY §5 given directly.

Keys: ``h``, ``phi`` (or ``field``), ``p`` (or ``tip_force``), ``tip_moment``, ``distributed_load``,
``h_pos``, ``fibres``, ``stiffness``, ``clamp_angle``, and for a hard-magnetic rod (THEORY §9)
``h_r`` with ``magnetization`` (the angle β(s) of the remanent magnetisation to the tangent, in
every form ``fibres`` takes; default 0 when ``h_r`` is given). Lengths (positions) are in units of the rod
length ℓ. Every group must lie in its range (:data:`~actuator_design.config.limits.GROUP_RANGES`).
"""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import model_validator

from ..profiles import constant_profile
from ..scene import Scene, UniformField
from .base import Angle, Number, Q, StrictModel
from .errors import error
from .field_specs import DimensionlessField, NumberXY
from .limits import group_problem
from .profile_specs import FibreProfile, MagnetizationProfile, StiffnessProfile

__all__ = ["DimensionlessScene"]


def _xy(vec):
    return None if vec is None else (vec.x, vec.y)


class DimensionlessScene(StrictModel):
    """The groups of THEORY §5 given directly (see the module docstring)."""

    type: Literal["dimensionless"]
    h: Optional[Q("dimensionless", ge=0)] = None
    h_pos: Q("dimensionless", ge=0) = 0.0
    phi: Optional[Angle] = None
    field: Optional[DimensionlessField] = None
    p: Optional[Number] = None
    tip_force: Optional[NumberXY] = None
    tip_moment: Optional[Number] = None
    distributed_load: Optional[NumberXY] = None
    fibres: Optional[FibreProfile] = None
    stiffness: Optional[StiffnessProfile] = None
    clamp_angle: Angle = 0.0
    h_r: Optional[Q("dimensionless", ge=0)] = None
    magnetization: Optional[MagnetizationProfile] = None

    @model_validator(mode="after")
    def _check(self):
        if self.phi is not None and self.field is not None:
            raise error("give either phi (uniform field) or field, not both", "phi")
        if self.p is not None and self.tip_force is not None:
            raise error("give either p or tip_force, not both", "p")
        tip, load = self.tip_force, self.distributed_load
        for group, value, field in (
                ("h", self.h, "h"), ("h_pos", self.h_pos, "h_pos"), ("h_r", self.h_r, "h_r"),
                ("p", self.p, "p"),
                ("fx", tip and tip.x, "tip_force.x"), ("p", tip and tip.y, "tip_force.y"),
                ("tip_moment", self.tip_moment, "tip_moment"),
                ("qx", load and load.x, "distributed_load.x"),
                ("qy", load and load.y, "distributed_load.y")):
            problem = None if value is None else group_problem(group, value)
            if problem is not None:
                raise error(problem, field)
        return self

    def to_scene(self, name: Optional[str] = None) -> Scene:
        if self.field is not None:
            field = self.field.to_field()
        elif self.h is not None or self.phi is not None or self.hard_magnetic:
            field = UniformField(phi=self.phi or 0.0)
        else:
            field = None
        tip = (0.0, self.p) if self.p is not None else _xy(self.tip_force)
        return Scene(field=field, h=self.h or 0.0, h_pos=self.h_pos,
                     fibres=_profile(self.fibres, 0.0), stiffness=_profile(self.stiffness, 1.0),
                     tip_force=tip, tip_moment=self.tip_moment,
                     distributed_load=_xy(self.distributed_load), theta0=self.clamp_angle,
                     scales=None, name=name or "dimensionless cantilever", h_r=self.h_r or 0.0,
                     fibres_given=self.fibres is not None,
                     magnetization=(_profile(self.magnetization, 0.0) if self.hard_magnetic else None))

    @property
    def hard_magnetic(self) -> bool:
        """Whether the scene has a remanent magnetisation (``h_r`` or ``magnetization`` given)."""
        return self.h_r is not None or self.magnetization is not None


def _profile(spec, default: float):
    return constant_profile(default) if spec is None else spec.to_profile()
