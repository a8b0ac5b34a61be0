"""Continuation settings: one frozen object that validates itself (BifurcationKit's ContinuationPar)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

__all__ = ["ContinuationSettings"]


@dataclass(frozen=True)
class ContinuationSettings:
    """How far and how finely to continue.

    Attributes
    ----------
    ds : float
        Initial step: arclength in the metric W = diag(M, 1) for PALC, |Δλ| for Natural.
    ds_min, ds_max : float
        Smallest step before giving up (status ``"step_too_small"``) and largest step.
    max_steps : int
        Maximum number of points on the branch (the start included), ≥ 2.
    window : (float, float)
        λ interval; the branch ends on its edge (status ``"left_window"``). Infinite ends allowed.
    direction : {+1, −1}
        Sign of dλ at the start (ignored when a start tangent is given).
    tol : float
        Corrector stationarity tolerance, max_i |g_i| / m_i.
    arc_tol : float
        Tolerance of the arclength (or λ) constraint.
    max_corrector_iter : int
        Newton steps per corrector.
    min_cos_turn : float
        A step whose tangent turns by more than arccos(min_cos_turn) is halved, in [−1, 1)
        (−1: never).
    grow_iterations, shrink_iterations : int
        After a corrector of ≤ ``grow_iterations`` Newton steps the step grows by 1.5 (up to
        ds_max); after ≥ ``shrink_iterations`` it shrinks by 0.6.
    max_du, max_dlam : float
        Largest change of any unknown, max_i |Δu_i| (rad), and of λ per step (``inf``: no bound):
        the predictor is shortened to respect both, and a corrected step that moves an unknown
        further than ``max_du`` is halved. Loading paths bound the nodal angle change and the
        segment fraction per step this way.

    Raises
    ------
    ValueError
        Naming the field and its allowed range.
    """

    ds: float = 0.05
    ds_min: float = 1e-7
    ds_max: float = 0.5
    max_steps: int = 2000
    window: Tuple[float, float] = (-math.inf, math.inf)
    direction: float = 1.0
    tol: float = 1e-10
    arc_tol: float = 1e-9
    max_corrector_iter: int = 8
    min_cos_turn: float = 0.95
    grow_iterations: int = 2
    shrink_iterations: int = 5
    max_du: float = math.inf
    max_dlam: float = math.inf

    def __post_init__(self):
        for name in ("ds", "ds_min", "ds_max", "tol", "arc_tol"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"{name}: must be a finite number > 0, got {v!r}")
        for name in ("max_du", "max_dlam"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or math.isnan(v) or v <= 0:
                raise ValueError(f"{name}: must be a number > 0 (inf: no bound), got {v!r}")
        if self.ds_min > self.ds:
            raise ValueError(f"ds_min: must be <= ds = {self.ds:g}, got {self.ds_min:g}")
        if self.ds_min > self.ds_max:
            raise ValueError(f"ds_max: must be >= ds_min = {self.ds_min:g}, got {self.ds_max:g}")
        for name, low in (("max_steps", 2), ("max_corrector_iter", 1), ("grow_iterations", 0),
                          ("shrink_iterations", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise ValueError(f"{name}: must be an integer >= {low}, got {v!r}")
        try:
            lo, hi = (float(w) for w in self.window)
        except (TypeError, ValueError):
            raise ValueError(f"window: must be two numbers (lo, hi) with lo <= hi, got {self.window!r}") from None
        if math.isnan(lo) or math.isnan(hi) or not lo <= hi:
            raise ValueError(f"window: must be two numbers (lo, hi) with lo <= hi, got {self.window!r}")
        object.__setattr__(self, "window", (lo, hi))
        if self.direction not in (1, -1):
            raise ValueError(f"direction: must be +1 or -1, got {self.direction!r}")
        if not -1.0 <= self.min_cos_turn < 1.0:
            raise ValueError(f"min_cos_turn: must be in [-1, 1), got {self.min_cos_turn!r}")
