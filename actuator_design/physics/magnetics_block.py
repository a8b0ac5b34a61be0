"""The ``magnetics:`` block of a physical scene: soft particles, the body's own shape anisotropy,
saturation and the remanent magnetisation of hard-magnetic rods (THEORY §2, §9–§11).

It is the material of the magnetic terms (the χ̄, χ̂ and remanent terms), so it lives with them:
:meth:`MagneticSummary.field_groups` turns the material and an applied field into their groups, and
the summary reports itself (``validate``); a physical scene asks it rather than naming the groups.

* ``chi_bar``/``chi_hat``: the composite's effective susceptibilities given directly, or
* ``particles``: spheroids (``axis_ratio``, ``chi_par``, ``chi_perp``, ``volume_fraction``), or a
  filler preset ``material: carbonyl_iron | magnetite | ndfeb`` (:mod:`actuator_design.physics.magnetic_composite`)
  that supplies the susceptibility and the saturation magnetisation;
* ``body_demagnetization`` (default true): with particles and a rectangular cross-section the body's
  demagnetisation is combined with the composite tensor (THEORY §10), N_t = w/(w + t) or
  ``demagnetizing_factor``;
* ``remanence: 50 kA/m`` (M_r of the composite) or ``remanent_flux_density: 0.1 T`` (= μ0 M_r):
  a hard-magnetic rod (THEORY §9); its angle profile is the scene's ``magnetization``.

Magnetisations (M_r, M_s, the saturation field) and susceptibilities must be physically plausible
(:data:`MAX_MAGNETIZATION`, :data:`MAX_SUSCEPTIBILITY`): ``remanence: 1e12 A/m`` is one line
naming the field and its range, not a solver failure.

:meth:`Magnetics.resolve` turns the block into the numbers the groups are made of, with the reasons
(a zero coupling is explained, not silently accepted).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Annotated, Dict, List, Optional

import numpy as np
from pydantic import BeforeValidator, StrictBool, StrictStr, field_validator, model_validator

from actuator_design.config.base import Q, StrictModel, tagged
from actuator_design.config.errors import error
from actuator_design.config.profile_specs import FibreConstant, FibreExpression, FibreTable, constant_spec
from actuator_design.model.units import MU0, QuantityError, parse_quantity, registry
from actuator_design.physics import parameters as lens
from actuator_design.physics.magnetic_composite import (body_susceptibility, check_assumptions,
                                                        check_saturation, composite_tensor,
                                                        effective_susceptibilities, material,
                                                        transverse_demagnetizing_factor)

__all__ = ["Particles", "Magnetics", "MagneticSummary", "FluxDensity", "magnetic_group", "remanent_group",
           "MagnetizationProfile", "DimensionlessMagnetics", "PhysicalMagnetization",
           "MAX_MAGNETIZATION", "MAX_SUSCEPTIBILITY"]


#: Largest magnetisation (remanence, saturation magnetisation, saturation field) a scene may give,
#: A/m: about 1.5 × the saturation of Fe65Co35 (μ0 M_s ≈ 2.45 T, M_s ≈ 1.95 MA/m), the most
#: strongly magnetised material known; NdFeB, the strongest permanent magnet, has M_r ≈ 1.1 MA/m
#: (B_r ≈ 1.4 T); handbook values, e.g. Coey, *Magnetism and Magnetic Materials* (2010).
MAX_MAGNETIZATION = 3.0e6
MAGNETIZATION_WHY = ("physically plausible: the strongest permanent magnets reach about 1.1e6 A/m "
                     "(1.4 T), no material is magnetised beyond about 2e6 A/m (2.5 T)")
#: Largest susceptibility a scene may give (χ̄, χ̂, the particles' χ∥, χ⊥): the largest relative
#: permeability of any material, μr ≈ 1e6 (supermalloy, a handbook value), χ = μr − 1.
MAX_SUSCEPTIBILITY = 1.0e6
SUSCEPTIBILITY_WHY = "physically plausible: no material exceeds about 1e6 (supermalloy)"


def _flux_density(value):
    """A flux density in tesla (plain numbers are T) → the magnetisation B/μ0 in A/m."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        b = float(value)
    else:
        try:  # parse_quantity first: it refuses hostile strings before pint sees them
            m_r = parse_quantity(value, "magnetic_field", "remanent_flux_density")
        except QuantityError as err:
            raise error(err.detail) from None
        ureg = registry()
        if ureg(str(value)).dimensionality != ureg.tesla.dimensionality:
            raise error(f"expected a flux density in tesla (e.g. '0.1 T'), got {value!r}; "
                        "give a magnetisation in A/m as remanence")
        _check_flux_density(m_r, value)
        return m_r
    if not math.isfinite(b):
        raise error(f"must be a finite flux density >= 0 T, got {value!r}")
    _check_flux_density(b / MU0, value)
    return b / MU0


