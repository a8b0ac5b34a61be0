"""The built-in energy terms of the dimensionless rod energy (THEORY §4–5): bending, the field's
χ̄ and χ̂ terms and the dead loads, each one class behind the protocol of :mod:`.term_protocol`
(the hard-magnetic term is :mod:`.hard_magnetic`).

Adding a physics term = writing a subclass of :class:`EnergyTerm` and registering it
(:func:`~actuator_design.physics.registration.register_term`); nothing else changes. A plug-in term is present in a scene when
the scene lists it in ``extra_terms`` (with its values).
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
from actuator_design.physics.term_protocol import (EnergyTerm, ShootingPart,  # noqa: F401 (re-exported)
                                                   TermProfile, TermSummary, node_field_sources,
                                                   node_field_values, residual_slots, scalar_parameter_values,
                                                   structure_key, zero_potential)

__all__ = ["EnergyTerm", "TermSummary", "TermProfile", "structure_key", "scalar_parameter_values", "node_field_sources",
           "node_field_values", "residual_slots", "Bending", "FieldOrientation", "FieldPosition", "TipForce",
           "TipMoment", "DistributedLoad"]


# -- the built-in terms and their parameters ------------------------------------------------------
def _with_field(sc: Scene) -> Scene:
    return sc if sc.field is not None else replace(sc, field=UniformField(), h=0.0)


def _with_uniform_field(sc: Scene) -> Scene:
    sc = _with_field(sc)
    if not isinstance(sc.field, UniformField):
        raise ValueError(f"phi: needs a uniform field; this scene has a {sc.field.kind} field")
    return sc


def _fibre_angle(sc: Scene) -> float:
    if not sc.fibres.is_constant:
        raise ValueError("alpha: the scene's fibre angle is not constant; alpha sets a constant fibre angle")
    return float(sc.fibres.value)


def _tip_force(sc: Scene, i: int, v: Optional[float] = None):
    f = list(sc.tip_force or (0.0, 0.0))
    if v is None:
        return float(f[i])
    f[i] = v
    return replace(sc, tip_force=tuple(f))


def _load(sc: Scene, i: int, v: Optional[float] = None):
    q = list(sc.distributed_load or (0.0, 0.0))
    if v is None:
        return float(q[i])
    q[i] = v
    return replace(sc, distributed_load=tuple(q))


_H_KW = dict(term="field_orientation", lower=0.0, field_magnitude=True, residual="squared",
             ensure=_with_field, mirror=1.0)
#: The valid ranges of the groups (config/limits.py): h ≤ 1e4 keeps the clamp layer of width ~1/h
#: resolvable; a load's layer has width ~1/√|p| and its residuals grow like |p| (THEORY §5).
H_RANGE, LOAD_RANGE = (0.0, 1e4), (-1e5, 1e5)
#: dead loads are ∝ 1/B0 (THEORY §5)
_F_KW = dict(term="tip_force", residual="linear", stiffness_power=-1.0, scene_range=LOAD_RANGE,
             ensure=lambda sc: sc if sc.tip_force is not None else replace(sc, tip_force=(0.0, 0.0)))
_Q_KW = dict(unit="B0/l^3", term="distributed_load", residual="linear", stiffness_power=-1.0, scene_range=LOAD_RANGE,
             ensure=lambda sc: sc if sc.distributed_load is not None else replace(sc, distributed_load=(0.0, 0.0)))


@register_term
class Bending(EnergyTerm):
    """½ b(s) θ'² (THEORY §4: ½ Ẽ I κ², scaled by B0/ℓ)."""

    name = "bending"
    periodic_in_theta = True
    scaling_declared = True  # its parameters state their power laws
    node_fields = {"b": lambda scene, s: scene.stiffness(s)}

    @classmethod
    def present(cls, scene):
        return True

    @classmethod
    def phase_potential(cls, scene):
        if not scene.stiffness.is_constant:
            raise ValueError("stiffness: phase portraits need a constant bending stiffness b(s)")
        return zero_potential  # its ½ b θ'² is the first integral's kinetic part

    @classmethod
    def shooting_part(cls, scene):
        return ShootingPart(autonomous=scene.stiffness.is_constant)  # (b(s) is the scan's own)

    def density(self, kin, P):
        return 0.5 * kin.fields["b"] * kin.curvature**2


