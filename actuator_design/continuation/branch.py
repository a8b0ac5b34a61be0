"""What a continuation run returns: branches, their critical points, and the ``continue`` result.

:class:`Branch` (points in arclength order with stability, tip and energy), :class:`CriticalPoint`
(a fold or a branch point on it) and :class:`ContinuationResult` (the ``continue --json``
contract). Built by :class:`~actuator_design.continuation.follow.Continuation` from the engine's
:class:`~actuator_design.continuation.ContinuationBranch`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from actuator_design.model.scene import Scene
from actuator_design.physics.registry import describe_groups

__all__ = ["CriticalPoint", "Branch", "ContinuationResult"]


@dataclass
class CriticalPoint:
    """A fold (limit point) or a branch point on a branch.

    Attributes
    ----------
    kind : {"fold", "branch_point"}
    param : str
    value : float
        Parameter value λ* (units of the parameter).
    z : ndarray, shape (n_nodes,)
        θ at the nodes (rad).
    tip : dict
        ``x``, ``y`` (units of ℓ), ``angle`` = θ(1) (rad).
    morse_before, morse_after : int
        Morse index on the branch just before / after it.
    located : bool
        Located by root finding (True) or only bracketed (False, value interpolated).
    tangent : ndarray, shape (n_nodes,)
        Branch tangent (δu, δλ) there (W-normalised).
    """

    kind: str
    param: str
    value: float
    z: np.ndarray
    tip: Dict[str, float]
    morse_before: int
    morse_after: int
    located: bool = True
    tangent: Optional[np.ndarray] = field(default=None, repr=False)
    energy: float = float("nan")
    #: λ range that contains it: the step's end values widened by the arclength step (a bound on
    #: its uncertainty when not ``located``)
    interval: Optional[Tuple[float, float]] = None
    #: estimated discretisation error of ``value`` (units of the parameter; nan: not estimated, inf:
    #: not found on the finer mesh; JSON null for both),
    #: :func:`~actuator_design.continuation.branch_accuracy.critical_value_error`
    value_error: float = float("nan")

    def to_dict(self) -> dict:
        return {"kind": self.kind, "param": self.param, "value": float(self.value),
                self.param: float(self.value), "tip_angle": float(self.tip["angle"]),
                "tip": {k: float(v) for k, v in self.tip.items()}, "energy": float(self.energy),
                "morse_index_before": int(self.morse_before), "morse_index_after": int(self.morse_after),
                "located": bool(self.located),
                "value_error": float(self.value_error) if math.isfinite(self.value_error) else None}


@dataclass
class Branch:
    """One continued branch: N points (λ_k, z_k) in arclength order.

    Attributes
    ----------
    param : str
    lam : ndarray, shape (N,)
    z : ndarray, shape (N, n_nodes)
    morse_index : ndarray of int, shape (N,)
    min_eig : ndarray, shape (N,)
        Smallest eigenvalue of the mass-scaled reduced Hessian.
    stable : ndarray of bool, shape (N,)
    folds, branch_points : list of CriticalPoint
    status : str
        Why it stopped: ``"left_window"``, ``"max_points"``, ``"closed_loop"``,
        ``"step_too_small"``, or ``"touch"`` (a scene with obstacles: the rod touches one at the
        last point, :func:`~actuator_design.continuation.follow.continue_branch`).
    """

    param: str
    lam: np.ndarray
    z: np.ndarray
    morse_index: np.ndarray
    min_eig: np.ndarray
    folds: List[CriticalPoint]
    branch_points: List[CriticalPoint]
    status: str
    message: str
    stats: dict
    tips: np.ndarray = field(repr=False, default=None)  # (N, 3): angle, x, y
    energy: np.ndarray = field(repr=False, default=None)
    gamma: np.ndarray = field(repr=False, default=None)
    origin: Optional[str] = None

    @property
    def stable(self) -> np.ndarray:
        return self.morse_index == 0

    @property
    def tip_angle(self) -> np.ndarray:
        return self.tips[:, 0]

    def __len__(self) -> int:
        return self.lam.size

    def to_dict(self, shapes: bool = False) -> dict:
        pts = []
        for k in range(len(self)):
            d = {"value": float(self.lam[k]), self.param: float(self.lam[k]),
                 "tip_angle": float(self.tips[k, 0]), "tip_x": float(self.tips[k, 1]),
                 "tip_y": float(self.tips[k, 2]), "stable": bool(self.morse_index[k] == 0),
                 "morse_index": int(self.morse_index[k]), "energy": float(self.energy[k]),
                 "gamma": float(self.gamma[k])}
            if shapes:
                d["theta"] = self.z[k].tolist()
            pts.append(d)
        return {"param": self.param, "points": pts, "folds": [c.to_dict() for c in self.folds],
                "branch_points": [c.to_dict() for c in self.branch_points], "status": self.status,
                "message": self.message, "origin": self.origin, "stats": self.stats}


@dataclass
class ContinuationResult:
    """The branch from the start and, with switching, the branches bifurcating from it."""

    param: str
    branch: Branch
    secondary: List[Branch]
    scene: Scene
    window: tuple
    contact_path: Optional[Any] = None  # LoadingPath on from the first touch (status "touch")
    #: what the branch is and is not (e.g. a field group continued while the others it drives stay)
    notes: List[str] = field(default_factory=list)
    #: why the most demanding states of the branches miss the accuracy of a solve, or None (branch_accuracy)
    accuracy: Optional[str] = None

    @property
    def accurate(self) -> bool:
        """Whether the branch's end states meet the accuracy of a solve (:attr:`accuracy` is None)."""
        return self.accuracy is None

    @property
    def complete(self) -> bool:
        """Whether the window was covered: the branch ended at its end or closed on itself (not at a
        step too small, nor after its maximum number of points), or at a touch followed on with
        contact by a successful loading path."""
        if self.branch.status == "touch":
            return self.contact_path is not None and bool(self.contact_path.success)
        return self.branch.status not in ("step_too_small", "max_points")

    def to_dict(self) -> dict:
        """The ``continue --json`` contract: ``branch`` (points with the parameter value, tip angle,
        stable), ``folds`` and ``branch_points`` (value and tip angle each); ``contact_path``: the
        loading path with contact on from the first touch (``path --json``'s contract), or None;
        ``accurate`` and ``accuracy`` (why not, or None); ``success``: complete (not stopped by a too
        small step or by ``max_points``) and accurate (a study records a branch that is not as not
        converged)."""
        b = self.branch.to_dict()
        return {"param": self.param, "window": list(self.window), "branch": b["points"],
                "folds": b["folds"], "branch_points": b["branch_points"], "status": b["status"],
                "message": b["message"], "stats": b["stats"],
                "secondary_branches": [s.to_dict() for s in self.secondary],
                "groups": describe_groups(self.scene),
                "contact_path": None if self.contact_path is None else self.contact_path.to_dict(),
                "complete": self.complete, "notes": list(self.notes),
                "accurate": self.accurate, "accuracy": self.accuracy,
                "success": bool(self.complete and self.accurate)}
