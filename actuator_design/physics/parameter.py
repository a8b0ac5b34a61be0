"""One entry of the parameter lens as a term declares it: a named, unit-carrying scene value.

A leaf module: the energy terms (:mod:`~actuator_design.physics.terms`, the shipped
:mod:`~actuator_design.physics.extra_terms`, a user's term) declare their parameters with
:class:`Parameter` and :func:`plugin_parameter`; the lens (:mod:`~actuator_design.physics.parameters`)
collects them from the registered terms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Optional, Tuple

import numpy as np

from actuator_design.model.scene import Scene

__all__ = ["Parameter", "THETA0", "plugin_parameter"]


@dataclass(frozen=True)
class Parameter:
    """A named, unit-carrying scene value seen through one lens.

    Attributes
    ----------
    name : str
        Name used by the API, the CLI and configs (e.g. ``"h2"``).
    description : str
        Meaning, one line.
    unit : str
        Dimensionless unit (THEORY §5): ``"1"``, ``"rad"``, ``"B0/l"``, ``"B0/l^2"``, ``"B0/l^3"``.
    slot : str
        The NLP parameter slot it sets (``h2`` sets slot ``h``).
    read : callable (Scene) -> float
        The value in a scene (0 when its term is absent).
    write : callable (Scene, float) -> Scene
        A copy with the value set (no validation; :meth:`set` validates and adds the term).
    term : str or None
        Name of the energy term whose slot it sets (``None``: the clamp, always present).
    lower, upper : float
        Valid closed range.
    transform : {"identity", "sqrt"}
        Slot value as a function of the parameter value.
    field_power : int
        The value is ∝ H^field_power (0: independent of the applied field).
    field_magnitude : bool
        Setting it sets the field magnitude (``h``, ``h2``): other field-scaled values follow.
    residual : {None, "linear", "squared"}
        How the slot value enters the stationarity residual scale (forces ∝ value or value²).
    per_point : bool
        The slot spans every quadrature point (a constant profile such as ``alpha``).
    ensure : callable (Scene) -> Scene, optional
        Adds the needed term at value zero (or raises ValueError when the scene cannot have it).
    designable : bool
        A variable of the inverse design (a profile α(s) when ``per_point``).
    stiffness_power : float
        The value is ∝ B0^stiffness_power with every other input fixed (B0 = E I, THEORY §5: loads
        and h_r ∝ 1/B0, h ∝ B0^-½): how a change of Young's modulus moves it (robust design's
        ``youngs_modulus`` tolerance, a fit of E).
    susceptibility_power : float
        The value is ∝ χ^susceptibility_power (h ∝ χ̄^½; the ``chi_bar`` tolerance).
    remanent_field : bool
        The value is a remanent-magnetisation group ∝ H (THEORY §9): on a physical scene it reads as
        the applied field μ0 H through the rod's remanence, not through its susceptibility.
    profile_label : str or None
        What a designed profile of this parameter (``per_point``) is called in a summary
        (``"fibres"`` for α(s)); its symbol there is :attr:`slot`.
    flag_help : str or None
        The help of the parameter's own command-line flag on every scene command (``--<name>``, an
        angle as ``--<name>-deg`` in degrees; :attr:`flag`); None: set it with ``--set`` only.
    profile : callable (Scene) -> Profile, optional
        A ``per_point`` parameter's whole profile in a scene (α(s): the fibres; β(s): the
        magnetisation), what a design replaces by a Legendre series.
    with_profile : callable (Scene, Profile) -> Scene, optional
        A copy of the scene with that profile replaced.
    design_bound : float or None
        A designed profile's (``per_point`` and :attr:`designable`) largest allowed bound on its size,
        |profile(s)| ≤ bound (rad), which is also the design's default bound
        (``DesignSettings.<name>_max``: π/2 for the fibre angle α, π for a magnetisation angle β).
    layer_power : float or None
        The end layers this value makes narrow with it: their wavenumber grows as |value|^layer_power
        (1 for h, a clamp layer of width ~1/h; ½ for h_r, ~1/√h_r; THEORY §5, §9). None: it makes
        none, or does not say. (The fit's check of a header's unit: a value whose layer is thinner
        than 1 % of the rod is implausible, :mod:`actuator_design.calibration.plausibility`.)
    conjugate : {"x", "y", "angle"} or None
        The free end's quantity a dead end load is work-conjugate to (a tip force's components, a
        tip moment): the tip stiffness's loads (:mod:`actuator_design.analysis.stiffness`); None:
        none (an alias such as ``p`` of ``fy`` declares none).
    mirror : float or None
        The factor the value takes when the plane is reflected in the rod's axis (y → −y, θ → −θ:
        +1 for h, −1 for φ, a y-load, the tip moment, a profile α(s) or β(s) is negated); None: no
        exact mirror is known (a scene where its term is present has none).
    design_check : callable (Scene) -> str or None, optional
        Why the inverse design cannot vary this parameter on a scene (one clause for the message
        ``--vary <name>: <clause>``), or None when it can.
    scene_range : (float, float) or None
        The closed range a scene's value must lie in for the solver to honour it (checked for every
        scene from a config or the command line, ``config/limits.py``; e.g. h ≤ 1e4: the clamp
        layer of width ~1/h must stay resolvable, THEORY §5), when narrower than [lower, upper];
        None: [lower, upper] (:attr:`valid_range`).
    """

    name: str
    description: str
    unit: str
    slot: str
    read: Callable[[Scene], float]
    write: Callable[[Scene, float], Scene]
    term: Optional[str] = None
    lower: float = -math.inf
    upper: float = math.inf
    transform: str = "identity"
    field_power: int = 0
    field_magnitude: bool = False
    residual: Optional[str] = None
    per_point: bool = False
    ensure: Optional[Callable[[Scene], Scene]] = None
    designable: bool = False
    stiffness_power: float = 0.0
    susceptibility_power: float = 0.0
    remanent_field: bool = False
    profile_label: Optional[str] = None
    flag_help: Optional[str] = None
    scene_range: Optional[Tuple[float, float]] = None
    profile: Optional[Callable[[Scene], Any]] = None
    with_profile: Optional[Callable[[Scene, Any], Scene]] = None
    design_check: Optional[Callable[[Scene], Optional[str]]] = None
    mirror: Optional[float] = None
    conjugate: Optional[str] = None
    design_bound: Optional[float] = None
    layer_power: Optional[float] = None

    @property
    def valid_range(self) -> Tuple[float, float]:
        """The closed range a scene's value must lie in (:attr:`scene_range`, else [lower, upper])."""
        return self.scene_range if self.scene_range is not None else (self.lower, self.upper)

    def range_problem(self, value: float) -> Optional[str]:
        """What is wrong with a scene's ``value`` of this parameter (not finite, or outside
        :attr:`valid_range`), or None when it is in range."""
        lo, hi = self.valid_range
        if math.isfinite(value) and lo <= value <= hi:
            return None
        return f"must be a finite number in [{lo:g}, {hi:g}], got {value:g}"

    @property
    def flag(self) -> str:
        """Its command-line flag (``--h-r``; an angle in degrees: ``--magnetization-deg``)."""
        return "--" + self.name.replace("_", "-") + ("-deg" if self.unit == "rad" else "")

    # -- values --------------------------------------------------------------------------------
    def get(self, scene: Scene) -> float:
        """The value in ``scene`` (units of :attr:`unit`)."""
        return float(self.read(scene))

    def validate(self, value) -> float:
        """``value`` as a float; ValueError naming the parameter and its range otherwise."""
        try:
            if isinstance(value, str) and "_" in value:  # Python's 1_000 is no number a user writes
                raise ValueError
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{self.name}: must be a number, got {value!r}") from None
        if not math.isfinite(v):
            raise ValueError(f"{self.name}: must be finite, got {value!r}")
        if v < self.lower:
            raise ValueError(f"{self.name}: must be >= {self.lower:g}, got {v:g}")
        if v > self.upper:
            raise ValueError(f"{self.name}: must be <= {self.upper:g}, got {v:g}")
        return v

    def require(self, scene: Scene) -> Scene:
        """``scene`` with the term this parameter needs (added at value zero if absent)."""
        return self.ensure(scene) if self.ensure is not None else scene

    def set(self, scene: Scene, value) -> Scene:
        """A copy of ``scene`` with this parameter at ``value`` (validated; the term added)."""
        return self.write(self.require(scene), self.validate(value))

    # -- the NLP slot --------------------------------------------------------------------------
    def to_slot(self, value):
        """Slot value(s) from parameter value(s) (numpy; negative ``h2`` clipped to 0)."""
        if self.transform == "sqrt":
            return np.sqrt(np.maximum(value, 0.0))
        return value

    def slot_expr(self, symbol):
        """The slot as a CasADi expression of a parameter symbol (``h2``: √λ, so h² = λ exactly)."""
        if self.transform == "sqrt":
            import casadi as ca
            return ca.sqrt(symbol)
        return symbol

    def describe(self) -> str:
        """``description (unit; range)`` for help texts and CSV headers."""
        rng = []
        if self.lower > -math.inf:
            rng.append(f">= {self.lower:g}")
        if self.upper < math.inf:
            rng.append(f"<= {self.upper:g}")
        return f"{self.description} ({self.unit}{'; ' + ', '.join(rng) if rng else ''})"


