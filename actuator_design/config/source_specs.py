"""Configuration of real field sources: a permanent magnet, coils (physical scenes only).

    field:                                   field:
      type: magnet                             type: coils
      shape: cylinder        # or sphere       coils:
      diameter: 10 mm                            - kind: helmholtz   # loop, solenoid, maxwell
      height: 10 mm                                radius: 50 mm
      position: {x: 25 mm, y: -15 mm}              turns: 100
      axis_angle: 90 deg     # its north pole      current: 2 A
      remanence: 1.2 T                             position: {x: 10 mm, y: 0 mm}
                                                   axis_angle: 90 deg
    A cuboid (a block magnet, magnetised along one edge): ``shape: cuboid`` with ``height`` (along
    its axis and magnetisation), ``width`` (across it, in the rod's plane) and ``thickness`` (out of
    the plane) instead of a diameter. A disc or cylinder standing on the rod's plane and magnetised
    across a diameter: ``shape: diametric_cylinder``, ``diameter``, ``height`` (out of the plane);
    its ``axis_angle`` is the magnetisation's direction.

Several magnets: ``type: magnets`` with ``magnets: [...]``, each as above without ``type``.

Coils known by a calibration map (an electromagnetic navigation system, :mod:`actuator_design.model.coil_map`):

    field:
      type: coil_map
      file: emns_map.csv       # relative to this YAML file; columns x, y[, z], <coil>_bx, _by[, _bz]
      frame: {x: 0 mm, y: 0 mm, angle: 0 deg}   # the map's origin and x axis in the rod's frame
      coils:
        - {name: c1, current: 2 A, max_current: 10 A, resistance: 1.2 ohm}

Every source is centred in the rod's plane with its axis in that plane. magpylib computes the
field; :mod:`actuator_design.model.field_sources` fits it over the rod's reach and reports the fit error.
The field scale H0 is the largest |H| over the part of the reach outside the sources.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, List, Literal, Optional

import numpy as np
from pydantic import Field, PrivateAttr, StrictInt, model_validator

from actuator_design.config.base import Angle, LengthXY, Q, StrictModel
from actuator_design.config.errors import error
from actuator_design.model.coil_map import read_coil_map
from actuator_design.model.field_sources import FIT_TOLERANCE, CoilSource, MagnetSource, source_field
from actuator_design.model.sources import MappedCoil, plane_section, sections_overlap

__all__ = ["MagnetSpec", "PhysicalMagnet", "PhysicalMagnets", "MagnetTravel", "PhysicalCoils", "CoilSpec",
           "MappedCoilSpec", "PhysicalCoilMap", "MapFrame", "MAP_FIT_TOLERANCE"]

#: Default fit tolerance of a calibration map (relative to each coil's largest field): a measured
#: map's noise, not magpylib's rounding, sets what a fit can meet.
MAP_FIT_TOLERANCE = 1e-3

_MAX_TURNS = 2000


def _listed(names) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def _fitted(sources, length: float, tol: float, where: str):
    """The scene field and H0 of ``sources``; a failed fit or a clamp outside the fit's region
    is one config error naming ``where``."""
    try:
        field, h0 = source_field(tuple(sources), length, tol)
    except ValueError as exc:
        raise error(str(exc), where) from None
    for k, t in enumerate(field.terms):
        if not t.contains([0.0], [0.0])[0] and t.kind == "interior" and hasattr(t, "modes"):
            raise error(f"the clamp lies outside the calibration map's region (the disc of "
                        f"{t.valid_radius * length * 1e3:.4g} mm about ({t.centre[0] * length * 1e3:.4g}, "
                        f"{t.centre[1] * length * 1e3:.4g}) mm inscribed in the map's points)", where)
        if not t.contains([0.0], [0.0])[0] and t.kind == "interior":
            raise error(f"the clamp lies farther than {t.valid_radius * length * 1e3:.4g} mm from source {k + 1}'s "
                        "centre, beyond where its field inside the windings meets fit_tolerance", where)
        if not t.contains([0.0], [0.0])[0]:
            raise error(f"the clamp lies within {t.valid_radius * length * 1e3:.4g} mm of source {k + 1}'s "
                        "centre, where its field cannot be represented (its series about the centre holds only "
                        "outside the sphere that holds the whole source, and there only where it meets "
                        "fit_tolerance)", where)
    return field, h0


class MagnetTravel(StrictModel):
    """How far the magnet's stage can move it, for a design over its pose: each coordinate a range
    ``[low, high]`` that holds the configured value; a coordinate not given is held where it is.

        travel:
          x: [15 mm, 40 mm]
          y: [-30 mm, -10 mm]
          angle: [45 deg, 135 deg]
    """

    x: Optional[List[Q("length")]] = Field(default=None, min_length=2, max_length=2)
    y: Optional[List[Q("length")]] = Field(default=None, min_length=2, max_length=2)
    angle: Optional[List[Angle]] = Field(default=None, min_length=2, max_length=2)

    @model_validator(mode="after")
    def _check(self):
        for name in ("x", "y", "angle"):
            lo_hi = getattr(self, name)
            if lo_hi is not None and not lo_hi[0] < lo_hi[1]:
                shown = ", ".join(f"{math.degrees(v):.6g} deg" if name == "angle" else f"{v * 1e3:.6g} mm"
                                  for v in lo_hi)
                raise error(f"the range must be [low, high] with low < high, got [{shown}]", name)
        if self.angle is not None and self.angle[1] - self.angle[0] > 2 * math.pi + 1e-12:
            raise error("the range spans more than 360 deg", "angle")
        if self.x is None and self.y is None and self.angle is None:
            raise error("give at least one of x, y, angle (each a range [low, high])")
        return self


class MagnetSpec(StrictModel):
    """A permanent magnet magnetised along its axis: a cylinder (diameter, height), a sphere
    (diameter) or a cuboid (height along the axis, width across it in the plane, thickness out of
    it), centred in the rod's plane at ``position`` (m) with its axis (and north pole) at
    ``axis_angle`` to the rod axis; or a diametric cylinder (diameter, height out of the plane)
    magnetised at ``axis_angle``."""

    shape: Literal["cylinder", "sphere", "cuboid", "diametric_cylinder"] = "cylinder"
    diameter: Optional[Q("length", gt=0)] = None
    height: Optional[Q("length", gt=0)] = None
    width: Optional[Q("length", gt=0)] = None
    thickness: Optional[Q("length", gt=0)] = None
    position: LengthXY
    axis_angle: Angle = 0.0
    remanence: Q("magnetic_field", gt=0)
    travel: Optional[MagnetTravel] = None

    @model_validator(mode="after")
    def _check(self):
        t = self.travel
        if t is not None:
            for name, value, lo_hi in (("x", self.position.x, t.x), ("y", self.position.y, t.y),
                                       ("angle", self.axis_angle, t.angle)):
                shown = (f"{math.degrees(value):.6g} deg" if name == "angle" else f"{value * 1e3:.6g} mm")
                if name == "angle" and lo_hi is not None:  # angles are equal modulo a turn
                    value = lo_hi[0] + (value - lo_hi[0]) % (2 * math.pi)
                if lo_hi is not None and not lo_hi[0] <= value <= lo_hi[1] + 1e-12:
                    raise error(f"the configured {'axis_angle' if name == 'angle' else 'position ' + name} "
                                f"({shown}) lies outside its travel range", f"travel.{name}")
        needs = {"cylinder": ("diameter", "height"), "sphere": ("diameter",),
                 "cuboid": ("height", "width", "thickness"), "diametric_cylinder": ("diameter", "height")}[self.shape]
        for name in ("diameter", "height", "width", "thickness"):
            given = getattr(self, name) is not None
            if name in needs and not given:
                raise error(f"a {self.shape} magnet needs its {name} (e.g. '10 mm')", name)
            if name not in needs and given:
                hint = " (shape: cuboid?)" if name in ("width", "thickness") and self.shape == "cylinder" else ""
                raise error(f"a {self.shape} magnet has no {name}; give its {_listed(needs)}{hint}", name)
        return self

    def source(self) -> MagnetSource:
        t = self.travel
        travel = () if t is None else tuple(None if r is None else (float(r[0]), float(r[1]))
                                            for r in (t.x, t.y, t.angle))
        return MagnetSource(self.shape, float(self.diameter or 0.0), float(self.height or 0.0),
                            (float(self.position.x), float(self.position.y)), float(self.axis_angle),
                            float(self.remanence), travel, float(self.width or 0.0), float(self.thickness or 0.0))


class PhysicalMagnet(MagnetSpec):
    """One permanent magnet (:class:`MagnetSpec`) as the scene's field."""

    type: Literal["magnet"]
    fit_tolerance: Q("dimensionless", gt=1e-12, le=1e-3) = FIT_TOLERANCE

    def to_field(self, length: float, where: str = "field"):
        field, h0 = _fitted([self.source()], length, float(self.fit_tolerance), where)
        return replace(field, fit_tolerance=float(self.fit_tolerance)), h0


