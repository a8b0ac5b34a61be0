"""The energy-term protocol: what a term of the dimensionless rod energy (THEORY §4–5) declares about
itself, and the functions that read a list of terms (their NLP slots, per-point fields, residual
scales). A leaf below the term modules: the built-in terms (:mod:`.terms`, :mod:`.hard_magnetic`), the
shipped :mod:`.extra_terms` and a user's term subclass :class:`EnergyTerm`.

The total energy is Ê[θ] = ∫₀¹ Σ density(kinematics) ds + Σ tip(tip kinematics). A term reads the
rod through a kinematics object (:mod:`.kinematics`: directors, curvature and — only if it asks —
positions), scalar NLP parameters (``scalar_params``) and per-quadrature-point fields
(``node_fields``: name -> how a scene evaluates it at arc lengths s, e.g. the fibre angle α and the
relative stiffness b).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, List, NamedTuple, Optional, Tuple

import casadi as ca
import numpy as np

from actuator_design.model.scene import Scene
from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.physics.parameter import Parameter

__all__ = ["EnergyTerm", "TermSummary", "TermProfile", "ShootingPart", "NodeField", "structure_key",
           "scalar_parameter_values", "node_field_sources", "node_field_values", "residual_slots", "snap_zero", "zero_potential"]

NodeField = Callable[[Scene, np.ndarray], np.ndarray]


class TermProfile(NamedTuple):
    """A profile a term carries, as a scene's summary shows it."""

    key: str  #: its key in ``validate --json`` (``"magnetization"``)
    label: str  #: the summary's label (``"magnetisation: remanent"``)
    profile: object  #: the :class:`~actuator_design.model.profiles.Profile`
    symbol: str  #: its symbol (``"beta"``)
    angle: bool  #: values in rad, shown in degrees


def zero_potential(theta):
    """The part V(θ) = 0 of a term that adds nothing to the first integral (shaped like θ)."""
    return 0.0 * np.asarray(theta, float)


def snap_zero(v):
    """Trigonometric values within 4 ε of 0 as exact zeros (φ = π/2 given as a float is then exactly
    symmetric)."""
    v = np.asarray(v, float)
    return np.where(np.abs(v) < 4 * np.finfo(float).eps, 0.0, v)


@dataclass(frozen=True)
class ShootingPart:
    """A term's part of the planar Euler–Lagrange equation in a uniform field, as the shooting scan
    integrates it (:mod:`actuator_design.analysis.shooting_scan`; THEORY §5, §7, §9): the moment
    M = b θ' obeys M' = h² sin 2(θ + α − φ) − n_y cos θ + n_x sin θ, n(s) the sum of the terms'
    internal forces, and the a-priori bounds on γ = θ'(0) add up the terms' numbers.

    Attributes
    ----------
    twofold : float
        h² of a two-fold torque h² sin 2(θ + α(s) − φ) (the χ̄ term), 0 for none.
    twofold_angle : callable (s) -> ndarray, optional
        2(α(s) − φ) at arc lengths s, rad.
    force : callable (s) -> (ndarray, ndarray), optional
        The internal force (n_x, n_y)(s) it adds, units of B0/ℓ² (a dead tip force f, a distributed
        load's q (1 − s), a remanent torque written as a force).
    dead : bool
        ``force`` is a dead load's (bounded by :attr:`force_integral` and its largest size);
        False: a torque written as a force, bounded by :attr:`torque`.
    force_integral : float
        A bound on ∫₀¹ |n| ds of its dead force.
    torque : float
        A bound on its torque's size (the integral bound on γ).
    jacobi : float
        A bound on its part of the Jacobi coefficient |Q| (the growth exponent, THEORY §7).
    potential_max, spread : float
        The largest value of its part of the first integral (:meth:`EnergyTerm.phase_potential`)
        and that part's max − min, on an autonomous scene.
    autonomous : bool
        Its part does not depend on s (constant profiles, no distributed load).
    """

    twofold: float = 0.0
    twofold_angle: Optional[Callable[[np.ndarray], np.ndarray]] = None
    force: Optional[Callable[[np.ndarray], Tuple[np.ndarray, np.ndarray]]] = None
    dead: bool = True
    force_integral: float = 0.0
    torque: float = 0.0
    jacobi: float = 0.0
    potential_max: float = 0.0
    spread: float = 0.0
    autonomous: bool = True