def _check_flux_density(m_r: float, value) -> None:
    """μ0 M_r in [0, μ0 MAX_MAGNETIZATION] T, named in tesla as written."""
    if not 0.0 <= m_r <= MAX_MAGNETIZATION:
        raise error(f"must be in [0, {MU0 * MAX_MAGNETIZATION:.3g}] T (μ0 × {MAX_MAGNETIZATION:g} "
                    f"A/m; {MAGNETIZATION_WHY}), got {value!r}")


#: A flux density (T; a plain number is in T), read as the magnetisation B/μ0 in A/m.
FluxDensity = Annotated[float, BeforeValidator(_flux_density)]


#: Physically plausible magnetic material values: a unit slip is refused in one line.
_SUSCEPTIBILITY = Q("dimensionless", ge=0, le=MAX_SUSCEPTIBILITY, why=SUSCEPTIBILITY_WHY)
_SUSCEPTIBILITY_POSITIVE = Q("dimensionless", gt=0, le=MAX_SUSCEPTIBILITY, why=SUSCEPTIBILITY_WHY)
_MAGNETIZATION = Q("magnetic_field", ge=0, le=MAX_MAGNETIZATION, why=MAGNETIZATION_WHY)
_MAGNETIZATION_POSITIVE = Q("magnetic_field", gt=0, le=MAX_MAGNETIZATION, why=MAGNETIZATION_WHY)


class Particles(StrictModel):
    """Spheroidal particles (THEORY §2); fields in A/m (or T). ``material`` fills in the
    susceptibility and the saturation magnetisation of a preset filler."""

    material: Optional[StrictStr] = None
    axis_ratio: Q("dimensionless", ge=1) = 1.0
    chi_par: Optional[_SUSCEPTIBILITY_POSITIVE] = None
    chi_perp: Optional[_SUSCEPTIBILITY_POSITIVE] = None
    volume_fraction: Q("dimensionless", gt=0, lt=1)
    saturation_field: Optional[_MAGNETIZATION_POSITIVE] = None
    saturation_magnetization: Optional[_MAGNETIZATION_POSITIVE] = None

    @field_validator("material")
    @classmethod
    def _known(cls, name):
        try:
            material(name)
        except ValueError as err:
            raise error(str(err)) from None
        return name

    @model_validator(mode="after")
    def _fill(self):
        if self.material is None:
            for name in ("chi_par", "chi_perp"):
                if getattr(self, name) is None:
                    raise error("required (or give a material preset)", name)
        return self

    @property
    def preset(self):
        return None if self.material is None else material(self.material)

    @property
    def susceptibilities(self):
        """(χ∥, χ⊥) of the particle material."""
        chi = None if self.preset is None else self.preset.susceptibility
        return (self.chi_par if self.chi_par is not None else chi,
                self.chi_perp if self.chi_perp is not None else chi)

    @property
    def m_s(self) -> Optional[float]:
        """Saturation magnetisation of the filler, A/m (given, or from the preset), or None."""
        if self.saturation_magnetization is not None:
            return self.saturation_magnetization
        return None if self.preset is None else self.preset.saturation_magnetization


