"""The state reached from rest: loads and field ramped together from zero, warm-started Newton steps.

A dead load or a field switched on slowly moves the rod through a continuous family of stable
states; what it reaches at full load is the physical answer of ``solve`` (issue 10: from the
straight rod, IPOPT may descend into a coiled or self-intersecting minimum that no loading history
reaches). The homotopy scales every slot that sizes the stationarity residual — the loads and field
strengths each energy term declares (``EnergyTerm.residual_scale``: h, h_pos, p, tip moment,
distributed loads, …) — by λ ∈ [0, 1]; geometry (φ, fibre angles, stiffness) is not scaled. At
λ = 0 the rod is at rest: the straight rod at the clamp angle (a term with natural curvature makes
the rest state curved; it is solved for).

A run of the continuation engine: the natural-parameter :class:`~.secant.Secant` algorithm (a
secant predictor and the fast Newton of :mod:`actuator_design.reduced.newton`) with the events
:class:`~.events.Snap` and :class:`~.events.StabilityLoss` (``leave``); a step is accepted when Newton converges and no node angle
moves more than :data:`MAX_TURN` rad, otherwise it is halved. Each accepted state's stability is
checked (THEORY §7): past a branch point the path leaves along the unstable mode onto the stable
branch, as an imperfect real rod would, and stays on that side of the unstable state (a Newton
step that lands on the mirror branch is refused and the step halved), so that neighbouring loads
end on the same branch. When the step falls below
:data:`MIN_STEP` (relative to the load reached) the path has reached a fold of the loading history (a snap-through): the state
there is released by minimising the energy from the last state, as the physical rod would
snap, and the path goes on from the new state. Both escapes — along the unstable mode and at a
fold — are ``EquilibriumSolver.descend``: IPOPT with the exact Hessian, or in a fitted field a
trust-region Newton descent (every step lowering the energy), so the state reached is the one
descent reaches, whatever the iteration cap;
a branch-point escape that lands on the other side of the unstable state is refused, and so is a
later step back onto the unstable state (round-off puts it on either side).

A path can also land on *stations* λ_1 < … < λ_m = 1 on its way (:func:`path_from_rest` with
``stations``): the states at the points of a ray of loads {λ P} are those reached from rest at each
of them, so a study whose grid points lie on such a ray walks it once (:mod:`actuator_design.study.walk`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

from actuator_design.continuation.engine import continuation
from actuator_design.continuation.events import Snap, StabilityLoss
from actuator_design.continuation.secant import Secant, StatePath
from actuator_design.continuation.settings import ContinuationSettings
from actuator_design.reduced.stability import is_unstable

__all__ = ["RestPath", "StationState", "path_from_rest", "MAX_TURN", "MIN_STEP"]

#: largest change of any node angle in one accepted step (rad)
MAX_TURN = 0.5
#: smallest load step before the path is declared at a fold, relative to the load reached
#: (a strong field buckles the rod at λ ~ h_c/h: the scale of the path is the load, not 1)
MIN_STEP = 1e-5
#: ... and never below this fraction of the full load
MIN_STEP_FLOOR = 1e-9
#: size of the kick along the unstable mode (max-norm 1) after a branch point is crossed (rad)
BRANCH_KICK = 0.05
#: a loss of stability is located to within this fraction of the load before the kick
BRANCH_STEP = 0.02
#: an offset from the unstable state left at a branch point lies on the branch's side when its cosine
#: with the unstable mode (mass inner product) exceeds this
SIDE_COSINE = 1e-3
#: ... and its size (L² norm in the mass inner product, rad) exceeds this: a state back on the unstable
#: one is offset by round-off along the mode itself, so its cosine is ±1 and tells nothing
SIDE_OFFSET = 1e-6
#: most Newton solves along one path
MAX_SOLVES = 400
#: a secant step is accepted only when Newton's correction of the predictor is at most this
#: multiple of the predicted change (max-norms): a larger correction means Newton left the branch
#: being followed (e.g. for another stable branch born near an imperfect pitchfork, issue 22)
CORRECTOR_RATIO = 1.0
#: ... or at most this (rad): the correction that round-off and a tiny predicted change allow
CORRECTOR_FLOOR = 1e-3


@dataclass
class StationState:
    """The state on the path at one station.

    Attributes
    ----------
    z : ndarray, shape (n_nodes,)
        θ at the nodes.
    raw : RawSolution
        The solve that produced it (iterations, stationarity, message).
    snaps, branch_points : tuple of float
        Load fractions (of the path's full load) of the snaps and branch points met before it.
    check : StabilityCheck or None
        What the path learnt of its stability there (:mod:`actuator_design.reduced.stability`).
    newton : bool
        A converged Newton point of the path; False for the descent's answer after a branch-point
        kick or a snap (converged by Newton, but not a step of the path: a caller that reports it
        polishes it first).
    """

    z: np.ndarray
    raw: object
    snaps: Tuple[float, ...] = ()
    branch_points: Tuple[float, ...] = ()
    check: Optional[object] = None
    newton: bool = True


@dataclass
class RestPath:
    """The end of the loading path from rest.

    Attributes
    ----------
    z : ndarray, shape (n_nodes,)
        θ at the nodes at full load (λ = 1) when ``reached``, else at ``lam``.
    reached : bool
        Whether λ = 1 was reached with a converged state.
    lam : float
        Last load fraction reached.
    steps : int
        Accepted steps.
    solves : int
        Newton solves tried (accepted and rejected).
    snaps : list of float
        Load fractions at which the path met a fold and the state snapped.
    branch_points : list of float
        Load fractions after which the state had become unstable (a branch point crossed) and
        was moved onto the stable branch along its unstable mode.
    visits : list of StationState
        With ``stations``: the state at each station reached, in order (shorter than the stations
        when the path stopped early).
    rest : ndarray, shape (n_nodes,), or None
        The rest state (λ = 0), when it was found.
    stop : RawSolution or None
        The escape (branch point or snap) that failed, when that stopped the path.
    """

    z: np.ndarray
    reached: bool
    lam: float
    steps: int
    solves: int
    snaps: List[float] = field(default_factory=list)
    branch_points: List[float] = field(default_factory=list)
    visits: List[StationState] = field(default_factory=list)
    rest: Optional[np.ndarray] = None
    stop: Optional[object] = None

    @property
    def one_step(self) -> bool:
        """True when the full load was reached in one Newton step from rest."""
        return self.reached and self.steps == 1 and not self.snaps and not self.branch_points


def load_fraction(solver, params: np.ndarray, lam: float) -> np.ndarray:
    """The parameter vector with every load/field slot scaled by ``lam`` (shape as ``params``)."""
    out = np.array(params, float)
    for i in list(solver._scale_lin) + list(solver._scale_sq):
        out[i] *= lam
    return out


def _on_branch(z_new: np.ndarray, guess: np.ndarray, z: np.ndarray) -> bool:
    """Whether Newton's answer ``z_new`` from the secant predictor ``guess`` continues the branch
    through ``z``: its correction is small next to the predicted change (:data:`CORRECTOR_RATIO`,
    :data:`CORRECTOR_FLOOR`). On a smooth branch the correction is O(step²) and the change O(step),
    so halving the step always passes; a jump onto another branch does not shrink with the step."""
    correction = float(np.max(np.abs(z_new - guess)))
    predicted = float(np.max(np.abs(guess - z)))
    return correction <= max(CORRECTOR_RATIO * predicted, CORRECTOR_FLOOR)


def _on_side(z_new: np.ndarray, side, mass: np.ndarray) -> bool:
    """Whether ``z_new`` lies on the taken branch's side of the unstable state ``side[0]``: the
    cosine of its offset and the unstable mode ``side[1]`` in the mass inner product is above
    :data:`SIDE_COSINE` and its size :data:`SIDE_OFFSET` (a state back on the unstable one, offset by
    round-off, is on neither side)."""
    d, v = (z_new - side[0])[1:], side[1][1:]
    offset = float(np.sqrt(np.dot(d * mass, d)))
    dm = offset * float(np.sqrt(np.dot(v * mass, v)))
    return offset > SIDE_OFFSET and float(np.dot(d * mass, v)) > SIDE_COSINE * dm


def path_from_rest(solver, params: np.ndarray, tol: float = None, follow_stable: bool = True,
                   stations: Optional[Sequence[Tuple[float, np.ndarray]]] = None,
                   admissible=None) -> RestPath:
    """Continue the rest state of ``solver``'s scene from λ = 0 to 1 (loads and field ramped together).

    Parameters
    ----------
    solver : EquilibriumSolver
    params : ndarray, shape (n_params,)
        The full-load parameter vector.
    tol : float, optional
        Newton tolerance (default the solver's ``options.tol``).
    follow_stable : bool
        Check each state's stability and leave a branch that has lost it (``ensure_stable``);
        False follows the stationary branch wherever it goes.
    stations : sequence of (float, ndarray), optional
        Load fractions 0 ≤ λ_1 < … < λ_m = 1, each with its parameter vector (λ_k ``params`` up to
        rounding: the scene of a grid point on the ray): the path lands on each, solving there
        with that vector, and records the state (``RestPath.visits``).
    admissible : callable, optional
        ``z (n_nodes,) -> bool``: the states the escapes' descent may step to
        (``EquilibriumSolver.descend``), e.g. the rod inside the region where a fitted field holds.

    Returns
    -------
    RestPath
    """
    targets = [1.0] if stations is None else [float(lam) for lam, _ in stations]
    if any(b <= a for a, b in zip(targets, targets[1:])) or targets[-1] != 1.0 or targets[0] < 0.0:
        raise ValueError("stations must be ascending load fractions in [0, 1] ending at 1")
    ramp = _LoadRamp(solver, params, tol, stations, targets, admissible)
    z = solver.initial_guess(params)
    solves = 0
    rest = solver.solve_fast(z, ramp.at(0.0), max_iter=ramp.newton_iter, tol=tol, floor_scale=ramp.floor_scale)
    solves += 1
    if not rest.converged:
        rest = solver.solve_newton(z, ramp.at(0.0), tol=tol, floor_scale=ramp.floor_scale)
        solves += 1
    if not rest.converged:
        return RestPath(z, False, 0.0, 0, solves)
    budget = MAX_SOLVES + (4 * len(targets) if stations is not None else 0)
    settings = ContinuationSettings(ds=1.0, ds_min=MIN_STEP_FLOOR, ds_max=1.0, max_steps=budget,
                                    window=(0.0, 1.0), max_du=MAX_TURN)
    events = [Snap(past=2.0, after_step=1e-3)]
    if follow_stable:
        events.append(StabilityLoss(leave=True, locate=BRANCH_STEP, after_step=0.05))
    run = continuation(ramp, Secant(growth=2.0, min_step_relative=MIN_STEP), settings, events,
                       x0=rest.z, start=rest if stations is not None else None, solves=solves)
    return RestPath(run.z, run.reached, run.lam, run.steps, run.solves, run.snaps, run.branch_points,
                    ramp.visits, rest.z.copy(), run.escape)


class _LoadRamp(StatePath):
    """Loads and field ramped together, λ ∈ [0, 1], landing on the stations (:func:`path_from_rest`)."""

    def __init__(self, solver, params, tol, stations, targets, admissible):
        self.solver, self.params, self.tol, self.targets = solver, params, tol, targets
        self.exact = {} if stations is None else {float(lam): np.asarray(p, float) for lam, p in stations}
        self.escape_admissible = admissible
        self.mass = 1.0 / solver.kernel.inv_mass
        self.newton_iter = min(15, int(solver.options.max_iter))  # an iteration limit binds the path too
        # the mesh is graded for the full load (h = 1e4: end elements ~1e-5 long), where rounding
        # alone leaves |g|/m ~ 1e-5 at the straight rod: a state of the path is held to tol at its
        # own load's scale, and rounding may excuse what it would at the full load's (with a Newton
        # step ≤ 10 tol)
        self.floor_scale = solver.residual_scale(params)
        self.side = None  # (unstable state, mode) of the last branch point left: its branch's side
        self.visits: List[StationState] = []

    def at(self, lam):
        return self.exact[lam] if lam in self.exact else load_fraction(self.solver, self.params, lam)

    def correct(self, guess, z, P):
        return self.solver.solve_fast(guess, P, max_iter=self.newton_iter, tol=self.tol,
                                      floor_scale=self.floor_scale)

    def continues(self, z_new, guess, z, secant):
        return ((not secant or _on_branch(z_new, guess, z))
                and (self.side is None or _on_side(z_new, self.side, self.mass)))

    def stability(self, z, P):
        lowest = []
        unstable = is_unstable(self.solver, z, P, out=lowest)
        return unstable, (lowest[0] if lowest else None)

    def leave(self, z, P):
        # the path crossed a branch point (e.g. the pitchfork of the transverse field): the real
        # rod leaves along the unstable mode; follow the stable branch from here
        vec = self.solver.stability(z, P).eigenvector
        v = vec * (1.0 if vec[-1] >= 0 else -1.0)
        left = self.solver.descend(z + BRANCH_KICK * v, P, self.escape_admissible)
        if left.converged and not _on_side(left.z, (z, v), self.mass):
            left.converged, left.status = False, "other_side"
            left.message += "; it ended on the other side of the unstable state"
        self.side = (z.copy(), v)  # the branch taken: stay on its side of the unstable state
        return left

    def snap(self, z, P):
        # a fold of the loading path: the rod snaps; minimise from the last state just past it
        self.side = None
        return self.solver.descend(z, P, self.escape_admissible)

    def reached(self, run, raw, record, newton):
        self.visits.append(StationState(raw.z.copy(), raw, tuple(run.snaps), tuple(run.branch_points),
                                        record, newton))
