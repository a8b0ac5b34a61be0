"""The applied fields a scene can hold: uniform, a point dipole, an expression, real magnets and coils.

Dimensionless (THEORY §5): positions in units of the rod length ℓ, the field in units of a field
scale H0 whose strength is the scene's group ``h``. Their CasADi models are
:mod:`actuator_design.physics.fields`' (and :mod:`~actuator_design.physics.harmonic`'s for fitted
sources); here they are plain frozen values, as a :class:`~actuator_design.model.scene.Scene` keeps
them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as dc_field
from dataclasses import replace
from typing import Any, Optional, Tuple, Union

import numpy as np

__all__ = ["UniformField", "DipoleField", "ExpressionField", "SourceField", "Field", "DIPOLE_CLOSE",
           "outside_region"]


@dataclass(frozen=True)
class UniformField:
    """Uniform applied field at angle ``phi`` (rad) to the undeformed rod axis c1.

    Its strength is the scene's group ``h`` (THEORY §5).
    """

    phi: float = 0.0
    kind: str = dc_field(default="uniform", init=False)
    is_uniform: bool = dc_field(default=True, init=False)


#: a failed solve whose shape comes closer than this to a point dipole (units of ℓ) was drawn onto it
DIPOLE_CLOSE = 0.1


@dataclass(frozen=True)
class DipoleField:
    """Field of a point dipole (a small permanent magnet) lying in the plane of the rod.

    Dimensionless: positions in units of ℓ; the field scale is H0 = |m| / (4π ℓ³), the field of the
    dipole on its axis-normal at distance ℓ, so that ĥ(ρ) = [3 (m̂·ρ̂) ρ̂ − m̂] / |ρ|³ with
    ρ = x − x0 (THEORY §3; a 3-D dipole evaluated in its own equatorial plane z = 0).

    Parameters
    ----------
    x0, y0 : float
        Dipole position, units of ℓ, clamp at the origin.
    moment_angle : float
        Direction of the moment m̂ in the plane, rad from c1.
    """

    x0: float = 0.5
    y0: float = -0.5
    moment_angle: float = 0.5 * math.pi
    kind: str = dc_field(default="dipole", init=False)
    is_uniform: bool = dc_field(default=False, init=False)

    def reach_note(self) -> Optional[str]:
        """What to know before solving, or None: the dipole lies within the rod's reach (|r0| < 1),
        where its field grows as 1/ρ³ with nothing to stop the rod."""
        reach = math.hypot(self.x0, self.y0)
        if not reach < 1.0:
            return None
        return (f"the point dipole at ({self.x0:.4g}, {self.y0:.4g}) lies within the rod's reach ({reach:.4g} < 1 rod "
                "length from the clamp): its field grows as 1/distance^3 and it has no body to stop the rod, so a "
                "rod drawn towards it has no equilibrium")

    def failure_note(self, x: np.ndarray, y: np.ndarray) -> Optional[str]:
        """Why a solve failed, or None: :meth:`reach_note`, when the reported shape (``x``, ``y``,
        units of ℓ) came within :data:`DIPOLE_CLOSE` of the dipole (a scene with obstacles is not asked)."""
        note = self.reach_note()
        if note is None or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            return None
        closest = float(np.min(np.hypot(np.asarray(x) - self.x0, np.asarray(y) - self.y0)))
        if not closest < DIPOLE_CLOSE:
            return None
        return (f"{note}; the shape reported comes within {closest:.3g} of it; place it farther than one rod "
                "length, or give the magnet's body (a field of type magnet) and an obstacle where it is")


@dataclass(frozen=True)
class ExpressionField:
    """A user field ĥ(x, y) = (hx, hy) given as expressions in x, y (units of ℓ).

    The expressions describe a z-invariant (two-dimensional) field; they are parsed by a whitelist
    parser (no ``eval``) and checked to be divergence- and curl-free over the disc the rod can
    reach (``actuator_design.physics.fields``). Its strength is scaled by the group ``h``.
    """

    hx: str = "1"
    hy: str = "0"
    kind: str = dc_field(default="expression", init=False)
    is_uniform: bool = dc_field(default=False, init=False)


def outside_region(terms, x: np.ndarray, y: np.ndarray) -> Optional[str]:
    """Why the points (x, y) (units of ℓ) are not all where every fit holds, or None (``terms``: the
    fitted expansions of :mod:`actuator_design.physics.harmonic`, each with its ``contains``)."""
    for k, t in enumerate(terms):
        inside = t.contains(x, y)
        if not np.all(inside):
            i = int(np.argmin(inside))
            rho = math.hypot(float(x[i]) - t.centre[0], float(y[i]) - t.centre[1])
            side = "closer to" if t.kind == "exterior" else "farther from"
            return (f"the rod comes {side} source {k + 1}'s centre than its field representation holds "
                    f"(at ({float(x[i]):.4g}, {float(y[i]):.4g}) rod lengths: distance {rho:.6g}, "
                    f"{'at least' if t.kind == 'exterior' else 'at most'} {t.valid_radius:.6g})")
    return None


@dataclass(frozen=True)
class SourceField:
    """The field of magnets and coils (:mod:`actuator_design.model.field_sources`), computed by magpylib and
    represented over the rod's reach by fitted solid harmonics (divergence- and curl-free by
    construction; :mod:`actuator_design.physics.harmonic`). Dimensionless: ĥ = H/H0, positions in ℓ.

    Parameters
    ----------
    terms : tuple of HarmonicTerm or TesseralTerm
        One fitted expansion per source (its region: its ``contains``).
    sources : tuple
        The SI source descriptions the fit was made from (MagnetSource, CoilSource).
    length : float
        ℓ (m) the fit was made for.
    fit_error, gradient_error : float
        Largest errors of ĥ and ∇ĥ ℓ against magpylib at random points of the reach and on
        the edges of the reach and of each fit's region (relative to H0).
    weights : tuple of float
        w_k: ĥ = Σ_k w_k ĥ_k, source k's fitted field scaled by w_k (a coil's current I_k = w_k × the
        current it was fitted at); empty: every w_k = 1. NLP parameters, so a design over coil
        currents re-solves without rebuilding (:mod:`actuator_design.hardware.current_design`).
    fit_tolerance : float
        The tolerance the fit was made to (relative to H0), for a refit at other currents.
    max_power : float
        Largest total power Σ R_k I_k² of the coils, W (inf: no limit given).
    max_field : float
        Largest |H| the rod may see, A/m (μ0 H in T; inf: no limit given).
    placements : tuple of (float, float, float)
        Per source a rigid move of its fitted field: (dx, dy) in units of ℓ and a turn (rad) about its
        own centre; empty: none. NLP parameters ``source_dx_k``, ``source_dy_k``, ``source_turn_k``, so a
        design over a magnet's pose re-solves without rebuilding
        (:mod:`actuator_design.hardware.pose_design`).
    """

    terms: Tuple[Any, ...]
    sources: Tuple[Any, ...] = ()
    length: float = 1.0
    fit_error: float = 0.0
    gradient_error: float = 0.0
    weights: Tuple[float, ...] = ()
    fit_tolerance: float = 1e-7
    max_power: float = math.inf
    max_field: float = math.inf
    placements: Tuple[Tuple[float, float, float], ...] = ()
    kind: str = dc_field(default="sources", init=False)
    is_uniform: bool = dc_field(default=False, init=False)

    def describe(self) -> str:
        """One line: the sources, the fits' orders and regions, the errors against magpylib."""
        if any(hasattr(src, "field_per_amp") for src in self.sources):  # coils of a calibration map
            t = self.terms[0]
            orders = ", ".join(f"{getattr(src, 'name', '?')} {t.order}" for src, t in zip(self.sources, self.terms))
            centre = ", ".join(f"{v * self.length * 1e3:.4g}" for v in t.centre)
            return (f"{len(self.sources)} coil{'s' if len(self.sources) > 1 else ''} of a calibration map, fitted with "
                    f"solid harmonics (orders {orders}), holding within {t.valid_radius * self.length * 1e3:.4g} mm "
                    f"of ({centre}) mm; fit error {self.fit_error:.2g} on held-out samples (field, relative to H0), "
                    "gradient not measured (a map has no gradient samples)")
        names = []
        for src, t in zip(self.sources, self.terms):
            kind = getattr(src, "shape", None) or getattr(src, "kind", "source")
            region = ("beyond" if t.kind == "exterior" else "within") + f" {t.valid_radius * self.length * 1e3:.4g} mm"
            names.append(f"{kind} {'magnet' if hasattr(src, 'shape') else 'coil'} (order {t.order}, "
                         f"holds {region} of its centre)")
        harmonics = "solid" if any(hasattr(t, "modes") for t in self.terms) else "zonal"
        return (f"{', '.join(names)} by magpylib, fitted with {harmonics} harmonics; fit error {self.fit_error:.2g} "
                f"(field), {self.gradient_error:.2g} (gradient) relative to H0")

    def source_weights(self) -> Tuple[float, ...]:
        """w_k of every source (1 where ``weights`` is empty)."""
        return tuple(float(w) for w in self.weights) if self.weights else (1.0,) * len(self.terms)

    def source_placements(self) -> Tuple[Tuple[float, float, float], ...]:
        """(dx, dy, turn) of every source ((0, 0, 0) where ``placements`` is empty); the coils of a
        calibration map move as one rig, with the first map coil's placement."""
        if not self.placements:
            return ((0.0, 0.0, 0.0),) * len(self.terms)
        places = [tuple(float(v) for v in p) for p in self.placements]
        rig = [k for k, src in enumerate(self.sources) if hasattr(src, "field_per_amp")]
        for k in rig[1:]:
            places[k] = places[rig[0]]
        return tuple(places)

    def placed_terms(self) -> Tuple[Any, ...]:
        """The fitted expansions where the sources are: each centre moved by (dx, dy), each axis
        turned by its turn (:meth:`source_placements`)."""
        return tuple(t if (dx, dy, turn) == (0.0, 0.0, 0.0) else
                     replace(t, centre=(t.centre[0] + dx, t.centre[1] + dy), axis_angle=t.axis_angle + turn)
                     for t, (dx, dy, turn) in zip(self.terms, self.source_placements()))

    def region_problem(self, x: np.ndarray, y: np.ndarray) -> Optional[str]:
        """Why points (units of ℓ) of a state lie where the fit does not hold, or None."""
        return outside_region(self.placed_terms(), np.asarray(x, float), np.asarray(y, float))


Field = Union[UniformField, DipoleField, ExpressionField, SourceField]
