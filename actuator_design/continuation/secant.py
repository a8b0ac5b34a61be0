"""The engine's natural-parameter algorithm on the full state: ``continuation(path, Secant(), settings, events)``.

Loading paths from rest (:mod:`.from_rest`) and the branch following over a tolerance box
(:func:`actuator_design.robust.robustness.follow_segment`) move a load parameter λ from one end of a
:class:`StatePath` to the other with warm-started Newton steps on θ at the nodes (no tangents, no
inertia: the cheapest follower, what a state reached from rest needs):

* predictor: the secant through the last two accepted states (the last state after a start, a
  snap or a branch-point escape); the step lands on each of the path's ``targets`` on its way;
* a step is accepted when Newton converges, θ moves by at most ``settings.max_du`` rad at every
  node and the path's own ``continues`` test passes; the step then grows by ``Secant.growth`` up
  to ``settings.ds_max``. Otherwise it is halved. The first state the path does not find
  ``admissible`` ends the run (reason ``"touches an obstacle"``);
* a fold: natural continuation cannot pass one, so a fold is where the step falls below
  max(``Secant.min_step_relative`` λ, ``settings.ds_min``). :class:`~.events.Fold` with ``stop``
  ends the run there; :class:`~.events.Snap` releases the state by the path's ``snap`` (a descent
  from just past the fold, as the physical rod snaps) and goes on;
* :class:`~.events.StabilityLoss`: an unstable state is refused like a failed step (the loss is
  located like a fold), or, with ``leave``, located to ``locate`` λ, accepted, and left along its
  unstable mode by the path's ``leave``.

``settings.max_steps`` bounds the Newton solves (the work): a run that reaches the end on its last
allowed solve has reached it. ``settings.window[1]`` is the end of the path (its last target).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Sequence

import numpy as np

from actuator_design.continuation.events import Fold, Snap, StabilityLoss

__all__ = ["Secant", "StatePath", "SecantRun", "run_secant"]


@dataclass(frozen=True)
class Secant:
    """Natural continuation of the full state with a secant predictor (no tangents).

    Attributes
    ----------
    growth : float
        Factor of the step after an accepted one (> 1).
    min_step_relative : float
        The smallest step is max(min_step_relative λ, ``settings.ds_min``): a strong field folds
        the path at λ ~ h_c/h, so its scale is the load reached, not the path's length.
    """

    growth: float = 1.5
    min_step_relative: float = 0.0

    def __post_init__(self):
        if not self.growth > 1.0 or not np.isfinite(self.growth):
            raise ValueError(f"growth: must be a finite number > 1, got {self.growth!r}")
        if not 0.0 <= self.min_step_relative < 1.0:
            raise ValueError(f"min_step_relative: must be in [0, 1), got {self.min_step_relative!r}")


class StatePath:
    """A path of equilibria z(λ) (θ at the nodes) of parameter vectors P(λ): what :class:`Secant` continues.

    Subclasses give :meth:`at` and :meth:`correct`; :meth:`leave` and :meth:`snap` when they run
    with ``StabilityLoss(leave=True)`` and ``Snap``; the other hooks default to accepting every
    state, finding none unstable and recording nothing.

    Attributes
    ----------
    targets : sequence of float
        Ascending λ the path lands on; the last is its end.
    """

    targets: Sequence[float] = (1.0,)

    def at(self, lam: float) -> np.ndarray:
        """The parameter vector P(λ), shape (n_params,)."""
        raise NotImplementedError

    def correct(self, guess: np.ndarray, z: np.ndarray, P: np.ndarray):
        """Newton from ``guess`` (``z`` the last accepted state) at P: a RawSolution."""
        raise NotImplementedError

    def continues(self, z_new: np.ndarray, guess: np.ndarray, z: np.ndarray, secant: bool) -> bool:
        """Whether ``z_new`` continues the branch through ``z`` (``secant``: ``guess`` was a secant
        prediction, not the last state)."""
        return True

    def admissible(self, z: np.ndarray) -> bool:
        """Whether the path may go on through ``z``; the first state that may not ends the run
        (reason ``"touches an obstacle"``)."""
        return True

    def stability(self, z: np.ndarray, P: np.ndarray):
        """(unstable, record): whether ``z`` is unstable at P, and what to keep of the check."""
        return False, None

    def failure_reason(self, run: "SecantRun") -> str:
        """Why a step whose Newton failed was refused (the reason a fold stop reports)."""
        return "no convergence"

    def leave(self, z: np.ndarray, P: np.ndarray):
        """The state reached from the unstable ``z`` along its unstable mode (a RawSolution)."""
        raise NotImplementedError

    def snap(self, z: np.ndarray, P: np.ndarray):
        """The state reached from ``z`` at P just past a fold (a RawSolution)."""
        raise NotImplementedError

    def reached(self, run: "SecantRun", raw, record, newton: bool) -> None:
        """Called at every accepted state (``run.lam``, ``raw.z``) that lands on a target."""

    def accepted(self, run: "SecantRun", P: np.ndarray, record) -> None:
        """Called at every accepted Newton step (``run.z``, ``run.lam``), before ``reached``."""


@dataclass
class SecantRun:
    """Where a :class:`Secant` run got.

    Attributes
    ----------
    z : ndarray, shape (n_nodes,)
        The last accepted state, at ``lam``.
    lam : float
    steps : int
        Accepted steps (snaps included).
    solves : int
        Newton solves and escapes tried.
    reached : bool
        The path's end was reached.
    reason : str
        Why it stopped short ("" when reached): the refused steps' reason at a fold,
        "touches an obstacle", "work bound reached", or "escape failed".
    snaps, branch_points : list of float
        λ of each snap (the state after it) and each branch point left.
    escape : RawSolution or None
        The snap or branch-point escape that failed, when that stopped the run.
    """

    z: np.ndarray
    lam: float
    steps: int = 0
    solves: int = 0
    reached: bool = False
    reason: str = ""
    snaps: List[float] = field(default_factory=list)
    branch_points: List[float] = field(default_factory=list)
    escape: Optional[object] = None


def run_secant(path: StatePath, algorithm: Secant, settings, events: Sequence = (), *,
               z0: np.ndarray, start=None, solves: int = 0) -> SecantRun:
    """Continue ``path`` from the converged state ``z0`` at λ = ``settings.window[0]`` to its last
    target, ``settings.window[1]`` (called by :func:`~.engine.continuation`).

    Parameters
    ----------
    path : StatePath
    algorithm : Secant
    settings : ContinuationSettings
        ``window`` (λ at the start, the path's end), ``ds`` first step, ``ds_max``, ``ds_min``,
        ``max_du`` (rad), ``max_steps`` (Newton solves).
    events : sequence of Fold (with ``stop``), Snap, StabilityLoss
    z0 : ndarray, shape (n_nodes,)
    start : RawSolution, optional
        The solve of ``z0``: reported to ``path.reached`` when the start is a target.
    solves : int
        Solves already spent (they count towards ``settings.max_steps``).

    Returns
    -------
    SecantRun
    """
    st = settings
    snap = next((e for e in events if isinstance(e, Snap)), None)
    loss = next((e for e in events if isinstance(e, StabilityLoss)), None)
    unknown = [e for e in events if not isinstance(e, (Fold, Snap, StabilityLoss))]
    if unknown or (snap is None and not any(isinstance(e, Fold) and e.stop for e in events)):
        raise ValueError("Secant: events must be Fold(stop=True) or Snap, and optionally StabilityLoss")
    targets = [float(t) for t in path.targets]
    lam0, end = st.window
    if end != targets[-1] or not lam0 <= targets[0] or any(b <= a for a, b in zip(targets, targets[1:])):
        raise ValueError(f"Secant: the path's targets {targets} must ascend in the window {st.window} "
                         "and end on its edge")
    run = SecantRun(np.asarray(z0, float), lam0, solves=solves)
    z_prev, lam_prev = None, None
    dl, k = st.ds, 0

    def land(raw, record=None, newton=True):
        nonlocal k
        while k < len(targets) and targets[k] == run.lam:
            path.reached(run, raw, record, newton)
            k += 1

    if start is not None:
        land(start)
    while k < len(targets) - 1 and targets[k] == lam0:  # a target at the start without its solve: nothing to report
        k += 1
    while run.lam < end and run.solves < st.max_steps:
        z, lam = run.z, run.lam
        t = min(targets[k], lam + dl)
        guess = z if z_prev is None else z + (t - lam) / (lam - lam_prev) * (z - z_prev)
        P = path.at(t)
        raw = path.correct(guess, z, P)
        run.solves += 1
        if (raw.converged and np.all(np.isfinite(raw.z)) and float(np.max(np.abs(raw.z - z))) <= st.max_du
                and path.continues(raw.z, guess, z, z_prev is not None)):
            if not path.admissible(raw.z):
                run.reason = "touches an obstacle"
                return run
            unstable, record = path.stability(raw.z, P) if loss is not None else (False, None)
            if unstable and loss.leave and t - lam > loss.locate * t:
                dl = 0.5 * (t - lam)  # locate the loss of stability first
                continue
            if not unstable or loss.leave:
                z_prev, lam_prev, run.z, run.lam = z, lam, raw.z, t
                run.steps += 1
                dl = min(algorithm.growth * dl, st.ds_max)
                path.accepted(run, P, record)
                if not unstable:
                    land(raw, record)
                    continue
                # a branch point crossed: leave along the unstable mode onto the stable branch
                left = path.leave(run.z, P)
                run.solves += 1
                if not left.converged:
                    run.reason, run.escape = "escape failed", left
                    return run
                run.branch_points.append(run.lam)
                z_prev, lam_prev, run.z = None, None, left.z
                dl = min(dl, loss.after_step)
                land(left, newton=False)
                continue
            run.reason = loss.reason
        else:
            run.reason = path.failure_reason(run)
        dl *= 0.5
        min_step = max(algorithm.min_step_relative * lam, st.ds_min)
        if dl >= min_step:
            continue
        if snap is None:  # Fold(stop=True): the run ends at the fold
            return run
        # a fold of the path: the state snaps; released from the last state just past it
        t = min(targets[k], lam + snap.past * min_step)
        released = path.snap(z, path.at(t))
        run.solves += 1
        if not released.converged:
            run.reason, run.escape = "escape failed", released
            return run
        run.snaps.append(t)
        z_prev, lam_prev, run.z, run.lam = None, None, released.z, t
        run.steps += 1
        dl = snap.after_step
        land(released, newton=False)
    run.reached = run.lam >= end
    run.reason = "" if run.reached else "work bound reached"
    return run