class PhysicalMagnets(StrictModel):
    """Several permanent magnets (each a :class:`MagnetSpec`), their fields added; their bodies may
    touch but not intersect, and at most one has a ``travel`` for a design over its pose."""

    type: Literal["magnets"]
    magnets: List[MagnetSpec] = Field(min_length=1, max_length=16)
    fit_tolerance: Q("dimensionless", gt=1e-12, le=1e-3) = FIT_TOLERANCE

    @model_validator(mode="after")
    def _check(self):
        sections = [plane_section(m.source()) for m in self.magnets]
        for j in range(len(sections)):
            for k in range(j):
                size = min(np.ptp(sections[j], axis=0).max(), np.ptp(sections[k], axis=0).max())
                if sections_overlap(sections[k], sections[j], 1e-6 * size):
                    raise error(f"magnets {k + 1} and {j + 1} overlap (their bodies intersect in the rod's plane); "
                                "move one (touching is fine)", f"magnets[{j}].position")
        moving = [k for k, m in enumerate(self.magnets) if m.travel is not None]
        if len(moving) > 1:
            raise error(f"magnets {moving[0] + 1} and {moving[1] + 1} both have a travel; a design moves one "
                        "magnet (give the others none)", f"magnets[{moving[1]}].travel")
        return self

    def to_field(self, length: float, where: str = "field"):
        field, h0 = _fitted([m.source() for m in self.magnets], length, float(self.fit_tolerance), where)
        return replace(field, fit_tolerance=float(self.fit_tolerance)), h0