@dataclass
class MagneticSummary:
    """The magnetic numbers of a physical scene and where they come from.

    Attributes
    ----------
    chi_bar, chi_hat : float
        Susceptibilities used for h and h_pos (dimensionless).
    particle_chi_bar, particle_chi_hat : float or None
        The particle-only values (THEORY §2) when particles are given.
    fibre_angle : float or None
        Effective fibre angle (rad) replacing a constant fibre angle, or None (fibres unchanged).
    demagnetizing_factor : float or None
        N_t used for the body's demagnetisation, or None when it was not applied.
    chi_max : float
        Largest eigenvalue of the susceptibility used: |M| ≤ chi_max |H|.
    saturation : float or None
        ν M_s of the composite, A/m, when the filler is known.
    remanence : float or None
        M_r of the composite, A/m (hard-magnetic rods).
    notes : list of str
        Why the body's demagnetisation was (not) applied, and why a coupling is zero.
    """

    chi_bar: float
    chi_hat: float
    particle_chi_bar: Optional[float] = None
    particle_chi_hat: Optional[float] = None
    fibre_angle: Optional[float] = None
    demagnetizing_factor: Optional[float] = None
    chi_max: float = 0.0
    saturation: Optional[float] = None
    remanence: Optional[float] = None
    notes: List[str] = field(default_factory=list)
    #: where χ̄ and χ̂ come from, for messages about the groups (``"magnetics.particles"``)
    given: str = ""

    def field_groups(self, field: float, area: float, length: float, stiffness: float) -> Dict[str, float]:
        """Every dimensionless group the applied field drives in this material, at the field
        ``field`` (A/m; each group ∝ it), by lens name: h and h_pos (THEORY §5), h_r of a
        remanent magnetisation (THEORY §9). SI inputs: area m², length m, stiffness B0 in N m²."""
        out = {"h": magnetic_group(self.chi_bar, field, area, length, stiffness),
               "h_pos": magnetic_group(self.chi_hat, field, area, length, stiffness)}
        if self.remanence is not None:
            out["h_r"] = remanent_group(self.remanence, field, area, length, stiffness)
        return out

    @classmethod
    def nonmagnetic(cls) -> "MagneticSummary":
        """A rod without magnetics (no ``magnetics:`` block): zero susceptibilities, no remanence."""
        return cls(chi_bar=0.0, chi_hat=0.0, given="no magnetics")

    #: how each group of :meth:`field_groups` follows from the material, per unit field (for reports)
    FORMULAS = {"h": "h = c·H, c = sqrt(mu0 chi_bar A l^2 / (2 B))",
                "h_pos": "h_pos = c·H, c = sqrt(mu0 chi_hat A l^2 / (2 B))",
                "h_r": "h_r = c_r·H, c_r = mu0 M_r A l^2 / B (THEORY §9)"}
    #: each group's power laws in the material, the field and B (THEORY §5, §9), as messages show them
    POWER_LAWS = {"h": "h² ∝ χ̄ H²/B", "h_pos": "h_pos² ∝ χ̂ H²/B", "h_r": "h_r ∝ M_r H/B"}

    def coefficients(self, values: Dict[str, object], area: float, length: float, stiffness: float,
                     stiffness_ratio=1.0) -> Dict[str, object]:
        """Each group the field drives per unit field (g = c_g H^f), by lens name, with the material
        numbers ``values`` (by physical parameter name: χ̄, M_r; numbers or CasADi symbols) in place
        of this material's and the bending stiffness B0 · ``stiffness_ratio`` (B0 in N m²): the
        coefficients at unit values of those numbers (:meth:`field_groups`), times their power laws
        (``PhysicalParameter.groups``) and (B/B0)^e (:func:`~actuator_design.physics.parameters.stiffness_groups`)."""
        per_unit = replace(self, **{n: 1.0 for n in values}).field_groups(1.0, area, length, stiffness)
        powers, out = dict(lens.stiffness_groups()), {}
        for p, _ in lens.field_groups():
            if p.name in per_unit:  # (the material has that group)
                coef = per_unit[p.name]
                for n, x in values.items():
                    e = lens.physical_parameter(n).exponent(p.slot)
                    coef = coef * (x if e == 1 else x ** e) if e else coef
                e_B = powers.get(p.slot, 0.0)
                out[p.name] = coef * stiffness_ratio ** e_B if e_B else coef
        return out

    def group_sources(self, field: List[str]) -> Dict[str, List[str]]:
        """The inputs each group of :meth:`field_groups` comes from besides the rod (for messages):
        the material's and ``field``, the applied field's inputs as given."""
        out = {"h": [self.given] + field, "h_pos": [self.given] + field}
        if self.remanence is not None:
            out["h_r"] = field + [f"magnetics remanence M_r = {self.remanence:g} A/m"]
        return out

    def as_dict(self) -> Dict[str, Optional[float]]:
        """The numbers as ``validate --json`` reports them (magnetisations in A/m)."""
        return {"chi_bar": self.chi_bar, "chi_hat": self.chi_hat, "particle_chi_bar": self.particle_chi_bar,
                "particle_chi_hat": self.particle_chi_hat, "effective_fibre_angle": self.fibre_angle,
                "demagnetizing_factor": self.demagnetizing_factor, "chi_max": self.chi_max,
                "saturation_A_per_m": self.saturation, "remanence_A_per_m": self.remanence}

    def line(self) -> str:
        """The numbers as one line of a scene's summary (``validate``)."""
        out = f"magnetics   : chi_bar = {self.chi_bar:.6g}, chi_hat = {self.chi_hat:.6g}"
        if self.particle_chi_bar is not None:
            out += (f" (particles only: chi_bar = {self.particle_chi_bar:.6g}, "
                    f"chi_hat = {self.particle_chi_hat:.6g})")
        if self.demagnetizing_factor is not None:
            out += f", body N_t = {self.demagnetizing_factor:.6g}"
        if self.fibre_angle is not None:
            out += f", effective fibre angle = {math.degrees(self.fibre_angle):.6g} deg"
        if self.saturation is not None:
            out += f", saturation nu M_s = {self.saturation:.6g} A/m"
        if self.remanence is not None:
            out += f", remanence M_r = {self.remanence:.6g} A/m"
        return out


