"""What the stages of :func:`~actuator_design.inverse.design.design` pass to each other, and the result they produce.

The pipeline is ``problem → screen → optimise → choose → verify → result`` (see :mod:`actuator_design.inverse.design`);
each arrow carries one of the small dataclasses below. Also here: the target geometry shared by
the stages (pose distance, the field-axis angle φ modulo π, the target tip angle modulo 2π).
All quantities are dimensionless (THEORY §5): lengths in rod lengths ℓ, angles in rad.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from actuator_design.config.limits import GROUP_RANGES
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.inverse.nlp import DesignNLP, DesignPoint, profile_bound
from actuator_design.model.scene import Scene
from actuator_design.physics.parameters import applied_field, designed_profiles, remanent_group
from actuator_design.physics.registry import is_builtin, term_class
from actuator_design.robust.tolerances import Tolerances

__all__ = ["DesignSettings", "check_h_max", "DesignResult", "DesignProblem", "Candidate", "ScreenedStart", "Optimised",
           "Choice", "Verification", "status_of", "normalise_phi", "phi_period", "normalise_tip_angle", "tip_error",
           "target_error", "effort", "rank", "canonical_target", "TARGET_DECIMALS"]


def _largest(p) -> float:
    """A designed profile's largest allowed bound (rad; π when its term states none)."""
    return p.design_bound if p.design_bound is not None else math.pi


def _with_profile_bounds(cls):
    """Add to ``cls`` one setting ``<name>_max`` (rad) per profile a built-in term lets a design vary,
    after ``p_max``, in the order of the lens, defaulting to the profile's own largest bound (its
    term's ``design_bound``): the terms declare their designed profiles, so the settings name none
    of them. A plug-in term's profile has no setting (whenever it is registered): its bound is its
    largest (:meth:`DesignSettings.profile_max`)."""
    bounds = {profile_bound(name): p for name, p in designed_profiles().items() if p.term is not None and is_builtin(term_class(p.term))}
    clash = set(bounds) & set(cls.__annotations__)
    if clash:
        raise TypeError(f"DesignSettings: a designed profile's bound {sorted(clash)} is already a setting")
    fields = list(cls.__annotations__.items())
    at = [name for name, _ in fields].index("p_max") + 1
    cls.__annotations__ = dict(fields[:at] + [(key, float) for key in bounds] + fields[at:])
    for key, p in bounds.items():
        setattr(cls, key, _largest(p))
    return cls