class _CoilHardware(StrictModel):
    """A coil's current and its driver's limits (A, Ω)."""

    current: Q("current")
    max_current: Optional[Q("current", gt=0, le=1e5)] = None
    resistance: Optional[Q("resistance", gt=0, le=1e6)] = None

    @model_validator(mode="after")
    def _check_current(self):
        if self.max_current is not None and abs(self.current) > self.max_current:
            raise error(f"the current {self.current:g} A exceeds the coil's max_current {self.max_current:g} A",
                        "current")
        return self


class CoilSpec(_CoilHardware):
    """Circular windings: ``loop`` (``turns`` turns at one place), ``solenoid`` (``turns`` loops
    spread over ``length``), ``helmholtz`` / ``maxwell`` (two windings of ``turns`` turns,
    ``spacing`` apart — default the radius / √3 × the radius — with equal / opposite currents)."""

    kind: Literal["loop", "solenoid", "helmholtz", "maxwell"] = "loop"
    radius: Q("length", gt=0)
    turns: StrictInt = Field(default=1, ge=1, le=_MAX_TURNS)
    position: LengthXY
    axis_angle: Angle = 0.0
    length: Optional[Q("length", gt=0)] = None
    spacing: Optional[Q("length", gt=0)] = None

    @model_validator(mode="after")
    def _check(self):
        if self.kind == "solenoid" and self.length is None:
            raise error("a solenoid needs its length (e.g. '40 mm')", "length")
        if self.kind != "solenoid" and self.length is not None:
            raise error(f"only a solenoid has a length; a {self.kind} has none", "length")
        if self.kind in ("loop", "solenoid") and self.spacing is not None:
            raise error(f"only a helmholtz or maxwell pair has a spacing; a {self.kind} has none", "spacing")
        return self

    def source(self) -> CoilSource:
        spacing = self.spacing
        if spacing is None and self.kind in ("helmholtz", "maxwell"):
            spacing = self.radius * (1.0 if self.kind == "helmholtz" else math.sqrt(3.0))
        return CoilSource(self.kind, float(self.radius), (float(self.position.x), float(self.position.y)),
                          float(self.axis_angle), float(self.current), int(self.turns),
                          float(self.length or 0.0), float(spacing or 0.0),
                          math.inf if self.max_current is None else float(self.max_current),
                          math.nan if self.resistance is None else float(self.resistance))


class PhysicalCoils(StrictModel):
    """One or more coils (each :class:`CoilSpec`), their fields added; ``max_power`` (W, the total
    Σ R I² of coils with a ``resistance``) and ``max_field`` (|μ0 H| at the rod) limit a design
    over the currents."""

    type: Literal["coils"]
    coils: List[CoilSpec] = Field(min_length=1, max_length=16)
    fit_tolerance: Q("dimensionless", gt=1e-12, le=1e-3) = FIT_TOLERANCE
    max_power: Optional[Q("power", gt=0, le=1e9)] = None
    max_field: Optional[Q("magnetic_field", gt=0, le=1e9)] = None

    @model_validator(mode="after")
    def _check(self):
        _check_coil_set(self, [str(k + 1) for k in range(len(self.coils))])
        return self

    def to_field(self, length: float, where: str = "field"):
        return _with_limits(self, *_fitted([c.source() for c in self.coils], length, float(self.fit_tolerance), where))


