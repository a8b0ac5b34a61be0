"""The dead-load terms' configuration: the ``loads:`` block of a physical scene in SI units, and
the loads of a dimensionless scene in units of B0 (:class:`DimensionlessLoads`).

A tip force F (N), a tip moment M (N m), a distributed load q (N/m) or the rod's weight
q = ρ g A along the gravity direction. It lives with the load terms (:mod:`.terms`): the block turns
itself into their dimensionless groups (:meth:`Loads.groups`: F ℓ²/B0, M ℓ/B0, q ℓ³/B0, THEORY §5),
by lens name, so a physical scene asks it rather than naming the loads.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Tuple

import numpy as np
from pydantic import model_validator

from actuator_design.config.base import Angle, ForceXY, LineLoadXY, Number, NumberXY, Q, StrictModel
from actuator_design.config.errors import error
from actuator_design.physics import parameters as lens

__all__ = ["Weight", "Loads", "DimensionlessLoads"]


class Weight(StrictModel):
    """Self-weight q = ρ g A per unit length along the gravity direction ``gravity_angle``."""

    density: Q("density", gt=0)
    gravity_angle: Angle = -0.5 * math.pi
    g: Q("acceleration", gt=0) = 9.81


class Loads(StrictModel):
    """Dead loads: tip force (N), tip moment (N m), distributed load (N/m) or weight."""

    tip_force: Optional[ForceXY] = None
    tip_moment: Optional[Q("moment")] = None
    distributed: Optional[LineLoadXY] = None
    weight: Optional[Weight] = None

    @model_validator(mode="after")
    def _check(self):
        if self.distributed is not None and self.weight is not None:
            raise error("give either distributed or weight, not both", "weight")
        return self

    def line_load(self, area: float):
        """Distributed load (qx, qy) in N/m, or None."""
        if self.weight is None:
            return None if self.distributed is None else (self.distributed.x, self.distributed.y)
        w = self.weight
        with np.errstate(all="ignore"):
            q = float(np.float64(w.density) * w.g * area)
        # round-off of cos(-π/2) etc. to an exact zero, so "down" is exactly (0, -q)
        cx, cy = (0.0 if abs(c) < 1e-15 else c for c in (math.cos(w.gravity_angle),
                                                           math.sin(w.gravity_angle)))
        return (q * cx, q * cy)

    def groups(self, length: float, area: float, stiffness: float) -> Tuple[Dict[str, float], Dict[str, List[str]]]:
        """The dimensionless groups of the loads given, by lens name, and the inputs each comes from.

        Parameters
        ----------
        length, area, stiffness : float
            ℓ (m), A (m²) and B0 (N m²). Computed in float64: an overflow gives inf (the caller's
            range check names it), not an exception.

        Returns
        -------
        (dict, dict)
            Group name -> value (fx, p in B0/ℓ², m_tip in B0/ℓ, qx, qy in B0/ℓ³), and group name ->
            the YAML inputs it comes from (for messages).
        """
        values, given = {}, {}
        with np.errstate(all="ignore"):
            force = np.float64(length) ** 2 / stiffness
            if self.tip_force is not None:
                f = self.tip_force
                values["fx"], values["p"] = float(f.x * force), float(f.y * force)
                given["fx"] = given["p"] = [f"loads.tip_force = ({f.x:g}, {f.y:g}) N"]
            if self.tip_moment is not None:
                values["m_tip"] = float(self.tip_moment * np.float64(length) / stiffness)
                given["m_tip"] = [f"loads.tip_moment = {self.tip_moment:g} N m"]
            q = self.line_load(area)
            if q is not None:
                line = np.float64(length) ** 3 / stiffness
                values["qx"], values["qy"] = float(q[0] * line), float(q[1] * line)
                which = "loads.weight" if self.weight is not None else "loads.distributed"
                given["qx"] = given["qy"] = [f"{which} = ({q[0]:g}, {q[1]:g}) N/m"]
        return values, given


class DimensionlessLoads(StrictModel):
    """The dead loads of a ``type: dimensionless`` scene, in units of B0 (THEORY §5): ``p`` (a
    vertical tip force) or ``tip_force`` (x, y) in B0/ℓ², ``tip_moment`` in B0/ℓ,
    ``distributed_load`` (x, y) in B0/ℓ³."""

    p: Optional[Number] = None
    tip_force: Optional[NumberXY] = None
    tip_moment: Optional[Number] = None
    distributed_load: Optional[NumberXY] = None

    def check_load_keys(self) -> None:
        """Raise the configuration error of p given with tip_force (the scene's validator calls it
        with its own checks of exclusive keys)."""
        if self.p is not None and self.tip_force is not None:
            raise error("give either p or tip_force, not both", "p")

    def check_loads(self) -> None:
        """Raise the configuration error of the first load out of its range (the scene's validator
        calls it after the field's groups)."""
        for group, value, key in self._given():
            problem = lens.parameter(group).range_problem(value)
            if problem is not None:
                raise error(problem, key)

    def _given(self) -> List[Tuple[str, float, str]]:
        """(lens name, value, YAML key) of every load component given."""
        tip, q = self.tip_force, self.distributed_load
        entries = [("p", self.p, "p"), ("fx", tip and tip.x, "tip_force.x"), ("p", tip and tip.y, "tip_force.y"),
                   ("m_tip", self.tip_moment, "tip_moment"),
                   ("qx", q and q.x, "distributed_load.x"), ("qy", q and q.y, "distributed_load.y")]
        return [e for e in entries if e[1] is not None]

    def load_groups(self) -> Dict[str, float]:
        """The load groups given, by lens name (``p`` alone: a tip force (0, p))."""
        return {group: float(value) for group, value, _ in self._given()}