@register_term
class FieldOrientation(EnergyTerm):
    """−h² (ã_c·ĥ(r))², ã_c = (cos(θ+α), sin(θ+α)) (THEORY §4–5, the χ̄ term).

    In a uniform field this is −h² cos²(θ + α − φ) and needs no positions.
    """

    name = "field_orientation"
    periodic_in_theta = True
    scaling_declared = True  # its parameters state their power laws
    node_fields = {"alpha": lambda scene, s: scene.fibres(s)}
    parameters = (
        Parameter("h", "field group h", "1", "h", read=lambda sc: sc.h,
                  write=lambda sc, v: replace(sc, h=v, field=sc.field or UniformField()),
                  field_power=1, designable=True, stiffness_power=-0.5, susceptibility_power=0.5,
                  scene_range=H_RANGE, layer_power=1.0, **_H_KW),
        Parameter("h2", "h squared", "1", "h", read=lambda sc: sc.h ** 2,
                  write=lambda sc, v: replace(sc, h=float(np.sqrt(v)), field=sc.field or UniformField()),
                  transform="sqrt", field_power=2, stiffness_power=-1.0, susceptibility_power=1.0,
                  scene_range=(0.0, H_RANGE[1] ** 2), **_H_KW),
        Parameter("phi", "uniform field angle phi", "rad", "phi", read=lambda sc: sc.phi,
                  write=lambda sc, v: replace(sc, field=UniformField(phi=v)), term="field_orientation",
                  ensure=_with_uniform_field, designable=True, mirror=-1.0),
        Parameter("alpha", "constant fibre angle alpha", "rad", "alpha", read=_fibre_angle,
                  write=lambda sc, v: replace(sc, fibres=constant_profile(v)), term="field_orientation",
                  per_point=True, designable=True, profile_label="fibres", profile=lambda sc: sc.fibres, mirror=-1.0,
                  design_bound=math.pi / 2,  # a fibre angle beyond ±90° is the same fibre
                  with_profile=lambda sc, prof: replace(sc, fibres=prof)),
    )

    def __init__(self, field: FieldModel):
        self.field = field
        self.scalar_params = ("h",) + field.params

    @classmethod
    def present(cls, scene):
        return scene.field is not None

    @classmethod
    def result_groups(cls, scene):
        out = {"h": scene.h, "h_squared": scene.h**2}
        if scene.field is not None:
            out["field"] = scene.field.kind
            if isinstance(scene.field, UniformField):
                out["phi"] = scene.field.phi
        return out

    @classmethod
    def from_scene(cls, scene):
        return cls(field_model(scene.field))

    @classmethod
    def wavenumber(cls, scene):
        """√2 h, the pendulum frequency of THEORY §6 (and √2 h_pos: a gradient's own scale is only
        known a posteriori)."""
        return math.sqrt(2.0) * max(abs(scene.h), abs(scene.h_pos))

    @classmethod
    def tip_layer(cls, scene):
        """The rod lies along φ − α(s) but for the end layers: a varying α or field direction
        asks for a curvature the free end cannot have."""
        return scene.h != 0.0 and not (scene.fibres.is_constant and scene.field.is_uniform)

    @classmethod
    def dense_hessian(cls, scene):
        return not scene.field.is_uniform

    @classmethod
    def phase_potential(cls, scene):
        if not isinstance(scene.field, UniformField):
            raise ValueError(f"field: phase portraits need a uniform field (or none), got a {scene.field.kind} field")
        if not scene.fibres.is_constant:
            raise ValueError("fibres: phase portraits need a constant fibre angle alpha(s)")
        h2, shift = scene.h ** 2, float(scene.fibres.value) - scene.phi
        return lambda theta: h2 * np.cos(theta + shift) ** 2

    @classmethod
    def shooting_part(cls, scene):
        if not isinstance(scene.field, UniformField):
            raise ValueError(f"equilibria: only uniform fields (or none) are supported, this scene has a "
                             f"{scene.field.kind} field")
        h2 = scene.h ** 2  # |M'| ≤ h², |Q| ≤ 2h², h² cos² ψ ∈ [0, h²]
        return ShootingPart(twofold=h2, twofold_angle=lambda s: 2 * (scene.fibres(s) - scene.phi), torque=h2,
                            jacobi=2 * h2, potential_max=h2, spread=h2, autonomous=scene.fibres.is_constant)

    def density(self, kin, P):
        h2 = P["h"] ** 2
        u = kin.theta + kin.fields["alpha"]
        if self.field.is_uniform:
            return -h2 * ca.cos(u - P["phi"]) ** 2
        hx, hy = self.field.value(kin.x, kin.y, P)
        return -h2 * (ca.cos(u) * hx + ca.sin(u) * hy) ** 2

    def values(self, scene):
        return {"h": scene.h, **self.field.parameter_values(scene.field)}

    def structure(self):
        return (self.name,) + self.field.structure()


