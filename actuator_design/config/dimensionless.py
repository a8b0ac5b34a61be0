"""The ``type: dimensionless`` scene: the groups of THEORY §5 given directly.

Keys: ``h``, ``phi`` (or ``field``), ``p`` (or ``tip_force``), ``tip_moment``, ``distributed_load``,
``h_pos``, ``fibres``, ``stiffness``, ``clamp_angle``, and for a hard-magnetic rod (THEORY §9)
``h_r`` with ``magnetization`` (the angle β(s) of the remanent magnetisation to the tangent, in
every form ``fibres`` takes; default 0 when ``h_r`` is given). Lengths (positions) are in units of the rod
length ℓ. Every group must lie in its range (:data:`~actuator_design.config.limits.GROUP_RANGES`).
A value with a physical unit (``h: "1 kA/m"``, ``p: "1 mN"``) is refused in one line naming the
field: physical units need a ``type: physical`` scene, whose rod and material convert them
(angles may carry ``deg``/``rad``).

The loads' keys and the magnetic groups beyond h are declared with their terms
(:class:`~actuator_design.physics.load_block.DimensionlessLoads`,
:class:`~actuator_design.physics.magnetics_block.DimensionlessMagnetics`); the scene sets every
group through the parameter lens, which adds each group's term.
"""
from __future__ import annotations

import re
from typing import List, Literal, Optional

from pydantic import Field, model_validator

from actuator_design.config.base import Angle, Q, StrictModel
from actuator_design.config.errors import error
from actuator_design.config.field_specs import DimensionlessField
from actuator_design.config.limits import group_problem
from actuator_design.config.obstacle_specs import MAX_OBSTACLES, DimensionlessObstacle, obstacles_of
from actuator_design.config.profile_specs import FibreProfile, StiffnessProfile, profile_or
from actuator_design.config.term_specs import TermEntries, check_terms, terms_field, terms_of
from actuator_design.model.scene import Scene, UniformField
from actuator_design.model.units import COMMON_UNITS, registry
from actuator_design.physics import parameters as lens
from actuator_design.physics.load_block import DimensionlessLoads
from actuator_design.physics.magnetics_block import DimensionlessMagnetics
from actuator_design.physics.registration import without_optional_terms

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


class _SceneKeys(StrictModel):
    """The keys of the rod, the field and the obstacles (the load and magnetic keys are their terms')."""

    type: Literal["dimensionless"]
    h: Optional[Q("dimensionless", ge=0)] = None
    phi: Optional[Angle] = None
    field: Optional[DimensionlessField] = None
    fibres: Optional[FibreProfile] = None
    stiffness: Optional[StiffnessProfile] = None
    clamp_angle: Angle = 0.0
    obstacles: Optional[List[DimensionlessObstacle]] = Field(default=None, max_length=MAX_OBSTACLES)
    contact_gap: Optional[Q("dimensionless", ge=0, le=1)] = None
    terms: TermEntries = terms_field()


class DimensionlessScene(DimensionlessLoads, DimensionlessMagnetics, _SceneKeys):
    """The groups of THEORY §5 given directly (see the module docstring)."""

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
        self.check_load_keys()
        problem = None if self.h is None else group_problem("h", self.h)
        if problem is not None:
            raise error(problem, "h")
        self.check_magnetic_groups()
        self.check_loads()
        check_terms(self.terms)
        return self

    def to_scene(self, name: Optional[str] = None) -> Scene:
        if self.field is not None:
            field = self.field.to_field()
        elif self.h is not None or self.phi is not None:
            field = UniformField(phi=self.phi or 0.0)
        else:
            field = None  # (a term that needs a field, e.g. a remanent one, adds it at strength 0)
        scene = Scene(field=field, h=self.h or 0.0, fibres=profile_or(self.fibres, 0.0),
                      stiffness=profile_or(self.stiffness, 1.0), theta0=self.clamp_angle, scales=None,
                      **without_optional_terms(),  # a term is added when given
                      name=name or "dimensionless cantilever", fibres_given=self.fibres is not None,
                      obstacles=obstacles_of(self.obstacles), contact_gap=float(self.contact_gap or 0.0),
                      extra_terms=terms_of(self.terms))
        for group, value in {**self.magnetic_groups(), **self.load_groups()}.items():
            scene = lens.set_value(scene, group, value)  # each group's term added by the lens
        for profile_name, profile in self.magnetic_profiles().items():
            scene = lens.parameter(profile_name).with_profile(scene, profile)
        return scene