@dataclass(frozen=True)
class TermSummary:
    """What a scene's summary (``actuator-design validate``) says of one term.

    Attributes
    ----------
    groups : tuple of (str, float)
        Its dimensionless groups as (name, value) (``("h_r", 2.0)``), shown after h and φ.
    load : str or None
        The load it applies, one phrase in units of B0 (``"tip moment 1 B0/l"``).
    profile : TermProfile or None
        A profile it carries (a remanent magnetisation β(s)).
    """

    groups: Tuple[Tuple[str, float], ...] = ()
    load: Optional[str] = None
    profile: Optional[TermProfile] = None


class EnergyTerm:
    """Interface of an energy term; subclasses override what they contribute.

    Attributes
    ----------
    name : str
        Unique registry name (also the name used in ``Scene.extra_terms`` for plug-ins).
    parameters : tuple of Parameter
        The lens parameters this term contributes (:mod:`actuator_design.physics.parameters`).
    scalar_params : tuple of str
        Scalar NLP slots it reads (instances may extend them, e.g. with a field's slots).
    node_fields : dict of str -> callable (Scene, s) -> ndarray
        Per-quadrature-point fields it reads, and how a scene evaluates them.
    """

    name = "term"
    #: every parameter states its power laws in the field, B0 and χ (``Parameter.field_power``,
    #: ``stiffness_power``, ``susceptibility_power``): analyses that rescale a scene (a fit of E, a
    #: tolerance box) may take the term
    scaling_declared = False
    #: its energy's θ-derivatives are 2π-periodic in θ (it reads θ through directors and positions,
    #: or is linear in θ like a tip moment): a clamp angle may then be solved whole turns away
    #: (:meth:`~actuator_design.equilibrium.solver.EquilibriumSolver.solve_ipopt`); False for a term
    #: that reads θ itself (a spring to an absolute angle)
    periodic_in_theta = False
    parameters: Tuple[Parameter, ...] = ()
    scalar_params: Tuple[str, ...] = ()
    #: what a summary in physical units calls the load this term applies (``"tip force"``); None:
    #: the term's name
    load_name: Optional[str] = None
    node_fields: Dict[str, NodeField] = {}

    # -- presence in a scene -------------------------------------------------------------------
    @classmethod
    def present(cls, scene: Scene) -> bool:
        """Whether ``scene`` contains this term (plug-ins: listed in ``scene.extra_terms``)."""
        return scene.term_values(cls.name) is not None

    @classmethod
    def from_scene(cls, scene: Scene) -> "EnergyTerm":
        """The term instance for a scene that contains it."""
        return cls()

    # -- energy ------------------------------------------------------------------------------
    def density(self, kin: PlanarKinematics, P: Dict[str, ca.SX]):
        """Energy per unit (dimensionless) length at each point, or ``None``."""
        return None

    def tip(self, tip: PlanarTip, P: Dict[str, ca.SX]):
        """Energy concentrated at the free end, or ``None``."""
        return None

    def values(self, scene: Scene) -> Dict[str, float]:
        """Numerical values of ``scalar_params`` for a scene (plug-ins: from ``extra_terms``)."""
        tv = scene.term_values(self.name) or {}
        return {k: float(tv.get(k, 0.0)) for k in self.scalar_params}

    def residual_scale(self) -> Dict[str, str]:
        """Slot -> ``"linear"`` or ``"squared"``: how its value sizes the stationarity residual."""
        return {p.slot: p.residual for p in self.parameters if p.residual}

    def structure(self) -> tuple:
        return (self.name,)

    # -- what the mesh and the memory budget need to know ----------------------------------------
    @classmethod
    def wavenumber(cls, scene: Scene) -> float:
        """The inverse of the shortest length on which this term makes θ vary (units of 1/ℓ; 0 when
        it sets none): the a-priori mesh grading (:func:`actuator_design.equilibrium.accuracy.scene_wavenumber`)."""
        return 0.0

    @classmethod
    def summary(cls, scene: Scene) -> TermSummary:
        """What a scene's summary says of this term (asked of every registered term: it decides
        itself whether it has anything to say about ``scene``)."""
        return TermSummary()

    @classmethod
    def result_groups(cls, scene: Scene) -> Dict[str, object]:
        """What a result's ``groups`` (``result.json``, ``validate --json``) says of this term: its
        dimensionless values by key, plain numbers and lists (asked of every registered term; a
        plug-in term present in ``scene``: its values under its name)."""
        values = scene.term_values(cls.name)
        return {} if values is None else {cls.name: values}

    @classmethod
    def end_force(cls, scene: Scene) -> Optional[Tuple[float, float]]:
        """The dead force (fx, fy) this term applies at the free end (units of B0/ℓ²; None when it
        applies none): drawn as an arrow at the tip."""
        return None

    @classmethod
    def end_moment(cls, scene: Scene) -> float:
        """The dead moment this term applies at the free end (units of B0/ℓ; 0 when none): it makes
        a boundary layer at the tip (mesh grading) and sizes the moment balance there."""
        return 0.0

    @classmethod
    def tip_layer(cls, scene: Scene) -> bool:
        """Whether this term makes a boundary layer at the free end: the curvature it prefers there
        is not the zero that a free end's θ'(1) = 0 imposes (a fibre angle or a magnetisation that
        varies along the rod, a field that varies in direction, a distributed load), so a strong
        term bends the rod back over a length 1/k next to the tip. The mesh is then graded there too
        (:func:`actuator_design.equilibrium.acceptance.graded_options`)."""
        return False

    @classmethod
    def phase_potential(cls, scene: Scene) -> Optional[Callable[[np.ndarray], np.ndarray]]:
        """This term's part V(θ) of the first integral H(θ, θ') = ½ b θ'² + Σ V(θ) of an autonomous
        scene (:mod:`actuator_design.analysis.phase`): its energy per unit length as a function of the
        tangent angle alone, sign reversed (a tip load's work written along the rod), vectorised over
        θ (units of B0/ℓ). None: the term has no such part (a scene with it has no phase portrait).

        Raises
        ------
        ValueError
            Naming the scene's value that makes the Euler–Lagrange equation depend on s (a varying
            profile, a non-uniform field).
        """
        return None

    @classmethod
    def shooting_part(cls, scene: Scene) -> Optional[ShootingPart]:
        """This term's part of the uniform-field Euler–Lagrange equation the shooting scan
        integrates (:class:`ShootingPart`); None: the term has none (the scan refuses the scene).

        Raises
        ------
        ValueError
            Naming what the scan cannot integrate (a non-uniform field).
        """
        return None

    @classmethod
    def dense_hessian(cls, scene: Scene) -> bool:
        """Whether this term couples every node with every other (energy products of positions), so
        the Hessian is dense and the mesh has the dense memory budget (:mod:`actuator_design.config.limits`)."""
        return False


