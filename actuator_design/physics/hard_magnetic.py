"""The hard-magnetic (remanent) energy term of THEORY §9.

A remanent magnetisation of magnitude M_r, frozen in the material at angle β(s) to the tangent,
rotates with the rod: m̂ = (cos(θ+β), sin(θ+β)). Its Zeeman energy per unit length, scaled as in
THEORY §5, is

    −h_r (m̂ · ĥ(r)),   h_r = μ0 M_r H0 A ℓ² / B0,

which in a uniform field at angle φ is −h_r cos(θ + β − φ) (no positions needed); in a non-uniform
field it also exerts the distributed gradient force through r(s), like the χ̂ term. h_r is linear in
the field (``field_power = 1``), h² quadratic: a field ramp through the lens scales them apart.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Optional

import casadi as ca
import numpy as np

from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics.fields import FieldModel, field_model
from actuator_design.physics.parameter import Parameter
from actuator_design.physics.registration import register_term
from actuator_design.physics.term_protocol import (EnergyTerm, ShootingPart, TermProfile, TermSummary,
                                                   snap_zero)

__all__ = ["HardMagnetic", "with_hard_magnetic_term"]


def with_hard_magnetic_term(scene: Scene) -> Scene:
    """``scene`` containing the hard-magnetic term: an axial magnetisation (β = 0) and a uniform
    field of zero strength are added when absent (h_r itself is left as it is)."""
    if scene.field is None:
        scene = replace(scene, field=UniformField(), h=0.0)
    if scene.magnetization is None:
        scene = replace(scene, magnetization=constant_profile(0.0))
    return scene


def _needs_remanence(sc: Scene) -> Optional[str]:
    """Why β(s) cannot be designed: without remanence the magnetisation does nothing (a physical
    scene at zero field has it per unit field, ``Scales.per_field``)."""
    if sc.h_r > 0 or dict(getattr(sc.scales, "per_field", ()) or ()).get("h_r", 0.0) > 0:
        return None
    return ("the scene's h_r is 0; give the remanence in the scene (h_r > 0, or magnetics: remanence / "
            "remanent_flux_density) to design the magnetisation profile")


def _magnetization_angle(sc: Scene) -> float:
    if sc.magnetization is None:
        return 0.0
    if not sc.magnetization.is_constant:
        raise ValueError("magnetization: the scene's magnetisation angle is not constant; "
                         "magnetization sets a constant magnetisation angle")
    return float(sc.magnetization.value)


@register_term
class HardMagnetic(EnergyTerm):
    """−h_r (m̂·ĥ(r)), m̂ = (cos(θ+β), sin(θ+β)) (THEORY §9)."""

    name = "hard_magnetic"
    periodic_in_theta = True
    scaling_declared = True
    node_fields = {"beta": lambda scene, s: scene.magnetization(s)}
    parameters = (
        Parameter("h_r", "hard-magnetic group h_r = mu0 M_r H A l^2 / B0", "1", "h_r",
                  read=lambda sc: sc.h_r, write=lambda sc, v: replace(sc, h_r=v),
                  term="hard_magnetic", lower=0.0, field_power=1, residual="linear",
                  stiffness_power=-1.0, remanent_field=True, ensure=with_hard_magnetic_term,
                  scene_range=(0.0, 1e8), mirror=1.0, layer_power=0.5,  # as h²: a clamp layer of width ~1/√h_r
                  flag_help="hard-magnetic group h_r >= 0 (THEORY §9; adds an axial remanent magnetisation)"),
        Parameter("magnetization", "constant magnetisation angle beta to the tangent", "rad", "beta",
                  read=_magnetization_angle,
                  write=lambda sc, v: replace(sc, magnetization=constant_profile(v)),
                  term="hard_magnetic", per_point=True, ensure=with_hard_magnetic_term,
                  designable=True, profile_label="magnetised",  # designed as a profile β(s) (inverse/nlp.py)
                  profile=lambda sc: sc.magnetization, with_profile=lambda sc, prof: replace(sc, magnetization=prof),
                  design_check=_needs_remanence, mirror=-1.0, design_bound=np.pi,
                  flag_help="constant remanent magnetisation angle beta to the tangent, degrees (THEORY §9)"),
    )

    def __init__(self, field: FieldModel):
        self.field = field
        self.scalar_params = ("h_r",) + field.params

    @classmethod
    def summary(cls, scene: Scene) -> TermSummary:
        if scene.magnetization is None:
            return TermSummary()
        return TermSummary(groups=(("h_r", scene.h_r),),
                           profile=TermProfile("magnetization", "magnetisation: remanent", scene.magnetization,
                                               "beta", True))

    @classmethod
    def present(cls, scene: Scene) -> bool:
        return scene.magnetization is not None and scene.field is not None

    @classmethod
    def wavenumber(cls, scene: Scene) -> float:
        """√h_r: θ'' = h_r sin(θ + β − φ) linearised about the aligned state (THEORY §9), the
        remanent counterpart of the soft term's √2 h (a gradient's scale is only known a posteriori)."""
        return math.sqrt(abs(scene.h_r))

    @classmethod
    def tip_layer(cls, scene: Scene) -> bool:
        """The rod lies along φ − β(s) but for the end layers: a varying β or field direction asks
        for a curvature the free end cannot have."""
        return scene.h_r != 0.0 and not (scene.magnetization.is_constant and scene.field.is_uniform)

    @classmethod
    def result_groups(cls, scene: Scene) -> dict:
        return {} if scene.magnetization is None else {"h_r": scene.h_r}

    @classmethod
    def from_scene(cls, scene: Scene) -> "HardMagnetic":
        return cls(field_model(scene.field))

    @classmethod
    def phase_potential(cls, scene: Scene):
        if not scene.magnetization.is_constant:
            raise ValueError("magnetization: phase portraits need a constant magnetisation angle beta(s)")
        h_r, shift = float(scene.h_r), float(scene.magnetization.value) - scene.phi
        return lambda theta: h_r * np.cos(theta + shift)  # (the field's uniformity: FieldOrientation)

    @classmethod
    def shooting_part(cls, scene: Scene) -> ShootingPart:
        """In a uniform field the remanent torque is that of an internal force n_r(s) = h_r (cos(β − φ),
        −sin(β − φ)): −h_r cos(θ + β − φ) = −n_r·(cos θ, sin θ) (THEORY §9)."""
        h_r = float(scene.h_r)

        def force(s):
            s = np.asarray(s, float)
            if h_r == 0.0:
                return np.zeros_like(s), np.zeros_like(s)
            u = np.broadcast_to(np.asarray(scene.magnetization(s), float), s.shape) - scene.phi
            return h_r * snap_zero(np.cos(u)), -h_r * snap_zero(np.sin(u))

        return ShootingPart(force=force, dead=False, torque=h_r, jacobi=h_r, potential_max=h_r, spread=2 * h_r,
                            autonomous=scene.magnetization.is_constant)

    def density(self, kin, P):
        u = kin.theta + kin.fields["beta"]
        if self.field.is_uniform:
            return -P["h_r"] * ca.cos(u - P["phi"])
        hx, hy = self.field.value(kin.x, kin.y, P)
        return -P["h_r"] * (ca.cos(u) * hx + ca.sin(u) * hy)

    def values(self, scene):
        return {"h_r": scene.h_r, **self.field.parameter_values(scene.field)}

    def structure(self):
        return (self.name,) + self.field.structure()