def magnetic_group(chi: float, field: float, area: float, length: float, stiffness: float) -> float:
    """√(μ0 χ H0² A ℓ² / (2 B0)) (THEORY §5): h for χ = χ̄, h_pos for χ = χ̂. SI inputs.

    Computed in float64 (the same operations as in plain floats), so an overflow gives inf, not an
    exception.
    """
    with np.errstate(all="ignore"):
        return float(np.sqrt(np.float64(MU0) * chi * np.float64(field) ** 2 * area
                             * np.float64(length) ** 2 / (2.0 * stiffness)))


def remanent_group(remanence: float, field: float, area: float, length: float, stiffness: float) -> float:
    """h_r = μ0 M_r H0 A ℓ² / B0 (THEORY §9), SI inputs; float64 (an overflow gives inf)."""
    with np.errstate(all="ignore"):
        return float(np.float64(MU0) * remanence * np.float64(field) * area * np.float64(length) ** 2
                     / stiffness)


class Magnetics(StrictModel):
    """Soft (χ̄, χ̂ or particles) and hard (remanence) magnetics of a physical scene."""

    chi_bar: Optional[_SUSCEPTIBILITY] = None
    chi_hat: Optional[_SUSCEPTIBILITY] = None
    particles: Optional[Particles] = None
    body_demagnetization: StrictBool = True
    demagnetizing_factor: Optional[Q("dimensionless", ge=0, le=1)] = None
    remanence: Optional[_MAGNETIZATION] = None
    remanent_flux_density: Optional[FluxDensity] = None

    @model_validator(mode="after")
    def _check(self):
        if self.particles is not None and (self.chi_bar is not None or self.chi_hat is not None):
            raise error("give either chi_bar/chi_hat or particles, not both", "particles")
        if self.remanence is not None and self.remanent_flux_density is not None:
            raise error("give either remanence or remanent_flux_density, not both", "remanent_flux_density")
        if self.particles is None and self.chi_bar is None and self.remanent_magnetization is None:
            raise error("required (or give particles, or remanence for a hard-magnetic rod)", "chi_bar")
        return self

    @property
    def remanent_magnetization(self) -> Optional[float]:
        """M_r of the composite, A/m, or None (no hard-magnetic term): as given, else from a hard
        filler's preset, ν M_r of the particles (a dilute composite magnetised to remanence,
        THEORY §9; ``remanence: 0 A/m`` makes the rod soft)."""
        if self.remanence is not None:
            return self.remanence
        if self.remanent_flux_density is not None:
            return self.remanent_flux_density
        preset = None if self.particles is None else self.particles.preset
        if preset is not None and preset.remanence:
            return self.particles.volume_fraction * preset.remanence
        return None

    def susceptibilities(self):
        """(χ̄, χ̂) of the particles alone (THEORY §2) or as given, dimensionless."""
        if self.particles is None:
            return self.chi_bar or 0.0, self.chi_hat or 0.0

        p = self.particles
        chi_par, chi_perp = p.susceptibilities
        with np.errstate(all="ignore"):
            chi_bar, chi_hat = effective_susceptibilities(chi_par, chi_perp, p.axis_ratio, p.volume_fraction)
        return float(chi_bar), float(chi_hat)

    def resolve(self, width: Optional[float], thickness: Optional[float],
                fibre_angle: Optional[float]) -> MagneticSummary:
        """The susceptibilities the groups use, with the body's demagnetisation (THEORY §10).

        Parameters
        ----------
        width, thickness : float or None
            Rod cross-section, m (None when only an area is given).
        fibre_angle : float or None
            The constant fibre angle α (rad), or None when the fibre angle varies along the rod.
        """
        chi_bar, chi_hat = self.susceptibilities()
        out = MagneticSummary(chi_bar, chi_hat, chi_max=chi_bar + chi_hat,
                              remanence=self.remanent_magnetization,
                              given="magnetics.particles" if self.particles else f"magnetics.chi_bar = {chi_bar:g}")
        p = self.particles
        if p is None:
            if self.chi_bar is not None and self.chi_bar == 0 and not self.remanent_magnetization:
                out.notes.append("chi_bar = 0 as given: a uniform field exerts no torque on the rod")
            return out
        out.particle_chi_bar, out.particle_chi_hat = chi_bar, chi_hat
        if p.m_s is not None:
            out.saturation = p.volume_fraction * p.m_s
        n_t = self.demagnetizing_factor
        if n_t is None and width is not None and thickness is not None:
            n_t = transverse_demagnetizing_factor(width, thickness)
        isotropic = chi_bar == 0.0
        if not self.body_demagnetization:
            out.notes.append("body demagnetisation off (body_demagnetization: false)")
        elif n_t is None:
            out.notes.append("body demagnetisation not applied: no width and thickness "
                             "(give them, or demagnetizing_factor)")
        elif fibre_angle is None and not isotropic:
            out.notes.append("body demagnetisation not applied: the fibre angle varies along the rod "
                             "and chi_eff would vary with it (set body_demagnetization: false to "
                             "silence this note)")
        else:
            chi_par, chi_perp = p.susceptibilities
            alpha = 0.0 if fibre_angle is None else fibre_angle
            body = body_susceptibility(composite_tensor(chi_par, chi_perp, p.axis_ratio,
                                                        p.volume_fraction), alpha, n_t)
            out.chi_bar, out.chi_hat, out.chi_max = body.chi_bar, body.chi_hat, body.chi_max
            out.demagnetizing_factor = n_t
            if fibre_angle is not None or isotropic:
                # isotropic particles: the easy axis is the body's (the tangent) whatever the
                # layout, a varying one included (THEORY §10)
                out.fibre_angle = body.fibre_angle
            out.notes.append(f"body demagnetisation applied (THEORY §10): N_t = {n_t:.6g}")
        if isotropic:
            out.notes.append("isotropic particles: a fibre layout has no effect (the easy axis is the "
                             "rod's tangent, THEORY §10); inverse design does not design one")
        if out.chi_bar == 0.0 and not self.remanent_magnetization:
            out.notes.append("chi_bar = 0: isotropic particles (THEORY §2) without the body's "
                             "demagnetisation give no torque in a uniform field")
        return out

    def field_limit(self, summary: Optional[MagneticSummary]) -> float:
        """The largest field |H| on the rod (A/m) :meth:`check_assumptions` accepts: the particles'
        saturation field and ν M_s / χ_max (inf: no limit known; THEORY §11)."""
        p = self.particles
        if p is None:
            return math.inf
        limits = [p.saturation_field] if p.saturation_field is not None else []
        if summary is not None and p.m_s is not None and summary.chi_max > 0:
            limits.append(p.volume_fraction * p.m_s / summary.chi_max)
        return float(min(limits)) if limits else math.inf

    def check_assumptions(self, h_max: Optional[float], summary: Optional[MagneticSummary]) -> None:
        """Warn (ModelAssumptionWarning) about dense particles, a largest field on the rod ``h_max``
        (A/m; None: no field) above the saturation field, or a linear magnetisation above the
        composite's saturation ν M_s (THEORY §11)."""
        p = self.particles
        if p is None:
            return
        check_assumptions(volume_fraction=p.volume_fraction, field=h_max, saturation_field=p.saturation_field)
        if h_max is not None and summary is not None and p.m_s is not None:
            check_saturation(summary.chi_max, h_max, p.volume_fraction, p.m_s,
                             p.material or "saturation_magnetization")