@dataclass(frozen=True, kw_only=True)  # keywords only: the profile bounds' fields come from the terms
@_with_profile_bounds
class DesignSettings:
    """Bounds and tolerances of a design (dimensionless, THEORY §5).

    Attributes
    ----------
    h_max : float
        Largest field group h allowed.
    p_max : float
        Largest |p| allowed when the tip load is designed.
    alpha_terms : int
        Legendre coefficients of each designed profile (smooth layouts with few parameters): the
        fibre angle α(s), and the remanent magnetisation angle β(s) when it is designed.
    <name>_max : float
        One per profile a design can vary (:func:`~actuator_design.physics.parameters.designed_profiles`):
        the largest |profile(s)| (rad), default the profile's own largest bound. ``alpha_max`` (π/2) is
        a fabrication limit on the fibre angle α(s); ``magnetization_max`` (π) bounds a designed
        magnetisation angle β(s) (THEORY §9).
    margin : float
        Required stability margin μ: λ_min(H_r, M) ≥ μ.
    clearance : float
        With obstacles: the distance (units of ℓ) the designed rod keeps from every obstacle beyond
        the contact gap, at the design and over the tolerance box (e.g. a wall's position
        tolerance); 0 lets the design graze an obstacle.
    reach_tol : float
        A target is reachable when the nearest pose is within this distance (units of ℓ).
    accept_tol : float
        The verified achieved tip must be within this distance of the target.
    ramp_steps : int
        Points of each leg (ramp, rotation) of a verification schedule; the path follower refines
        between them (steps of ≤ 1/4 of a leg segment and ≤ 0.5 rad of shape change).
    time_limit : float
        Wall-clock budget of the search (s): once spent, no further starting design is optimised
        (the ones done are kept and the message says so); each NLP is also capped in iterations
        (:mod:`actuator_design.inverse.nlp`), so the work of a design is bounded.
    tolerances : Tolerances
        The lab's tolerance box the design must hold over (default: field ±5 %, angle ±2°; an
        empty box skips the robustness stage).
    """

    h_max: float = 10.0
    p_max: float = 20.0
    alpha_terms: int = 4
    margin: float = 1e-2
    clearance: float = 0.0
    reach_tol: float = 1e-6
    accept_tol: float = 1e-3
    ramp_steps: int = 20
    time_limit: float = 120.0
    tolerances: Tolerances = field(default_factory=Tolerances)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """One clear ``ValueError`` naming the first setting outside its range (on construction,
        and so on :func:`dataclasses.replace`: the settings are frozen)."""
        check_h_max(self.h_max)
        profile_checks = []  # |profile(s)| <= bound, up to the profile's own largest bound
        for name, p in designed_profiles().items():
            bound, largest = self.profile_max(profile_bound(name)), _largest(p)
            profile_checks.append((profile_bound(name), 0 < bound <= largest + 1e-12,
                                   f"must lie in (0, {math.degrees(largest):g}] deg, got {math.degrees(bound):g} deg"))
        checks = (
            ("p_max", self.p_max >= 0 and math.isfinite(self.p_max), "must be a finite number >= 0"),
            *profile_checks,
            ("alpha_terms", isinstance(self.alpha_terms, (int, np.integer)) and 1 <= self.alpha_terms <= 12,
             "must be an integer in [1, 12]"),
            ("margin", self.margin >= 0 and math.isfinite(self.margin), "must be a finite number >= 0"),
            ("clearance", 0 <= self.clearance < 1, "must lie in [0, 1) rod lengths"),
            ("reach_tol", 0 < self.reach_tol < 1, "must lie in (0, 1) rod lengths"),
            # (a negative acceptance is allowed: nothing meets it, a way to test the verdicts)
            ("accept_tol", math.isfinite(self.accept_tol) and self.accept_tol < 1,
             "must be a finite number < 1 rod length"),
            ("ramp_steps", isinstance(self.ramp_steps, (int, np.integer)) and 2 <= self.ramp_steps <= 10_000,
             "must be an integer in [2, 10000]"),
            ("time_limit", 0 < self.time_limit <= 86400, "must lie in (0, 86400] s"),
            ("tolerances", isinstance(self.tolerances, Tolerances), "expected a tolerance box (Tolerances)"),
        )
        for name, ok, rule in checks:
            if not ok:
                value = getattr(self, name)
                raise ValueError(f"{name} {rule}" + ("" if "got" in rule else f", got {value!r}"))

    def bounds(self) -> Dict[str, float]:
        """The design's bounds by key: h_max, p_max and each designed profile's ``<name>_max``
        (:func:`~actuator_design.inverse.nlp.profile_bound`)."""
        return {"h_max": self.h_max, "p_max": self.p_max,
                **{profile_bound(n): self.profile_max(profile_bound(n)) for n in designed_profiles()}}

    def profile_max(self, key: str) -> float:
        """The bound ``key`` (``<name>_max``, rad) of a designed profile: the setting of that name, or
        for a plug-in term's profile (no setting) its largest bound."""
        return getattr(self, key) if hasattr(self, key) else _largest(designed_profiles()[key[:-len("_max")]])


def check_h_max(h_max: float) -> None:
    """h_max in (0, 1e4], the valid range of h (``config/limits.py``: a clamp layer of width ~1/h)."""
    hi = GROUP_RANGES["h"].hi
    if not (0 < h_max <= hi):
        raise ValueError(f"h_max must lie in (0, {hi:g}] (--h-max; the valid range of h: the clamp layer "
                         f"has width ~1/h), got {h_max:g}")