def structure_key(terms: List[EnergyTerm]) -> tuple:
    """Hashable key of what is built symbolically: scenes with equal keys share one NLP."""
    return tuple(t.structure() for t in terms)


def scalar_parameter_values(terms: List[EnergyTerm], scene: Scene) -> Dict[str, float]:
    out = {"theta0": scene.theta0}
    for t in terms:
        out.update(t.values(scene))
    return {k: float(v) for k, v in out.items()}


def node_field_sources(terms: List[EnergyTerm]) -> Dict[str, NodeField]:
    """Per-point field name -> evaluator (Scene, s) -> values, over ``terms``, sorted by name."""
    out: Dict[str, NodeField] = {}
    for t in terms:
        for name, fn in t.node_fields.items():
            out.setdefault(name, fn)
    return dict(sorted(out.items()))


def node_field_values(terms: List[EnergyTerm], scene: Scene, s: np.ndarray) -> Dict[str, np.ndarray]:
    """The per-point fields ``terms`` read, evaluated for ``scene`` at arc lengths ``s``."""
    return {n: np.asarray(fn(scene, s), float) for n, fn in node_field_sources(terms).items()}


def residual_slots(terms: List[EnergyTerm]) -> Dict[str, str]:
    """Slot -> ``"linear"``/``"squared"`` over ``terms`` (their contribution to the residual scale)."""
    out: Dict[str, str] = {}
    for t in terms:
        out.update(t.residual_scale())
    return out