def _check_coil_set(spec, labels) -> None:
    """Some current flows, and ``max_power`` has every coil's resistance (coils named by ``labels``)."""
    if all(c.current == 0.0 for c in spec.coils):
        raise error("every coil's current is zero: there is no field", "coils")
    if spec.max_power is not None and any(c.resistance is None for c in spec.coils):
        k = next(i for i, c in enumerate(spec.coils) if c.resistance is None)
        raise error(f"max_power needs every coil's resistance (coil {labels[k]} has none, e.g. "
                    "'resistance: 2 ohm')", "max_power")


def _with_limits(spec, field, h0):
    """(the scene field with the spec's fit tolerance and hardware limits (inf: none), H0)."""
    limits = {"fit_tolerance": float(spec.fit_tolerance),
              "max_power": math.inf if spec.max_power is None else float(spec.max_power),
              "max_field": math.inf if spec.max_field is None else float(spec.max_field)}
    return replace(field, **limits), h0


class MappedCoilSpec(_CoilHardware):
    """A coil of a calibration map: its ``name`` (the prefix of its columns, ``<name>_bx``), its
    current, and optionally its driver's ``max_current`` and its ``resistance``."""

    name: str = Field(pattern=r"^[A-Za-z][A-Za-z0-9]*$", max_length=32)


class MapFrame(StrictModel):
    """Where a map's own frame lies in the rod's: its origin at (x, y) (m) and its x axis at
    ``angle`` to the rod's axis (its z axis normal to the rod's plane, as the rod's)."""

    x: Q("length") = 0.0
    y: Q("length") = 0.0
    angle: Angle = 0.0


class PhysicalCoilMap(StrictModel):
    """Coils known by their field per ampere on a grid (a calibration map file,
    :mod:`actuator_design.model.coil_map`): the listed coils carry their currents, the others none;
    ``max_power`` and ``max_field`` as for ``type: coils``; ``frame``: where the map's own frame
    lies in the rod's (default: the same)."""

    type: Literal["coil_map"]
    file: str = Field(min_length=1, max_length=4096)
    coils: List[MappedCoilSpec] = Field(min_length=1, max_length=16)
    fit_tolerance: Q("dimensionless", gt=1e-12, le=0.1) = MAP_FIT_TOLERANCE
    max_power: Optional[Q("power", gt=0, le=1e9)] = None
    max_field: Optional[Q("magnetic_field", gt=0, le=1e9)] = None
    frame: Optional[MapFrame] = None
    _map: Any = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _check(self):
        try:
            cmap = read_coil_map(self.file)
        except ValueError as exc:
            raise error(str(exc), "file") from None
        self._map = cmap  # read once: the scene is built from what was validated
        names = [c.name for c in self.coils]
        for k, name in enumerate(names):
            if name not in cmap.fields:
                raise error(f"no coil '{name}' in {cmap.source} (its coils: {', '.join(cmap.names)})",
                            f"coils[{k}].name")
            if names.index(name) != k:
                raise error(f"coil '{name}' is listed twice", f"coils[{k}].name")
        _check_coil_set(self, [f"'{n}'" for n in names])
        return self

    def sources(self):
        """The listed coils as :class:`MappedCoil` in the rod's frame (the map's points and fields
        turned by ``frame.angle`` and moved to ``frame``'s origin)."""
        cmap, f = self._map, self.frame or MapFrame()
        turn = np.array([[math.cos(f.angle), -math.sin(f.angle)], [math.sin(f.angle), math.cos(f.angle)]])

        def in_rod_frame(v, origin=(0.0, 0.0)):
            v = np.array(v, float)
            v[:, :2] = v[:, :2] @ turn.T + origin
            return tuple(tuple(float(c) for c in row) for row in v)

        points = in_rod_frame(cmap.points, (f.x, f.y))
        return [MappedCoil(current=float(c.current), name=c.name, points=points,
                           field_per_amp=in_rod_frame(cmap.fields[c.name]),
                           max_current=math.inf if c.max_current is None else float(c.max_current),
                           resistance=math.nan if c.resistance is None else float(c.resistance))
                for c in self.coils]

    def to_field(self, length: float, where: str = "field"):
        return _with_limits(self, *_fitted(self.sources(), length, float(self.fit_tolerance), where))
