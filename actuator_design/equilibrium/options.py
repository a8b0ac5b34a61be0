"""Solver settings: which transcription, at what resolution, solved how."""
from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass
from typing import Optional, Tuple

from actuator_design.config.limits import mesh_problem  # the memory budget (README "Units and scenes")

__all__ = ["SolverOptions", "TRANSCRIPTIONS", "METHODS", "MAX_DEGREE", "STARTS", "MAX_LEVELS", "MAX_ITERATIONS"]

TRANSCRIPTIONS = ("lgl", "midpoint")
METHODS = ("ipopt", "newton", "fast")
#: Highest LGL degree (as in a config's ``solver.degree``): beyond it the nodes and the
#: differentiation matrix lose accuracy and one element's dense block dominates the Hessian.
MAX_DEGREE = 60
#: Starts of ``solve`` without an initial guess: the state reached from rest, or the straight rod.
STARTS = ("rest", "straight")
#: Most grading levels towards one end (element length 2^-40/E: far below any layer of h ≤ 1e4).
MAX_LEVELS = 40
MAX_SPLITS = 16  # extra element boundaries (contact points)
#: Most iterations of one solve (IPOPT's default is 3000; a converging Newton needs tens): bounds the
#: work a setting can cause.
MAX_ITERATIONS = 100_000


