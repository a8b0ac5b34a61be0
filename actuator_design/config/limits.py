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
plus numerical copies. Measured peak memory (Python 3.11, CasADi 3.6, uniform field; peak RSS of
``actuator-design solve``): midpoint 4000: 0.22 GB, 16 000: 0.51 GB, 30 000: 0.87 GB, 35 000:
0.99 GB, 40 000: 1.11 GB, 133 333: 3.44 GB; lgl × 10: 800: 0.62 GB, 1100: 0.81 GB, 1400: 1.01 GB,
1904: 1.29 GB. These fit
≈ 0.15 GB + :data:`BYTES_PER_UNKNOWN` · n + :data:`BYTES_PER_ENTRY` · n (2b + 1) within 5 %
(b = degree for ``lgl``, 1 for ``midpoint``: the Hessian's half band):

* terms local in θ (uniform field, tip loads, distributed loads): the Hessian is banded, and
  n is capped so that the model above stays within :data:`MEMORY_BUDGET` (≈ 0.85 GB above the
  interpreter's 0.15 GB);
* a non-uniform field (dipole, expression) couples every pair of nodes through the positions: the
  Hessian is dense, about 21 kB per entry (midpoint 125: 0.48 GB; 250: 1.6 GB), so at most
  :data:`MAX_DENSE_UNKNOWNS` = 200 unknowns (≈ 0.85 GB).

Rounding. The stationarity residual r = max_i |∂Ê/∂θ_i| / m_i of a converged state carries a
rounding floor ≈ K ε / Δ² (Δ the smallest node spacing, in rod lengths; measured K = 0.48–0.49 for
midpoint 35 000, 40 000 and 133 333, 1.9–2.3 for lgl 800, 1100, 1400 and 1904 × 10; used:
:data:`ROUNDING_K`, 0.5 and 3.5, the latter with 1.5 × more margin). Newton accepts
a residual at the rounding floor only up to 10⁴ × tol, so where the user picks a uniform mesh
(configuration and flags) one with K ε/Δ² > :data:`ROUNDING_MARGIN` × tol, which cannot be confirmed
on every machine (midpoint 133 333 stopped at 1.9e-6, lgl 1904 × 10 at 1.4e-6, both with tol
1e-10), is refused: at the default tol = 1e-10 midpoint up to 30 011 intervals, lgl of degree 10
up to 374 elements (a spectral mesh that fine is never needed: the accuracy driver's largest is 200).

Magnetic material properties (physical scenes, SI) must be physically plausible, so a unit slip
(``1e12 A/m``) is refused in one line instead of reaching the solver as an enormous group:

=============================================  ===========  =====================================
property                                       range        why
=============================================  ===========  =====================================
remanence M_r, remanent_flux_density / μ0,     [0, 3e6]     no material is magnetised beyond the
saturation_magnetization M_s, saturation_field  A/m         saturation of Fe65Co35, μ0 M_s ≈ 2.45 T
                                                            (M_s ≈ 1.95 MA/m); the strongest
                                                            permanent magnets (NdFeB) reach
                                                            B_r ≈ 1.4 T (M_r ≈ 1.1 MA/m)
chi_bar, chi_hat, particles.chi_par, chi_perp  [0, 1e6]     the largest relative permeability of
                                                            any material (supermalloy, μr ≈ 1e6)
=============================================  ===========  =====================================

The bounds are generous (about 1.5 times the strongest material) so that every real material,
and every preset of :mod:`actuator_design.physics.magnetic_composite`, passes; they live with the
material model (:data:`actuator_design.physics.magnetics_block.MAX_MAGNETIZATION`,
:data:`~actuator_design.physics.magnetics_block.MAX_SUSCEPTIBILITY`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Dict, Iterable, Iterator, Mapping, Optional, Tuple

import numpy as np
from numpy.polynomial import legendre

from actuator_design.physics import parameters as lens

__all__ = ["GroupRange", "GROUP_RANGES", "MAX_BANDED_ENTRIES", "MAX_DENSE_UNKNOWNS", "MEMORY_BUDGET",
           "BYTES_PER_UNKNOWN", "BYTES_PER_ENTRY", "ROUNDING_MARGIN", "ROUNDING_K", "smallest_spacing",
           "group_problem", "unknowns", "mesh_problem", "scene_group_values"]

#: Peak memory a banded (local-term) mesh may need above the interpreter's, bytes.
MEMORY_BUDGET = 0.85e9
#: Measured peak memory per free unknown and per Hessian entry (module docstring), bytes.
BYTES_PER_UNKNOWN = 18_200
BYTES_PER_ENTRY = 1_930
#: Largest number of Hessian entries for a banded Hessian (the budget at no per-unknown cost:
#: an upper bound kept for callers; :func:`mesh_problem` applies the full model).
MAX_BANDED_ENTRIES = int(MEMORY_BUDGET // BYTES_PER_ENTRY)
#: A uniform mesh is refused when its rounding floor K ε/Δ² exceeds this multiple of tol (Newton
#: accepts up to 10⁴ tol at the floor; 10 × margin for other machines and scenes).
ROUNDING_MARGIN = 1e3
#: Measured rounding floor of the residual in units of ε/Δ², by transcription (module docstring;
#: lgl measured at degree 10 as 1.9–2.3, taken as 3.5 for every degree).
ROUNDING_K = {"midpoint": 0.5, "lgl": 3.5}
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



class _GroupRanges(Mapping):
    """The valid range of each dimensionless group (THEORY §5), by its name in the parameter lens:
    every scalar parameter a term declares a range for (``Parameter.valid_range``), read from the
    registered terms when asked (a plug-in term registered later is seen too)."""

    def _ranges(self) -> Dict[str, GroupRange]:
        return {n: GroupRange(n, *p.valid_range) for n, p in lens.parameters().items()
                if not p.per_point and p.valid_range != (-math.inf, math.inf)}

    def __getitem__(self, name: str) -> GroupRange:
        return self._ranges()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._ranges())

    def __len__(self) -> int:
        return len(self._ranges())


#: The valid range of each dimensionless group (THEORY §5), by its lens name (``GROUP_RANGES["h"]``).
GROUP_RANGES: Mapping[str, GroupRange] = _GroupRanges()


def group_problem(name: str, value: float) -> Optional[str]:
    """What is wrong with ``value`` for the group ``name``, or None when it is in range."""
    rng = GROUP_RANGES[name]
    if rng.holds(value):
        return None
    return f"must be a finite number in {rng.text()}, got {value:g}"


def scene_group_values(scene) -> Iterable[Tuple[str, float]]:
    """``(group name, value)`` of every ranged group of a :class:`~actuator_design.model.scene.Scene`,
    one per NLP slot (``p`` for the vertical tip load, not its alias ``fy``), in registration order
    (0 where the scene lacks the term)."""
    slots = set()
    for name in GROUP_RANGES:
        p = lens.parameter(name)
        if p.slot not in slots:
            slots.add(p.slot)
            yield name, p.get(scene)


def unknowns(transcription: str, elements: int, degree: int) -> int:
    """Free unknowns θ_i of a transcription (the clamp node is eliminated)."""
    return int(elements) * (int(degree) if transcription == "lgl" else 1)


@functools.lru_cache(maxsize=None)
def _lgl_end_gap(degree: int) -> float:
    """The gap between the end node of [0, 1] and the next LGL node of degree ``degree`` (the first
    root of P'_d, as ``transcription.lgl.lgl_nodes_weights`` has it, computed here with numpy)."""
    if degree <= 1:
        return 1.0
    c = np.zeros(int(degree) + 1)
    c[-1] = 1.0
    first = float(np.min(np.real(legendre.legroots(legendre.legder(c)))))
    return (1.0 + first) / 2.0


def smallest_spacing(transcription: str, elements: int, degree: int) -> float:
    """The smallest node spacing of a uniform mesh, rod lengths.

    ``midpoint``: 1 / elements; ``lgl``: the gap between an element's end node and the next LGL
    node, times the element length 1 / elements.
    """
    if transcription != "lgl":
        return 1.0 / int(elements)
    return _lgl_end_gap(int(degree)) / int(elements)


def _largest_elements(ok, hi: int) -> int:
    """The largest e in [1, hi] with ok(e) (ok monotone: true up to a point)."""
    lo = 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        lo, hi = (mid, hi) if ok(mid) else (lo, mid - 1)
    return lo


def mesh_problem(transcription: str, elements: int, degree: int, dense: bool = False,
                 tol: Optional[float] = None) -> Optional[str]:
    """Why this mesh is too large for the memory budget (≈ 1 GB) or too fine for the rounding
    floor at ``tol`` (module docstring), or None.

    Parameters
    ----------
    transcription : {"lgl", "midpoint"}
    elements, degree : int
        Mesh size (``degree`` is ignored by ``midpoint``).
    dense : bool
        The scene's Hessian is dense (a non-uniform field, or a term whose energy couples every
        point: ``EnergyTerm.dense_hessian``).
    tol : float, optional
        The solver's stationarity tolerance (``SolverOptions.tol``): the rounding floor is checked
        against it (a mesh the user picks); None checks memory only (meshes the tool picks).

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
        return (f"elements must be <= {MAX_DENSE_UNKNOWNS // per} for {what} with a dense Hessian (a "
                f"non-uniform field, or a term coupling every point; at most {MAX_DENSE_UNKNOWNS} unknowns "
                f"to stay under ~1 GB), got {elements} ({n} unknowns)")
    band = 2 * per + 1

    def fits(e):
        return e * per * (BYTES_PER_UNKNOWN + band * BYTES_PER_ENTRY) <= MEMORY_BUDGET

    def rounds(e):
        floor = ROUNDING_K[transcription] * np.finfo(float).eps / smallest_spacing(transcription, e, degree) ** 2
        return tol is None or floor <= ROUNDING_MARGIN * tol

    if fits(elements) and rounds(elements):
        return None
    cap = _largest_elements(lambda e: fits(e) and rounds(e), int(elements))
    if not rounds(cap + 1):
        why = (f"at tol {tol:g}: finer meshes carry a rounding floor K ε/Δ² in the residual that tol "
               f"cannot confirm; a larger tol allows more")
    else:
        why = (f"peak memory from the measured model ≈ "
               f"{0.15 + n * (BYTES_PER_UNKNOWN + band * BYTES_PER_ENTRY) / 1e9:.2g} GB for {elements}; "
               f"the budget is ~1 GB")
    return f"elements must be <= {cap} for {what} ({why}), got {elements}"