#: The remanent magnetisation angle β(s) (THEORY §9) takes every form the fibre angle takes.
MagnetizationProfile = tagged(("magnetization",), FibreConstant, FibreTable, FibreExpression, bare=constant_spec)


class DimensionlessMagnetics(StrictModel):
    """The magnetic groups of a ``type: dimensionless`` scene beyond h and φ (THEORY §5, §9):
    ``h_pos`` (the χ̂ group, non-uniform fields), and for a hard-magnetic rod ``h_r`` with
    ``magnetization``, the angle β(s) of the remanent magnetisation to the tangent (default 0 when
    ``h_r`` is given; ``h_r`` default 0 when only β(s) is)."""

    h_pos: Q("dimensionless", ge=0) = 0.0
    h_r: Optional[Q("dimensionless", ge=0)] = None
    magnetization: Optional[MagnetizationProfile] = None

    def check_magnetic_groups(self) -> None:
        """Raise the configuration error of the first group out of its range (the scene's validator
        calls it, after h)."""
        for group, value in self.magnetic_groups().items():
            problem = lens.parameter(group).range_problem(value)
            if problem is not None:
                raise error(problem, group)

    @property
    def hard_magnetic(self) -> bool:
        """Whether the scene has a remanent magnetisation (``h_r`` or ``magnetization`` given)."""
        return self.h_r is not None or self.magnetization is not None

    def magnetic_groups(self) -> Dict[str, float]:
        """The groups given, by lens name (h_r 0 when only the magnetisation is given)."""
        out = {"h_pos": self.h_pos}
        if self.hard_magnetic:
            out["h_r"] = self.h_r or 0.0
        return out

    def magnetic_profiles(self) -> Dict[str, object]:
        """The profiles given, by lens name (:class:`~actuator_design.model.profiles.Profile`)."""
        return _profiles(self.magnetization)


def _profiles(magnetization) -> Dict[str, object]:
    return {} if magnetization is None else {"magnetization": magnetization.to_profile()}


class PhysicalMagnetization(StrictModel):
    """The remanent magnetisation's angle β(s) to the tangent in a physical scene (``magnetization``,
    THEORY §9; default 0): a hard-magnetic rod's, so it needs the scene's remanence."""

    magnetization: Optional[MagnetizationProfile] = None

    def check_with_magnetics(self, magnetics: Optional[Magnetics]) -> None:
        """Raise the configuration error of a magnetisation angle without a remanence."""
        if self.magnetization is not None and (magnetics is None or magnetics.remanent_magnetization is None):
            raise error("needs magnetics.remanence or magnetics.remanent_flux_density "
                        "(a hard-magnetic rod, THEORY §9)", "magnetization")

    def magnetic_profiles(self) -> Dict[str, object]:
        """The profiles given, by lens name (:class:`~actuator_design.model.profiles.Profile`)."""
        return _profiles(self.magnetization)