@dataclass
class DesignResult:
    """Outcome of :func:`~actuator_design.inverse.design.design`; :meth:`to_dict` is the ``design --json`` contract.

    ``schedule`` is the verified path from zero field, a list of ``{"h", "phi"[, "p"]}``; its angles
    are continuous (a rotating field is not wrapped), so its last φ may differ from ``design["phi"]``
    (reported in (−π/2, π/2]) by a multiple of π — the same field axis, as the energy depends on
    cos²(θ + α − φ) only.

    Invariant: ``success`` implies ``verified``, ``reachable``, ``stable`` and ``snap_free``;
    ``verified`` implies ``stable`` and ``snap_free``; the message says "verified by" exactly when
    ``verified``, and states the reason whenever ``success`` is False.
    """

    def __repr__(self) -> str:
        """One line: the verdict, the design (h, φ in rad) and the tip error (units of ℓ)."""
        d = self.design or {}
        return (f"DesignResult(status={status_of(self)!r}, success={self.success}, "
                f"vary={tuple(self.vary)}, h={d.get('h', float('nan')):.8g}, phi={d.get('phi', float('nan')):.6g}, "
                f"error={self.error:.3g}, verified={self.verified}, stable={self.stable})")


    success: bool
    reachable: bool
    verified: bool
    stable: bool
    snap_free: bool
    target: Tuple[float, ...]
    achieved: Dict[str, float]
    error: float
    design: Dict[str, object]
    vary: Tuple[str, ...]
    schedule: List[Dict[str, float]]
    message: str
    scene: Scene
    design_scene: Optional[Scene] = None
    forward: Optional[EquilibriumResult] = None
    path: object = None
    optima: List[Dict[str, object]] = field(default_factory=list)
    stability_margin: float = float("nan")
    alternatives: Dict[str, bool] = field(default_factory=dict)
    timings: Dict[str, float] = field(default_factory=dict)
    stiffness_target: Optional[float] = None
    achieved_stiffness: Optional[float] = None
    tolerances: Optional[Tolerances] = None
    robustness: object = None  # a design_robust_stage.RobustReport, or None when not evaluated
    #: "inaccurate" (the mesh does not resolve the design's state) or "failed" (a stage stopped on
    #: a numerical error) when set; otherwise derived from the flags (:func:`status_of`)
    status: str = ""
    mesh: Optional[Dict[str, object]] = None  # the mesh the design was made on (design_mesh.mesh_dict)
    #: with obstacles: how far the reported state keeps from each (:func:`~actuator_design.contact.clearance.clearances`)
    clearance: Optional[List[Dict[str, object]]] = None

    def to_dict(self) -> Dict[str, object]:
        tgt = {} if not self.target else {"x": self.target[0], "y": self.target[1]}
        if len(self.target) > 2:
            tgt["angle"] = self.target[2]
        if self.stiffness_target is not None:
            tgt["stiffness"] = self.stiffness_target
        out = {
            "success": bool(self.success), "reachable": bool(self.reachable),
            "verified": bool(self.verified), "stable": bool(self.stable), "snap_free": bool(self.snap_free),
            "target": tgt, "achieved": {k: float(v) for k, v in self.achieved.items()},
            "error": float(self.error), "design": self.design, "schedule": self.schedule,
            "vary": list(self.vary), "message": self.message, "status": status_of(self),
            "stability_margin": float(self.stability_margin), "optima": self.optima,
            "alternatives": self.alternatives, "timings_s": self.timings,
            "units": {"length": "rod length", "angle": "rad", "h": "dimensionless field group",
                      "p": "B0/l^2", "stiffness": "B0/l^3"},
        }
        if self.stiffness_target is not None:
            out["achieved_stiffness"] = self.achieved_stiffness
        if self.tolerances is not None:
            out["tolerances"] = self.tolerances.to_dict()
        out["robustness"] = None if self.robustness is None else self.robustness.to_dict()
        if self.mesh is not None:
            out["mesh"] = dict(self.mesh)
        if self.clearance is not None:
            out["clearance"] = [dict(c) for c in self.clearance]
        sc = self.scene.scales
        H = None
        if sc is not None and sc.h_per_field > 0 and math.isfinite(self.design.get("h", float("nan"))):
            H = self.design["h"] / sc.h_per_field  # h ∝ H0: the designed field scale in A/m
        elif sc is not None and "h" not in self.vary:  # the field magnitude is the scene's (no soft coupling)
            applied = applied_field(self.design_scene if self.design_scene is not None else self.scene)
            H = applied if applied is not None and applied > 0 else None
        if H is not None:
            # the designed field scale in A/m and as μ0H in mT
            out["physical"] = {"field_A_per_m": H, "stiffness_scale_N_per_m": sc.stiffness,
                               "field_mT": H * 4e-7 * math.pi * 1e3,
                               "tip_x_m": self.achieved.get("x", float("nan")) * sc.length,
                               "tip_y_m": self.achieved.get("y", float("nan")) * sc.length}
            if self.achieved_stiffness is not None:
                out["physical"]["stiffness_N_per_m"] = self.achieved_stiffness * sc.stiffness
        return out