THETA0 = Parameter("theta0", "clamp angle theta0", "rad", "theta0",
                   read=lambda sc: sc.theta0, write=lambda sc, v: replace(sc, theta0=v), mirror=-1.0)


def plugin_parameter(term: str, slot: str, description: str, unit: str = "1", *,
                     name: Optional[str] = None, lower: float = -math.inf, upper: float = math.inf,
                     residual: Optional[str] = None, field_power: int = 0,
                     stiffness_power: float = 0.0, flag_help: Optional[str] = None) -> Parameter:
    """A parameter of a plug-in term whose value lives in the scene's ``extra_terms``.

    Setting it adds the term (its other values 0) when the scene does not have it. ``unit`` is its
    dimensionless unit (``"B0/l^4"`` for a stiffness per area); ``stiffness_power`` e says the value
    is ∝ B0^e (−1 for a value given in units of B0, THEORY §5). ``flag_help`` gives it its own flag
    on every scene command (:attr:`Parameter.flag`).
    """
    def read(sc: Scene) -> float:
        return float((sc.term_values(term) or {}).get(slot, 0.0))

    def write(sc: Scene, v: float) -> Scene:
        return sc.with_term(term, **{slot: v})

    def ensure(sc: Scene) -> Scene:
        return sc if sc.term_values(term) is not None else sc.with_term(term)

    return Parameter(name or slot, description, unit, slot, read, write, term=term, lower=lower,
                     upper=upper, residual=residual, field_power=field_power, ensure=ensure,
                     stiffness_power=stiffness_power, flag_help=flag_help)
