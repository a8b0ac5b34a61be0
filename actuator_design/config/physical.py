"""The ``type: physical`` scene: SI quantities non-dimensionalised with ℓ, B0 and H0 (THEORY §5).

* h² = μ0 χ̄ H0² A ℓ² / (2 B0),  h_pos² = μ0 χ̂ H0² A ℓ² / (2 B0), with χ̄, χ̂ from the
  ``magnetics`` block (:mod:`actuator_design.physics.magnetics_block`: particles, the body's shape anisotropy, THEORY §10);
* hard-magnetic rods: h_r = μ0 M_r H0 A ℓ² / B0 (THEORY §9), the angle profile ``magnetization``;
* tip force F ℓ²/B0, tip moment M ℓ/B0, distributed load q ℓ³/B0 (weight: q = ρ g A along gravity);
* uniform field: H0 = magnitude; dipole of moment m: H0 = m/(4π ℓ³), positions /ℓ; expression
  field: H0 = ``scale``.

The derived quantities (A, B0, H0) and groups are computed in float64 without exceptions (an
overflow gives inf) and then checked: A and B0 positive and finite, every group within its range
(:mod:`actuator_design.config.limits`). A failure names the derived group and the fields it comes
from, with their values, so ``length: 1e308 m`` is one clear line.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from typing import Dict, List, Literal, Optional

import numpy as np
from pydantic import Field, model_validator

from actuator_design.config.base import Angle, Q, StrictModel
from actuator_design.config.errors import error
from actuator_design.config.field_specs import PhysicalDipole, PhysicalField, max_shape_on_rod
from actuator_design.config.limits import GROUP_RANGES, group_problem
from actuator_design.config.obstacle_specs import MAX_OBSTACLES, PhysicalObstacle, obstacles_of
from actuator_design.config.profile_specs import FibreProfile, StiffnessProfile, profile_or
from actuator_design.config.term_specs import TermEntries, check_terms, terms_field, terms_of
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scales, Scene
from actuator_design.physics import parameters as lens
from actuator_design.physics.load_block import Loads, Weight
from actuator_design.physics.magnetics_block import (Magnetics, MagneticSummary, Particles,
                                                     PhysicalMagnetization, magnetic_group, remanent_group)
from actuator_design.physics.registration import without_optional_terms

__all__ = ["Rod", "Particles", "Magnetics", "Weight", "Loads", "Clamp", "PhysicalScene",
           "magnetic_group", "remanent_group"]

class Rod(StrictModel):
    """Rod geometry and stiffness: A = w t, I = w t³/12, B0 = E I (or ``bending_stiffness``)."""

    length: Q("length", gt=0)
    width: Optional[Q("length", gt=0)] = None
    thickness: Optional[Q("length", gt=0)] = None
    youngs_modulus: Optional[Q("pressure", gt=0)] = None
    bending_stiffness: Optional[Q("bending_stiffness", gt=0)] = None
    area: Optional[Q("area", gt=0)] = None
    stiffness_profile: Optional[StiffnessProfile] = None
    #: mass density (kg/m³) and modal damping ratio ζ of the material: the rod's relaxation time, to
    #: check that a timed schedule is quasi-static (:mod:`actuator_design.schedules.dynamics`)
    density: Optional[Q("density", gt=0)] = None
    damping_ratio: Optional[Q("dimensionless", gt=0, le=10)] = None

    @model_validator(mode="after")
    def _check(self):
        has_wt = self.width is not None and self.thickness is not None
        if (self.width is None) != (self.thickness is None):
            missing = "width" if self.width is None else "thickness"
            raise error("required together with " + ("thickness" if missing == "width" else "width"),
                        missing)
        if self.youngs_modulus is None and self.bending_stiffness is None:
            raise error("required (or give bending_stiffness)", "youngs_modulus")
        if self.youngs_modulus is not None and self.bending_stiffness is not None:
            raise error("give either youngs_modulus or bending_stiffness, not both", "bending_stiffness")
        if self.youngs_modulus is not None and not has_wt:
            raise error("required with youngs_modulus (I = w t³/12)", "width")
        if self.area is not None and (has_wt or self.youngs_modulus is not None):
            raise error("give either area (with bending_stiffness) or width and thickness", "area")
        if self.area is None and not has_wt:
            raise error("required with bending_stiffness when width and thickness are not given", "area")
        if self.stiffness_profile is not None:
            b0 = float(self.stiffness_profile.to_profile()(0.0))
            if abs(b0 - 1.0) > 1e-12:
                raise error(f"must equal 1 at s = 0 (B0 is the clamp stiffness), got {b0:g}",
                            "stiffness_profile")
        for name, value in (("cross_section_area", self.cross_section_area),
                            ("clamp_stiffness", self.clamp_stiffness)):
            if not (math.isfinite(value) and value > 0):
                field = self._source_of(name)
                what = "A = w t" if name == "cross_section_area" else "B0 = E w t³/12"
                raise error(f"gives {what} = {value:g}, which must be positive and finite (over- or "
                            f"underflow: check the value and its unit)", field)
        # the scales of THEORY §5 (energy B0/ℓ, force B0/ℓ², line load B0/ℓ³) must be representable
        with np.errstate(all="ignore"):  # float64 over- and underflow give inf and 0, not errors
            scales = [float(np.float64(self.clamp_stiffness) / np.float64(self.length) ** k)
                      for k in (1, 2, 3)]
        # (a huge length is named by the derived groups it blows up; a tiny one divides by 0 first)
        if float(self.length) < 1.0 and not all(math.isfinite(v) and v > 0 for v in scales):
            raise error(f"gives the unit force B0/l^2 = {scales[1]:g} N (and B0/l, B0/l^3), which must "
                        "be positive and finite (over- or underflow: check the value and its unit)",
                        "length")
        return self

    def _source_of(self, derived: str) -> str:
        if derived == "cross_section_area":
            return "area" if self.area is not None else "width"
        return "bending_stiffness" if self.bending_stiffness is not None else "youngs_modulus"

    @property
    def cross_section_area(self) -> float:
        """A, m²."""
        if self.area is not None:
            return self.area
        with np.errstate(all="ignore"):
            return float(np.float64(self.width) * self.thickness)

    @property
    def clamp_stiffness(self) -> float:
        """B0, N m²."""
        if self.bending_stiffness is not None:
            return self.bending_stiffness
        with np.errstate(all="ignore"):
            return float(np.float64(self.youngs_modulus) * self.width * np.float64(self.thickness) ** 3
                         / 12.0)

    def sources(self) -> List[str]:
        """The given rod fields with their values, for messages about derived groups."""
        names = ["length", "width", "thickness", "youngs_modulus", "bending_stiffness", "area"]
        units = {"length": "m", "width": "m", "thickness": "m", "youngs_modulus": "Pa",
                 "bending_stiffness": "N m^2", "area": "m^2"}
        return [f"rod.{n} = {getattr(self, n):g} {units[n]}" for n in names
                if getattr(self, n) is not None]


class Clamp(StrictModel):
    """Clamp angle θ(0), rad."""

    angle: Angle = 0.0


@dataclass
class _Derived:
    """The dimensionless groups of a physical scene and the fields each comes from."""

    values: Dict[str, float]
    sources: Dict[str, List[str]]
    h0: float
    magnetics: Optional[MagneticSummary] = None
    #: every field-driven group at a unit field (dg/dH0 per A/m), by lens name
    per_field: Dict[str, float] = dataclass_field(default_factory=dict)


class _SceneKeys(StrictModel):
    """The keys of the rod, its material, the field, the loads, the clamp and the obstacles (the
    remanent magnetisation's angle is its term's: :class:`PhysicalMagnetization`)."""

    type: Literal["physical"]
    rod: Rod
    magnetics: Optional[Magnetics] = None
    field: Optional[PhysicalField] = None
    loads: Optional[Loads] = None
    fibres: Optional[FibreProfile] = None


class _MoreKeys(StrictModel):
    clamp: Optional[Clamp] = None
    obstacles: Optional[List[PhysicalObstacle]] = Field(default=None, max_length=MAX_OBSTACLES)
    terms: TermEntries = terms_field()


class PhysicalScene(_MoreKeys, PhysicalMagnetization, _SceneKeys):
    """SI description, non-dimensionalised by ℓ, B0 and H0 (THEORY §5)."""

    @model_validator(mode="after")
    def _check(self):
        if self.field is not None and self.magnetics is None:
            raise error("required when a field is given", "magnetics")
        self.check_with_magnetics(self.magnetics)  # the term parts mixed in check themselves
        if self.obstacles and self.rod.thickness is None:  # the gap to an obstacle is half of it
            raise error("required with obstacles (the rod's surface touches them, its centre line half "
                        "the thickness away); give rod.width and rod.thickness", "rod.thickness")
        if isinstance(self.field, PhysicalDipole):  # the position check needs ℓ
            self.field.to_field(self.rod.length, where="field.position")
        derived = self._derived()
        for name, value in derived.values.items():
            problem = group_problem(name, value)
            if problem is not None:
                rng = GROUP_RANGES[name]
                raise error(f"derived {name} = {value:g} must be a finite number in {rng.text()}; it "
                            f"comes from {', '.join(derived.sources[name])} (THEORY §5)", name)
        check_terms(self.terms, self.rod.length, self.rod.clamp_stiffness)
        return self

    def _derived(self) -> _Derived:
        rod = self.rod
        length, area, b0 = rod.length, rod.cross_section_area, rod.clamp_stiffness
        values, sources = {}, {}
        h0 = 0.0
        summary, per_field = None, {}
        if self.field is not None:
            _, h0 = self.field.to_field(length)
            summary = self.magnetics_summary()
            field_src = [f"field.{k} = {getattr(self.field, k):g} {unit}" for k, unit in
                         (("magnitude", "A/m"), ("moment", "A m^2"), ("scale", "A/m"))
                         if hasattr(self.field, k)]
            values.update(summary.field_groups(h0, area, length, b0))
            per_field = summary.field_groups(1.0, area, length, b0)
            for name, given in summary.group_sources(field_src).items():
                sources[name] = rod.sources() + given
        load_values, load_given = (self.loads or Loads()).groups(length, area, b0)
        values.update(load_values)
        for name, given in load_given.items():
            sources[name] = rod.sources() + given
        return _Derived(values, sources, float(h0), summary, {k: float(v) for k, v in per_field.items()})

    def magnetics_summary(self) -> Optional[MagneticSummary]:
        """The magnetic numbers and their reasons (:meth:`actuator_design.physics.magnetics_block.Magnetics.resolve`)."""
        if self.magnetics is None:
            return None
        fib = self.fibres.to_profile() if self.fibres is not None else constant_profile(0.0)
        return self.magnetics.resolve(self.rod.width, self.rod.thickness,
                                      float(fib.value) if fib.is_constant else None)

    def to_scene(self, name: Optional[str] = None) -> Scene:
        length, b0 = self.rod.length, self.rod.clamp_stiffness
        d = self._derived()
        v = d.values
        field = None if self.field is None else self.field.to_field(length)[0]
        self._check_assumptions(field, d.h0, d.magnetics)
        fibres = profile_or(self.fibres, 0.0)
        if d.magnetics is not None and d.magnetics.fibre_angle is not None:
            fibres = constant_profile(d.magnetics.fibre_angle)  # THEORY §10: the effective angle
        per = d.per_field  # (every group the field drives, remanent ones only of a remanent rod)
        scene = Scene(
            field=field, fibres=fibres, stiffness=profile_or(self.rod.stiffness_profile, 1.0),
            **without_optional_terms(),  # a term is added when given
            theta0=self.clamp.angle if self.clamp else 0.0,
            scales=Scales(length=length, bending_stiffness=b0, field=d.h0, h_per_field=per.get("h", 0.0),
                          mass_per_length=(float(self.rod.density) * self.rod.cross_section_area
                                           if self.rod.density is not None else 0.0),
                          damping_ratio=float(self.rod.damping_ratio or 0.0),
                          per_field=tuple(per.items()),
                          field_limit=self._field_limit(field, d.magnetics)),
            name=name or "physical cantilever", fibres_given=self.fibres is not None,
            fibres_physical=not self._isotropic_particles(),
            obstacles=obstacles_of(self.obstacles, length),
            contact_gap=0.5 * float(self.rod.thickness) / length if self.rod.thickness is not None else 0.0,
            extra_terms=terms_of(self.terms, length, b0))
        for group, value in v.items():  # the field's and the loads' groups, each term added by the lens
            scene = lens.set_value(scene, group, value)
        if field is not None:  # (without a field the remanence has nothing to act on)
            for profile_name, profile in self.magnetic_profiles().items():
                scene = lens.parameter(profile_name).with_profile(scene, profile)
        return scene

    def _isotropic_particles(self) -> bool:
        """Spherical (or otherwise isotropic) particles: χ̄ = 0 of the particles alone (THEORY §2),
        so the only anisotropy is the body's and a fibre layout has no effect (THEORY §10)."""
        m = self.magnetics
        return bool(m is not None and m.particles is not None and m.susceptibilities()[0] == 0.0)

    def _field_limit(self, field, summary: Optional[MagneticSummary]) -> float:
        """The largest field |H| on the rod (A/m) the model accepts (inf: no limit known)."""
        return math.inf if field is None or self.magnetics is None else self.magnetics.field_limit(summary)

    def _check_assumptions(self, field, h0: float, summary: Optional[MagneticSummary]) -> None:
        """Warn (ModelAssumptionWarning) when the largest field on the rod leaves the model (THEORY §11)."""
        if self.magnetics is not None:
            self.magnetics.check_assumptions(None if field is None else h0 * max_shape_on_rod(field), summary)