def status_of(res: "DesignResult") -> str:
    """The ``status`` word of a design result: "success", "inaccurate" (the mesh does not resolve
    the design's state), "failed" (a stage stopped on a numerical error), "unreachable",
    "not_robust" (no design holds over the whole tolerance box), "not_verified" (no snap-free path
    from zero field), or "not_accepted" (verified, but the tip or stiffness misses the target)."""
    if res.status:
        return res.status
    if res.success:
        return "success"
    if not res.reachable:
        return "unreachable"
    if res.robustness is not None and not res.robustness.holds:
        return "not_robust"
    return "not_accepted" if res.verified else "not_verified"


# -- what flows between the stages -------------------------------------------------------------------
@dataclass(frozen=True)
class DesignProblem:
    """A validated design request: what every stage reads.

    target : () or (x, y) or (x, y, angle); the angle already normalised to (−π, π].
    stiffness : target tip stiffness dp/dv1 (B0/ℓ³) or None.
    base : the user's scene (with a tip-force term when a stiffness is asked for).
    variable_sets : the sets of design variables tried in order (one when the user chose).
    user_vary : whether the user chose the variables.
    fibres_fixed : the scene's fibre layout is the user's (kept unless ``alpha`` is varied).
    deadline : ``time.perf_counter()`` value after which no new start is optimised.
    seeds : designs found on another mesh (:class:`~actuator_design.inverse.mesh.Seed`), screened first.
    notes : what the request was changed to before any stage ran (said first in the message).
    """

    target: Tuple[float, ...]
    stiffness: Optional[float]
    base: Scene
    options: SolverOptions
    settings: DesignSettings
    variable_sets: Tuple[Tuple[str, ...], ...]
    user_vary: bool
    deadline: float
    fibres_fixed: bool = False
    seeds: Tuple[object, ...] = ()
    notes: Tuple[str, ...] = ()

    def rank(self, pt: DesignPoint):
        """Sort key: designs that reach the target first, by least effort; then by distance."""
        return rank(pt, self.target, self.settings, self.stiffness)


@dataclass
class Candidate:
    """One set of design variables with its prepared base scene and its (cached) design NLP."""

    vary: Tuple[str, ...]
    base: Scene
    nlp: DesignNLP


@dataclass
class ScreenedStart:
    """A starting design kept by the screen: its distance to the target, design vector d of shape
    (nd,), and the stable forward state z (θ at the nodes, shape (n_nodes,))."""

    distance: float
    d: np.ndarray
    z: np.ndarray


@dataclass
class Optimised:
    """The distinct local optima of one candidate, best first (see :meth:`DesignProblem.rank`)."""

    candidate: Candidate
    optima: List[DesignPoint]
    out_of_time: bool = False

    def reaches(self, problem: DesignProblem) -> bool:
        return bool(self.optima) and problem.rank(self.optima[0])[0] == 0