@dataclass(frozen=True)
class SolverOptions:
    """How an equilibrium is computed.

    Attributes
    ----------
    transcription : {"lgl", "midpoint"}
        ``"lgl"``: spectral elements on Legendre–Gauss–Lobatto nodes of polynomial ``degree``
        (high order); ``"midpoint"``: piecewise-linear θ with the midpoint rule (second order).
    elements : int
        Number of elements (``lgl``) or intervals (``midpoint``), ≥ 1, and at most what keeps the
        Hessian under ~1 GB (:mod:`actuator_design.config.limits`: 4·10⁵ banded entries, i.e.
        elements × degree × (2 degree + 1) for ``lgl`` and 3 × elements for ``midpoint``).
    degree : int
        Polynomial degree per element for ``lgl``, in [2, 60]; ignored by ``midpoint``.
    method : {"ipopt", "newton"}
        ``"ipopt"``: interior-point minimisation of the discrete energy with the clamp as a
        constraint. ``"newton"``: damped Newton on the discrete stationarity equations (fast warm
        re-solves; falls back to IPOPT when it fails).
    tol : float
        Convergence tolerance on the stationarity residual (dimensionless, scaled by the
        quadrature weights).
    max_iter : int
        Iteration limit.
    ensure_stable : bool
        When the solver stops at an unstable equilibrium (Morse index > 0), perturb along the most
        unstable eigenvector and re-solve, reporting that it did.
    accuracy : float or None
        Target tip error (units of ℓ and rad). When set, :func:`~actuator_design.equilibrium.pipeline.solve`
        picks the LGL resolution itself and reports an a-posteriori ``error_estimate`` from two
        resolutions (:mod:`actuator_design.equilibrium.accuracy`); ``transcription``, ``elements``,
        ``degree`` and ``tol`` are then chosen for it.
    jit : bool
        Compile the gradient/Hessian evaluation to machine code with the system C compiler
        (CasADi JIT; about 1 s more build time, several times faster evaluation). Falls back to
        CasADi's virtual machine, with a note in the result, when no compiler works.

    start : {"rest", "straight"}
        Where :func:`~actuator_design.equilibrium.pipeline.solve` starts when given no initial guess and no
        solver. ``"rest"`` (default): the state reached from rest, i.e. loads and field ramped
        together from zero with warm-started Newton steps (:mod:`actuator_design.continuation.from_rest`); the
        straight-rod start is solved as well (returned when it reaches the same state), and the
        result says when it reaches another stable state. ``"straight"``: the straight rod at the clamp angle.
    adapt : bool
        Let ``solve`` (no solver given) grade the mesh towards the clamp from the scene's boundary
        layer width (``clamp_levels``/``tip_levels`` raised as needed), and double its elements while
        the result misses ``residual_tol`` (at most 4 times,
        :data:`~actuator_design.equilibrium.acceptance.REFINE_DOUBLINGS`); the Euler–Lagrange
        residual is checked against ``residual_tol`` either way.
    residual_tol : float
        Accuracy asked for: the largest accepted Euler–Lagrange (moment balance) residual relative
        to the moment scale max(1, |clamp moment|, |clamp force|, |tip moment|); a result above it is
        ``success=False`` with ``status="inaccurate"``. Default 1e-4 for ``lgl``; the midpoint rule
        (second order) is held to max(residual_tol, 10/N).
    clamp_levels, tip_levels : int
        Geometric grading of the ``lgl`` mesh towards the clamp/tip (see
        :class:`~actuator_design.transcription.lgl.LGL`), in [0, 40].
    split_at : tuple of float
        Extra ``lgl`` element boundaries in (0, 1) (at most 16): where a point force (a contact)
        kinks θ', so that each side is one polynomial (:mod:`actuator_design.contact.equilibrium` sets them).
    keep_self_intersecting : bool
        Accept a self-intersecting shape as a result (no self-contact); by default it is solved with
        self-contact (``self_contact``) or, without, ``success=False`` with ``status="self_intersecting"``.
    self_contact : bool
        Solve a shape that would cross itself (or come closer to itself than the rod's thickness,
        2·``Scene.contact_gap``) as a self-contact equilibrium reached from rest
        (:mod:`actuator_design.contact.self_contact`; the scene needs ``contact_gap`` > 0, the rod's
        half-thickness); False: refuse it as ``"self_intersecting"`` (the behaviour before self-contact).

    Notes
    -----
    ``method="fast"``: full Newton steps on the stationarity equations with the exact Hessian,
    evaluated through CasADi's low-overhead buffer interface and solved by LAPACK (dense or banded);
    every step must reduce the residual, otherwise it falls back to ``"newton"`` (and that to
    IPOPT). Meant for warm re-solves; the stability verdict is still computed.
    """

    transcription: str = "lgl"
    elements: int = 4
    degree: int = 10
    method: str = "ipopt"
    tol: float = 1e-10
    max_iter: int = 200
    ensure_stable: bool = True
    jit: bool = False
    accuracy: Optional[float] = None
    start: str = "rest"
    adapt: bool = True
    residual_tol: float = 1e-4
    clamp_levels: int = 0
    tip_levels: int = 0
    keep_self_intersecting: bool = False
    self_contact: bool = True
    split_at: Tuple[float, ...] = ()

    def __post_init__(self):
        if self.transcription not in TRANSCRIPTIONS:
            raise ValueError(f"transcription must be one of {TRANSCRIPTIONS}, got {self.transcription!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if int(self.elements) < 1:
            raise ValueError(f"elements must be >= 1, got {self.elements}")
        if self.transcription == "lgl" and not 2 <= int(self.degree) <= MAX_DEGREE:
            raise ValueError(f"degree must be in [2, {MAX_DEGREE}] for lgl, got {self.degree}")
        if self.start not in STARTS:
            raise ValueError(f"start must be one of {STARTS}, got {self.start!r}")
        if not (0 < self.residual_tol < 1):
            raise ValueError(f"residual_tol must lie in (0, 1), got {self.residual_tol}")
        for name in ("clamp_levels", "tip_levels"):
            if not 0 <= int(getattr(self, name)) <= MAX_LEVELS:
                raise ValueError(f"{name} must lie in [0, {MAX_LEVELS}], got {getattr(self, name)}")
        if not (0 < self.tol < 1):
            raise ValueError(f"tol must lie in (0, 1), got {self.tol}")
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, numbers.Integral) \
                or not 1 <= self.max_iter <= MAX_ITERATIONS:
            raise ValueError(f"max_iter must be an integer in [1, {MAX_ITERATIONS}], got {self.max_iter!r}")
        split = tuple(float(v) for v in self.split_at)
        if len(split) > MAX_SPLITS or not all(math.isfinite(v) and 0.0 < v < 1.0 for v in split):
            raise ValueError(f"split_at: at most {MAX_SPLITS} arc lengths in (0, 1), got {self.split_at}")
        object.__setattr__(self, "split_at", tuple(sorted(set(split))))
        if self.accuracy is None:
            mesh = (self.transcription, int(self.elements) + self.extra_elements, int(self.degree))
            problem = mesh_problem(*mesh)  # memory only: the tool picks meshes finer than a user may
            if problem is not None:  # over budget anyway: name the binding cap, rounding included
                raise ValueError(mesh_problem(*mesh, tol=self.tol) or problem)
        if self.accuracy is not None and not (0 < self.accuracy < 1):
            raise ValueError(f"accuracy must lie in (0, 1) (a tip error in rod lengths/rad), got {self.accuracy}")

    @property
    def extra_elements(self) -> int:
        """Elements added by grading (``lgl`` only)."""
        return (int(self.clamp_levels) + int(self.tip_levels) + len(self.split_at)
                if self.transcription == "lgl" else 0)

    def as_dict(self) -> dict:
        return asdict(self)