@register_term
class FieldPosition(EnergyTerm):
    """−h_pos² |ĥ(r)|² (THEORY §4, the χ̂ term; built only for non-uniform fields)."""

    name = "field_position"
    periodic_in_theta = True
    scaling_declared = True  # its parameters state their power laws
    parameters = (
        Parameter("h_pos", "positional field group h_pos (non-uniform fields)", "1", "h_pos",
                  read=lambda sc: sc.h_pos, write=lambda sc, v: replace(sc, h_pos=v),
                  term="field_position", lower=0.0, field_power=1, residual="squared",
                  stiffness_power=-0.5, susceptibility_power=0.5, scene_range=H_RANGE, mirror=1.0),
    )

    def __init__(self, field: FieldModel):
        self.field = field
        self.scalar_params = ("h_pos",) + field.params

    @classmethod
    def summary(cls, scene):
        shown = scene.field is not None and not scene.field.is_uniform
        return TermSummary(groups=(("h_pos", scene.h_pos),) if shown else ())

    @classmethod
    def result_groups(cls, scene):
        return {"h_pos": scene.h_pos} if scene.field is not None and not scene.field.is_uniform else {}

    @classmethod
    def present(cls, scene):
        return scene.field is not None and not scene.field.is_uniform and scene.h_pos != 0.0

    @classmethod
    def from_scene(cls, scene):
        return cls(field_model(scene.field))

    def density(self, kin, P):
        hx, hy = self.field.value(kin.x, kin.y, P)
        return -P["h_pos"] ** 2 * (hx**2 + hy**2)

    def values(self, scene):
        return {"h_pos": scene.h_pos, **self.field.parameter_values(scene.field)}

    def structure(self):
        return (self.name,) + self.field.structure()


@register_term
class TipForce(EnergyTerm):
    """−f·r(1): dead tip force f = (fx, fy), p = fy (THEORY §5)."""

    name = "tip_force"
    periodic_in_theta = True
    load_name = "tip force"
    scaling_declared = True  # its parameters state their power laws
    scalar_params = ("fx", "fy")
    parameters = (
        Parameter("p", "vertical tip load p = fy", "B0/l^2", "fy", read=lambda sc: _tip_force(sc, 1),
                  write=lambda sc, v: _tip_force(sc, 1, v), designable=True, mirror=-1.0, **_F_KW),
        Parameter("fy", "tip force y component", "B0/l^2", "fy", read=lambda sc: _tip_force(sc, 1),
                  write=lambda sc, v: _tip_force(sc, 1, v), mirror=-1.0, conjugate="y", **_F_KW),
        Parameter("fx", "tip force x component", "B0/l^2", "fx", read=lambda sc: _tip_force(sc, 0),
                  write=lambda sc, v: _tip_force(sc, 0, v), mirror=1.0, conjugate="x", **_F_KW),
    )

    @classmethod
    def present(cls, scene):
        return scene.tip_force is not None

    @classmethod
    def wavenumber(cls, scene):
        return math.sqrt(math.hypot(*scene.tip_force))  # the elastica's √|f|

    @classmethod
    def end_force(cls, scene):
        return None if scene.tip_force is None else (float(scene.tip_force[0]), float(scene.tip_force[1]))

    @classmethod
    def phase_potential(cls, scene):
        fx, fy = (float(f) for f in scene.tip_force)
        return lambda theta: fy * np.sin(theta) + fx * np.cos(theta)  # −f·r(1) = −∫ f·(cos θ, sin θ) ds

    @classmethod
    def shooting_part(cls, scene):
        fx, fy = scene.tip_force
        size = float(np.linalg.norm(np.array(scene.tip_force, float)))
        return ShootingPart(force=lambda s: (fx, fy), force_integral=size, potential_max=size, spread=2 * size)

    @classmethod
    def summary(cls, scene):
        if scene.tip_force is None:
            return TermSummary()
        fx, fy = scene.tip_force
        return TermSummary(groups=(("p", scene.p),), load=f"tip force (fx, fy) = ({fx:.6g}, {fy:.6g}) B0/l^2")

    @classmethod
    def result_groups(cls, scene):
        return {} if scene.tip_force is None else {cls.name: list(scene.tip_force), "p": scene.p}

    def tip(self, tip, P):
        return -(P["fx"] * tip.x + P["fy"] * tip.y)

    def values(self, scene):
        return {"fx": scene.tip_force[0], "fy": scene.tip_force[1]}


