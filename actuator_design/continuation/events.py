"""Events along a branch: what is detected on a step and how it is located.

* :class:`Fold` — a limit point: the λ-component of the tangent changes sign;
* :class:`BranchPoint` — an inertia change that is not a fold: the sign of det [G_x; tᵀW] changes
  (with a continuously oriented tangent it changes at a simple branch point, not at a fold);
* :class:`Snap`, :class:`StabilityLoss` — what a :class:`~.secant.Secant` run does at a fold (snap
  through it) and at a state that lost stability (refuse it, or leave along its unstable mode);
* :class:`UserEvent` — a sign change of a scalar function of the point on the branch
  (:class:`BranchState`), e.g. "the tip crosses the wall x = c".

All are located by one routine (``engine.locate_event``): ``brentq`` on the step's arclength σ, each
evaluation a corrected point, so the event is accurate to the corrector tolerance. An event made
with ``stop=True`` ends the run where it is located inside the window (status ``"event"``; the
branch ends on the last point before it): a loading path stops where its branch loses stability.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, Optional, Tuple

import numpy as np

__all__ = ["Fold", "BranchPoint", "Snap", "StabilityLoss", "UserEvent", "EventPoint", "BranchState"]


@dataclass(frozen=True)
class Fold:
    """Detect and locate folds (limit points in λ); ``stop``: end the run at the first one."""

    kind: str = "fold"
    stop: bool = False


@dataclass(frozen=True)
class BranchPoint:
    """Detect and locate branch points (an eigenvalue of H crossing zero where λ does not turn);
    ``stop``: end the run at the first one."""

    kind: str = "branch_point"
    stop: bool = False


@dataclass(frozen=True)
class Snap:
    """For :class:`~.secant.Secant` runs: at a fold of the path the state is released — the path's
    ``snap`` minimises the energy from the last state at ``past`` smallest steps beyond the fold, as
    the physical rod snaps — and the run goes on from there with the step ``after_step``."""

    past: float = 2.0
    after_step: float = 1e-3
    kind: str = "snap"


@dataclass(frozen=True)
class StabilityLoss:
    """For :class:`~.secant.Secant` runs: a state that lost stability.

    ``leave=False``: refused like a failed step (the loss is located to the smallest step, like a
    fold; a refusal reports ``reason``). ``leave=True``: located to ``locate`` λ, accepted, and left
    along its unstable mode by the path's ``leave`` (a branch point crossed); the run goes on with
    a step of at most ``after_step``.
    """

    leave: bool = False
    locate: float = 0.02
    after_step: float = 0.05
    reason: str = "fold or stability loss"
    kind: str = "stability_loss"


@dataclass(frozen=True)
class UserEvent:
    """A user event: where ``function(state)`` changes sign along the branch.

    Parameters
    ----------
    name : str
    function : callable
        :class:`BranchState` -> float, continuous along the branch.
    stop : bool
        End the run at the first sign change.
    """

    name: str
    function: Callable[["BranchState"], float]
    kind: str = "user"
    stop: bool = False


class BranchState:
    """A point x = (u, λ) on a branch, as user events see it.

    Attributes
    ----------
    lam : float
    u : ndarray, shape (n,)
    z : ndarray, shape (n + 1,)
        θ at the nodes (rad).
    tip : dict
        ``angle`` = θ(1) (rad), ``x``, ``y`` (units of ℓ), computed on first use.
    """

    def __init__(self, problem, x: np.ndarray):
        self.problem, self.x = problem, x
        self.lam = float(x[problem.n])
        self.u = x[:problem.n]
        self._tip = None

    @property
    def z(self) -> np.ndarray:
        return self.problem.full(self.u, self.lam)

    @property
    def tip(self) -> Dict[str, float]:
        if self._tip is None:
            a, x, y = self.problem.tip(self.x)
            self._tip = {"angle": a, "x": x, "y": y}
        return self._tip


@dataclass
class EventPoint:
    """An event located on a step.

    Attributes
    ----------
    kind : {"fold", "branch_point", "user"}
    name : str
        The user event's name (else ``kind``).
    x : ndarray, shape (n + 1,)
        (u, λ) at the event.
    tangent : ndarray, shape (n + 1,)
        Branch tangent there (W-normalised).
    index_before, index_after : int
        Morse index at the step's ends.
    located : bool
        Located by root finding (True) or only bracketed (False, x interpolated).
    interval : (float, float)
        λ range containing it: the step's end values widened by the step length.
    """

    kind: str
    name: str
    x: np.ndarray
    tangent: Optional[np.ndarray] = field(default=None, repr=False)
    index_before: int = 0
    index_after: int = 0
    located: bool = True
    interval: Optional[Tuple[float, float]] = None

    @property
    def lam(self) -> float:
        return float(self.x[-1])
