"""One class per energy term of the dimensionless rod energy (THEORY §4–5), behind one interface.

The total energy is Ê[θ] = ∫₀¹ Σ density(θ, θ', x, y) ds + Σ tip(θ(1), x(1), y(1)). A term reads
scalar NLP parameters (``scalar_params``) and per-quadrature-point fields (``node_fields``: the fibre
angle α and the relative stiffness b), and says whether it needs rod positions (a transcription
builds x(s), y(s) at the quadrature points only if some term needs them).

Adding a physics term = adding a class here and a line in :func:`build_terms`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import casadi as ca
import numpy as np

from ..scene import Scene
from .fields import FieldModel, field_model

__all__ = ["PointState", "TipState", "EnergyTerm", "build_terms", "structure_key",
           "scalar_parameter_values", "NODE_FIELDS"]

#: Per-point fields a term may read, and how a scene evaluates them at arc lengths s.
NODE_FIELDS = {
    "alpha": lambda scene, s: scene.fibres(s),
    "b": lambda scene, s: scene.stiffness(s),
}


@dataclass
class PointState:
    """State at the quadrature points (CasADi column vectors of equal length)."""

    theta: ca.SX
    kappa: ca.SX
    x: Optional[ca.SX]
    y: Optional[ca.SX]
    fields: Dict[str, ca.SX]


@dataclass
class TipState:
    theta: ca.SX
    x: ca.SX
    y: ca.SX


class EnergyTerm:
    """Interface of an energy term; subclasses override what they contribute."""

    name = "term"
    scalar_params: Tuple[str, ...] = ()
    node_fields: Tuple[str, ...] = ()
    needs_position = False

    def density(self, st: PointState, P: Dict[str, ca.SX]):
        """Energy per unit (dimensionless) length at each point, or ``None``."""
        return None

    def tip(self, st: TipState, P: Dict[str, ca.SX]):
        """Energy concentrated at the free end, or ``None``."""
        return None

    def values(self, scene: Scene) -> Dict[str, float]:
        """Numerical values of ``scalar_params`` for a scene."""
        return {}

    def structure(self) -> tuple:
        return (self.name,)


class Bending(EnergyTerm):
    """½ b(s) θ'² (THEORY §4: ½ Ẽ I κ², scaled by B0/ℓ)."""

    name = "bending"
    node_fields = ("b",)

    def density(self, st, P):
        return 0.5 * st.fields["b"] * st.kappa**2


class FieldOrientation(EnergyTerm):
    """−h² (ã_c·ĥ(r))², ã_c = (cos(θ+α), sin(θ+α)) (THEORY §4–5, the χ̄ term).

    In a uniform field this is −h² cos²(θ + α − φ) and needs no positions.
    """

    name = "field_orientation"
    node_fields = ("alpha",)

    def __init__(self, field: FieldModel):
        self.field = field
        self.scalar_params = ("h",) + field.params
        self.needs_position = not field.is_uniform

    def density(self, st, P):
        h2 = P["h"] ** 2
        u = st.theta + st.fields["alpha"]
        if self.field.is_uniform:
            return -h2 * ca.cos(u - P["phi"]) ** 2
        hx, hy = self.field.value(st.x, st.y, P)
        return -h2 * (ca.cos(u) * hx + ca.sin(u) * hy) ** 2

    def values(self, scene):
        return {"h": scene.h, **self.field.parameter_values(scene.field)}

    def structure(self):
        return (self.name,) + self.field.structure()


class FieldPosition(EnergyTerm):
    """−h_pos² |ĥ(r)|² (THEORY §4, the χ̂ term; built only for non-uniform fields)."""

    name = "field_position"
    needs_position = True

    def __init__(self, field: FieldModel):
        self.field = field
        self.scalar_params = ("h_pos",) + field.params

    def density(self, st, P):
        hx, hy = self.field.value(st.x, st.y, P)
        return -P["h_pos"] ** 2 * (hx**2 + hy**2)

    def values(self, scene):
        return {"h_pos": scene.h_pos, **self.field.parameter_values(scene.field)}

    def structure(self):
        return (self.name,) + self.field.structure()


class TipForce(EnergyTerm):
    """−f·r(1): dead tip force f = (fx, fy), p = fy (THEORY §5)."""

    name = "tip_force"
    scalar_params = ("fx", "fy")

    def tip(self, st, P):
        return -(P["fx"] * st.x + P["fy"] * st.y)

    def values(self, scene):
        return {"fx": scene.tip_force[0], "fy": scene.tip_force[1]}


class TipMoment(EnergyTerm):
    """−m θ(1): dead tip moment, counter-clockwise positive."""

    name = "tip_moment"
    scalar_params = ("m_tip",)

    def tip(self, st, P):
        return -P["m_tip"] * st.theta

    def values(self, scene):
        return {"m_tip": scene.tip_moment}


class DistributedLoad(EnergyTerm):
    """−q·r(s) per unit length: a dead distributed load such as weight."""

    name = "distributed_load"
    scalar_params = ("qx", "qy")
    needs_position = True

    def density(self, st, P):
        return -(P["qx"] * st.x + P["qy"] * st.y)

    def values(self, scene):
        return {"qx": scene.distributed_load[0], "qy": scene.distributed_load[1]}


def build_terms(scene: Scene) -> List[EnergyTerm]:
    """The terms this scene contains, and no others (a term absent from the scene is not built)."""
    terms: List[EnergyTerm] = [Bending()]
    if scene.field is not None:
        fm = field_model(scene.field)
        terms.append(FieldOrientation(fm))
        if not fm.is_uniform and scene.h_pos != 0.0:
            terms.append(FieldPosition(fm))
    if scene.tip_force is not None:
        terms.append(TipForce())
    if scene.tip_moment is not None:
        terms.append(TipMoment())
    if scene.distributed_load is not None:
        terms.append(DistributedLoad())
    return terms


def structure_key(terms: List[EnergyTerm]) -> tuple:
    """Hashable key of what is built symbolically: scenes with equal keys share one NLP."""
    return tuple(t.structure() for t in terms)


def scalar_parameter_values(terms: List[EnergyTerm], scene: Scene) -> Dict[str, float]:
    out = {"theta0": scene.theta0}
    for t in terms:
        out.update(t.values(scene))
    return {k: float(v) for k, v in out.items()}
