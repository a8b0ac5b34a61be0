"""Valid ranges of the dimensionless groups and of the mesh size: what the solver can honour.

Every scene reaching the solver, from a configuration file or from command-line flags, is checked
against these ranges (README "Units and scenes"). The groups are those of THEORY §5:

=========================  ====================  ==========================================
group                      range                 why
=========================  ====================  ==========================================
h, h_pos                   [0, 1e4]              boundary layer of width ~1/h at the clamp
h_r (hard-magnetic)        [0, 1e8]              as h²: layer of width ~1/√h_r
p, fx, fy (tip force)      [-1e5, 1e5]           layer of width ~1/√|p|; residuals ~|p|
tip moment m               [-1e5, 1e5]           curvature ~|m|
distributed load qx, qy    [-1e5, 1e5]           as the tip force, integrated
=========================  ====================  ==========================================

Mesh size. The solver stores the Hessian of the discrete energy in the n free unknowns θ_i
(n = elements × degree for ``lgl``, n = elements for ``midpoint``) as a CasADi expression graph
plus numerical copies. Measured peak memory (Python 3.11, CasADi 3.6):

* terms local in θ (uniform field, tip loads, distributed loads): the Hessian is banded with
  2b + 1 entries per row (b = degree for ``lgl``, 1 for ``midpoint``); about 2 kB per entry
  (lgl 400 × 10: 0.31 GB; midpoint 4000: 0.16 GB), so at most :data:`MAX_BANDED_ENTRIES`
  = 4·10⁵ entries (≈ 0.8 GB);
* a non-uniform field (dipole, expression) couples every pair of nodes through the positions: the
  Hessian is dense, about 21 kB per entry (midpoint 125: 0.48 GB; 250: 1.6 GB), so at most
  :data:`MAX_DENSE_UNKNOWNS` = 200 unknowns (≈ 0.85 GB).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Optional, Tuple

__all__ = ["GroupRange", "GROUP_RANGES", "MAX_BANDED_ENTRIES", "MAX_DENSE_UNKNOWNS",
           "group_problem", "unknowns", "mesh_problem", "scene_group_values"]

#: Largest number of Hessian entries for a banded (local-term) Hessian, ≈ 0.8 GB at 2 kB each.
MAX_BANDED_ENTRIES = 400_000
#: Largest number of free unknowns when a non-uniform field makes the Hessian dense (≈ 0.85 GB).
MAX_DENSE_UNKNOWNS = 200


@dataclass(frozen=True)
class GroupRange:
    """The closed interval [lo, hi] a dimensionless group must lie in.

    Attributes
    ----------
    symbol : str
        The group's name in THEORY §5 (``"h"``, ``"p"``, ...).
    lo, hi : float
        Bounds, dimensionless.
    """

    symbol: str
    lo: float
    hi: float

    def text(self) -> str:
        return f"[{self.lo:g}, {self.hi:g}]"

    def holds(self, value: float) -> bool:
        return math.isfinite(value) and self.lo <= value <= self.hi


_LOAD = 1e5
#: The valid range of each dimensionless group (THEORY §5), by the name it has in a scene.
GROUP_RANGES = {
    "h": GroupRange("h", 0.0, 1e4),
    "h_pos": GroupRange("h_pos", 0.0, 1e4),
    "h_r": GroupRange("h_r", 0.0, 1e8),
    "fx": GroupRange("fx", -_LOAD, _LOAD),
    "p": GroupRange("p", -_LOAD, _LOAD),
    "tip_moment": GroupRange("tip_moment", -_LOAD, _LOAD),
    "qx": GroupRange("qx", -_LOAD, _LOAD),
    "qy": GroupRange("qy", -_LOAD, _LOAD),
}


def group_problem(name: str, value: float) -> Optional[str]:
    """What is wrong with ``value`` for the group ``name``, or None when it is in range."""
    rng = GROUP_RANGES[name]
    if rng.holds(value):
        return None
    return f"must be a finite number in {rng.text()}, got {value:g}"


def scene_group_values(scene) -> Iterable[Tuple[str, float]]:
    """``(group name, value)`` of every group a :class:`~actuator_design.scene.Scene` sets."""
    yield "h", scene.h
    yield "h_pos", scene.h_pos
    if scene.magnetization is not None:
        yield "h_r", scene.h_r
    if scene.tip_force is not None:
        yield "fx", scene.tip_force[0]
        yield "p", scene.tip_force[1]
    if scene.tip_moment is not None:
        yield "tip_moment", scene.tip_moment
    if scene.distributed_load is not None:
        yield "qx", scene.distributed_load[0]
        yield "qy", scene.distributed_load[1]


def unknowns(transcription: str, elements: int, degree: int) -> int:
    """Free unknowns θ_i of a transcription (the clamp node is eliminated)."""
    return int(elements) * (int(degree) if transcription == "lgl" else 1)


def mesh_problem(transcription: str, elements: int, degree: int, dense: bool = False) -> Optional[str]:
    """Why this mesh is too large for the memory budget (≈ 1 GB), or None.

    Parameters
    ----------
    transcription : {"lgl", "midpoint"}
    elements, degree : int
        Mesh size (``degree`` is ignored by ``midpoint``).
    dense : bool
        The scene has a non-uniform field, which makes the Hessian dense.

    Returns
    -------
    str or None
        ``"elements must be <= ... "``: starts with the field to blame.
    """
    per = int(degree) if transcription == "lgl" else 1
    n = unknowns(transcription, elements, degree)
    what = f"{transcription} of degree {degree}" if transcription == "lgl" else "midpoint"
    if dense:
        if n <= MAX_DENSE_UNKNOWNS:
            return None
        return (f"elements must be <= {MAX_DENSE_UNKNOWNS // per} for {what} in a non-uniform field "
                f"(dense Hessian: at most {MAX_DENSE_UNKNOWNS} unknowns to stay under ~1 GB), "
                f"got {elements} ({n} unknowns)")
    band = 2 * (per if transcription == "lgl" else 1) + 1
    if n * band <= MAX_BANDED_ENTRIES:
        return None
    return (f"elements must be <= {MAX_BANDED_ENTRIES // (band * per)} for {what} (Hessian storage: "
            f"at most {MAX_BANDED_ENTRIES} entries to stay under ~1 GB), got {elements}")