@register_term
class TipMoment(EnergyTerm):
    """−m θ(1): dead tip moment, counter-clockwise positive."""

    name = "tip_moment"
    periodic_in_theta = True
    load_name = "tip moment"
    scaling_declared = True  # its parameters state their power laws
    scalar_params = ("m_tip",)
    parameters = (
        Parameter("m_tip", "tip moment", "B0/l", "m_tip", read=lambda sc: sc.tip_moment or 0.0,
                  write=lambda sc, v: replace(sc, tip_moment=v), term="tip_moment", residual="linear",
                  stiffness_power=-1.0, scene_range=LOAD_RANGE, mirror=-1.0, conjugate="angle",
                  ensure=lambda sc: sc if sc.tip_moment is not None else replace(sc, tip_moment=0.0)),
    )

    @classmethod
    def present(cls, scene):
        return scene.tip_moment is not None

    @classmethod
    def wavenumber(cls, scene):
        return abs(scene.tip_moment)

    @classmethod
    def end_moment(cls, scene):
        return float(scene.tip_moment or 0.0)

    @classmethod
    def phase_potential(cls, scene):
        return zero_potential  # it sets the end line b θ'(1) = m (end_moment), not H

    @classmethod
    def shooting_part(cls, scene):
        return ShootingPart()  # it sets the end condition b θ'(1) = m (end_moment)

    @classmethod
    def summary(cls, scene):
        return TermSummary(load=None if scene.tip_moment is None else f"tip moment {scene.tip_moment:.6g} B0/l")

    @classmethod
    def result_groups(cls, scene):
        return {} if scene.tip_moment is None else {cls.name: scene.tip_moment}

    def tip(self, tip, P):
        return -P["m_tip"] * tip.theta

    def values(self, scene):
        return {"m_tip": scene.tip_moment}


@register_term
class DistributedLoad(EnergyTerm):
    """−q·r(s) per unit length: a dead distributed load such as weight."""

    name = "distributed_load"
    periodic_in_theta = True
    load_name = "distributed load"
    scaling_declared = True  # its parameters state their power laws
    scalar_params = ("qx", "qy")
    parameters = (
        Parameter("qx", "distributed load x component", slot="qx", read=lambda sc: _load(sc, 0),
                  write=lambda sc, v: _load(sc, 0, v), mirror=1.0, **_Q_KW),
        Parameter("qy", "distributed load y component", slot="qy", read=lambda sc: _load(sc, 1),
                  write=lambda sc, v: _load(sc, 1, v), mirror=-1.0, **_Q_KW),
    )

    @classmethod
    def present(cls, scene):
        return scene.distributed_load is not None

    @classmethod
    def summary(cls, scene):
        q = scene.distributed_load
        return TermSummary(load=None if q is None else f"distributed load (qx, qy) = ({q[0]:.6g}, {q[1]:.6g}) B0/l^3")

    @classmethod
    def result_groups(cls, scene):
        return {} if scene.distributed_load is None else {cls.name: list(scene.distributed_load)}

    @classmethod
    def wavenumber(cls, scene):
        return math.hypot(*scene.distributed_load) ** (1.0 / 3.0)

    @classmethod
    def tip_layer(cls, scene):
        """The internal force q (1 − s) vanishes at the free end but its slope does not: the rod held
        along a strong field (or hanging) is bent there by it, which the free end cannot follow."""
        return any(q != 0.0 for q in scene.distributed_load)

    @classmethod
    def phase_potential(cls, scene):
        if any(q != 0 for q in scene.distributed_load):
            raise ValueError("distributed_load: phase portraits need no distributed load (it makes the "
                             "equation depend on s)")
        return zero_potential

    @classmethod
    def shooting_part(cls, scene):
        qx, qy = scene.distributed_load  # n(s) = q (1 − s): ∫|n| ≤ |q|/2
        return ShootingPart(force=lambda s: (qx * (1 - s), qy * (1 - s)),
                            force_integral=0.5 * float(np.linalg.norm(np.array(scene.distributed_load, float))),
                            autonomous=not (qx or qy))

    def density(self, kin, P):
        return -(P["qx"] * kin.x + P["qy"] * kin.y)

    def values(self, scene):
        return {"qx": scene.distributed_load[0], "qy": scene.distributed_load[1]}
