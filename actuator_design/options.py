"""Solver settings: which transcription, at what resolution, solved how."""
from __future__ import annotations

from dataclasses import asdict, dataclass

__all__ = ["SolverOptions", "TRANSCRIPTIONS", "METHODS"]

TRANSCRIPTIONS = ("lgl", "midpoint")
METHODS = ("ipopt", "newton")


@dataclass(frozen=True)
class SolverOptions:
    """How an equilibrium is computed.

    Attributes
    ----------
    transcription : {"lgl", "midpoint"}
        ``"lgl"``: spectral elements on Legendre–Gauss–Lobatto nodes of polynomial ``degree``
        (high order); ``"midpoint"``: piecewise-linear θ with the midpoint rule (second order).
    elements : int
        Number of elements (``lgl``) or intervals (``midpoint``), ≥ 1.
    degree : int
        Polynomial degree per element for ``lgl`` (≥ 2); ignored by ``midpoint``.
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
    """

    transcription: str = "lgl"
    elements: int = 4
    degree: int = 10
    method: str = "ipopt"
    tol: float = 1e-10
    max_iter: int = 200
    ensure_stable: bool = True

    def __post_init__(self):
        if self.transcription not in TRANSCRIPTIONS:
            raise ValueError(f"transcription must be one of {TRANSCRIPTIONS}, got {self.transcription!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if int(self.elements) < 1:
            raise ValueError(f"elements must be >= 1, got {self.elements}")
        if self.transcription == "lgl" and int(self.degree) < 2:
            raise ValueError(f"degree must be >= 2 for lgl, got {self.degree}")
        if not (0 < self.tol < 1):
            raise ValueError(f"tol must lie in (0, 1), got {self.tol}")

    def as_dict(self) -> dict:
        return asdict(self)
