"""The ``type: dimensionless`` scene: the groups of THEORY §5 given directly.

Keys: ``h``, ``phi`` (or ``field``), ``p`` (or ``tip_force``), ``tip_moment``, ``distributed_load``,
``h_pos``, ``fibres``, ``stiffness``, ``clamp_angle``, and for a hard-magnetic rod (THEORY §9)
``h_r`` with ``magnetization`` (the angle β(s) of the remanent magnetisation to the tangent, in
every form ``fibres`` takes; default 0 when ``h_r`` is given). Lengths (positions) are in units of the rod
length ℓ. Every group must lie in its range (:data:`~actuator_design.config.limits.GROUP_RANGES`).
A value with a physical unit (``h: "1 kA/m"``, ``p: "1 mN"``) is refused in one line naming the
field: physical units need a ``type: physical`` scene, whose rod and material convert them
(angles may carry ``deg``/``rad``).
"""
from __future__ import annotations

import re
from typing import List, Literal, Optional

from pydantic import Field, model_validator

from actuator_design.config.base import Angle, Number, Q, StrictModel
from actuator_design.config.errors import error
from actuator_design.config.field_specs import DimensionlessField, NumberXY
from actuator_design.config.limits import group_problem
from actuator_design.config.obstacle_specs import MAX_OBSTACLES, DimensionlessObstacle, obstacles_of
from actuator_design.config.profile_specs import FibreProfile, MagnetizationProfile, StiffnessProfile
from actuator_design.config.term_specs import TermEntries, check_terms, terms_field, terms_of
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scene, UniformField
from actuator_design.model.units import COMMON_UNITS, registry

__all__ = ["DimensionlessScene"]


_NUMBER_UNIT = re.compile(r"^\s*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*(°|[^\s\d.+-].*?)\s*$")
#: Keys whose string values are not quantities.
_NOT_QUANTITIES = ("type", "expression")


def physical_unit_of(text) -> Optional[str]:
    """The unit of ``"<number> <unit>"`` when it is a physical one (not an angle, not a pure
    number), else None (no unit, an angle, or an unreadable unit the field's own check reports).
    """
    if not isinstance(text, str):
        return None
    m = _NUMBER_UNIT.match(text)
    if not m:
        return None
    unit = m.group(1)
    known = COMMON_UNITS.get("deg" if unit == "°" else unit)
    if known is not None:
        return None if known[0] == "angle" else unit
    try:
        q = registry().Quantity(1.0, unit)
        base = q.to_base_units().units
    except Exception:  # noqa: BLE001 - pint: unknown unit; the field's own check names it
        return None
    return None if (q.unitless or base == registry().radian) else unit


def _physical_unit_problem(data, path=()):
    """``(dotted path, text, unit)`` of the first value with a physical unit in ``data``, or None."""
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        if key in _NOT_QUANTITIES:
            continue
        if isinstance(value, (dict, list)):
            found = _physical_unit_problem(value, path + (key,))
            if found is not None:
                return found
        else:
            unit = physical_unit_of(value)
            if unit is not None:
                return path + (key,), value, unit
    return None


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
    obstacles: Optional[List[DimensionlessObstacle]] = Field(default=None, max_length=MAX_OBSTACLES)
    contact_gap: Optional[Q("dimensionless", ge=0, le=1)] = None
    terms: TermEntries = terms_field()

    @model_validator(mode="before")
    @classmethod
    def _no_physical_units(cls, data):
        found = _physical_unit_problem(data) if isinstance(data, dict) else None
        if found is not None:
            path, text, unit = found
            field = "".join(f"[{p}]" if isinstance(p, int) else (f".{p}" if i else str(p))
                            for i, p in enumerate(path))
            raise error(f"{text!r} has a physical unit ({unit}), but the scene is dimensionless: "
                        f"physical units need a physical scene (type: physical, with the rod and "
                        f"its material); here give {field} as a plain number (dimensionless, "
                        f"THEORY §5)", field)
        return data

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
                ("m_tip", self.tip_moment, "tip_moment"),
                ("qx", load and load.x, "distributed_load.x"),
                ("qy", load and load.y, "distributed_load.y")):
            problem = None if value is None else group_problem(group, value)
            if problem is not None:
                raise error(problem, field)
        check_terms(self.terms)
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
                     magnetization=(_profile(self.magnetization, 0.0) if self.hard_magnetic else None),
                     obstacles=obstacles_of(self.obstacles), contact_gap=float(self.contact_gap or 0.0),
                     extra_terms=terms_of(self.terms))

    @property
    def hard_magnetic(self) -> bool:
        """Whether the scene has a remanent magnetisation (``h_r`` or ``magnetization`` given)."""
        return self.h_r is not None or self.magnetization is not None


def _profile(spec, default: float):
    return constant_profile(default) if spec is None else spec.to_profile()