@dataclass
class Choice:
    """The chosen design: the best optimum, its candidate, its forward scene and the notes so far.

    A later stage (e.g. a robustness check) may replace ``point``/``scene`` and append notes.
    """

    point: DesignPoint
    candidate: Candidate
    scene: Scene
    reachable: bool
    notes: List[str]
    alternatives: Dict[str, bool]
    optima: List[Dict[str, object]]


@dataclass
class Verification:
    """What the independent verification found: the fresh forward solve, the loading path (None
    when no snap-free path reaches the design), its label, and the schedule followed."""

    forward: Optional[EquilibriumResult]
    path: object
    label: str
    schedule: List[Dict[str, float]]


# -- target geometry ---------------------------------------------------------------------------------
def normalise_phi(phi: float, period: float = math.pi) -> float:
    """φ's representative in (−period/2, period/2]: the soft-magnetic energy is π-periodic in φ (the
    field acts on its axis); with a hard-magnetic term the period is 2π (:func:`phi_period`)."""
    return float(phi - period * math.ceil((phi - period / 2) / period))


def phi_period(scene) -> float:
    """The period of the energy in the field angle φ: π, or 2π with a hard-magnetic term of h_r ≠ 0
    (−h_r cos(θ + β − φ) changes sign under H → −H, THEORY §9)."""
    return 2 * math.pi if remanent_group(scene) != 0.0 else math.pi


#: Decimal places a target pose is resolved to (rod lengths, rad): 1e-12, far below every
#: tolerance of a design (reach_tol, accept_tol, the discretisation error), so one request written
#: two ways — 0.6 or 12 mm / 20 mm = 0.6000000000000001, a target moved by an ulp — is one problem.
TARGET_DECIMALS = 12


def canonical_target(target) -> tuple:
    """``target`` (x, y[, angle]) resolved to :data:`TARGET_DECIMALS` decimal places; -0.0 as 0.0."""
    return tuple(round(float(v), TARGET_DECIMALS) + 0.0 for v in target)


def normalise_tip_angle(angle: float) -> float:
    """A target tip angle modulo 2π, in [−π, π] (finite input; exact for any magnitude)."""
    return float(math.remainder(angle, 2.0 * math.pi))


def tip_error(tip, target) -> float:
    """Euclidean distance of tip (x, y[, angle]) from target (x, y[, angle]) (ℓ and rad mixed)."""
    e = [tip[0] - target[0], tip[1] - target[1]]
    if len(target) > 2:
        e.append(tip[2] - target[2])
    return float(np.linalg.norm(e))


def target_error(pt: DesignPoint, target, stiffness: Optional[float]) -> float:
    """Pose distance (units of ℓ) plus the relative stiffness error."""
    err = tip_error(pt.tip, target) if target else 0.0
    if stiffness is not None:
        k = getattr(pt, "stiffness", None)
        err += abs(k / stiffness - 1.0) if (k is not None and math.isfinite(k)) else np.inf
    return err


def effort(pt: DesignPoint) -> float:
    """The stage-B objective: h² + p² + the smoothness of each designed profile, α(s) and β(s)
    (Σ k²(k+1)²/4 c_k², cf. ∫α'²)."""
    def smoothness(c) -> float:
        k = np.arange(len(c), dtype=float)
        return float(np.sum(k**2 * (k + 1) ** 2 / 4.0 * np.asarray(c, float) ** 2))

    total = pt.h**2 + pt.p**2
    for coefficients in pt.profiles.values():  # in design order, as the NLP's effort
        total += smoothness(coefficients)
    return float(total)


def rank(pt: DesignPoint, target, settings: DesignSettings, stiffness: Optional[float] = None):
    """Designs that reach the target first, by least effort; the others by distance."""
    err = target_error(pt, target, stiffness)
    return (0, effort(pt)) if err <= settings.reach_tol else (1, err)
