"""Pseudo-arclength continuation of equilibrium branches in any scalar parameter (THEORY §7–8).

The branch is the solution set of G(u, λ) = ∇_u Ê(u; P(λ)) = 0, u = (θ_1, …, θ_n) the free node
values of the collocation (θ_0 = θ0 eliminated), λ one parameter of the lens
(:mod:`actuator_design.physics.parameters`: ``h``, ``h2`` = h², ``phi``, ``p``, ``fx``, ``m_tip``, ``qx``,
``qy``, ``theta0``, ``alpha``, …) substituted symbolically into the NLP's parameter vector by the
reduced system (:mod:`actuator_design.reduced`; ``h2`` enters as (√λ)² = λ exactly).

This module is a client of the continuation engine (:func:`actuator_design.continuation.continuation`:
PALC predictor–corrector in the mass-weighted metric W = diag(M, 1), folds where the λ-component of
the tangent changes sign, branch points where det [G_x; tᵀW] does, both located by ``brentq`` on
σ ↦ (−1)^{Morse index} · min|μ_i| along the step). It adds what the analyses need on top: the
start from a forward solve, tips, energies and θ'(0) along the branch, and branch switching —
the second null vector of [G_u G_λ] at a branch point (W-orthogonal to the branch tangent) is the
direction of the bifurcating branch. Every change of stability along a branch is located to the
corrector's accuracy and inserted as a branch point of its own (:mod:`.stability_changes`), so the
branch data and figures switch from stable to unstable exactly there.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.analysis.registration import register
from actuator_design.analysis.stability_changes import insert_stability_changes
from actuator_design.contact.clearance import least_clearance
from actuator_design.contact.path import follow_contact_path
from actuator_design.contact.self_contact import least_self_clearance
from actuator_design.continuation import (PALC, BifurcationProblem, BranchPoint, ContinuationSettings, Fold,
                                          UserEvent, continuation)
from actuator_design.continuation.branch import Branch, ContinuationResult, CriticalPoint
from actuator_design.continuation.branch_accuracy import (branch_accuracy, branch_options, critical_accuracy,
                                                          unlocated_note)
from actuator_design.equilibrium.acceptance import warm_values
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve_from_rest
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.solver import EquilibriumSolver, get_solver
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.physics.parameters import Parameter
from actuator_design.physics.registry import term_class
from actuator_design.reduced.system import reduced_system, substituted_energy

__all__ = ["get_param", "set_param", "Continuation", "Branch", "CriticalPoint", "continue_branch",
           "branch_options", "default_ds_max", "ContinuationResult", "system_function", "substituted_energy"]

_WHAT = "continuation parameter"


def _check_name(name: str) -> Parameter:
    return lens.parameter(name, _WHAT)


def get_param(scene: Scene, name: str) -> float:
    """The value of continuation parameter ``name`` in ``scene`` (0 for an absent term); a thin
    name for :func:`actuator_design.physics.parameters.get_value`."""
    return lens.get_value(scene, name, _WHAT)


def set_param(scene: Scene, name: str, value: float) -> Scene:
    """A copy of ``scene`` with parameter ``name`` set to ``value`` (adding the term if absent);
    a thin name for :func:`actuator_design.physics.parameters.set_value`.

    Raises
    ------
    ValueError
        Unknown name, a value outside the parameter's range (e.g. ``h2 < 0``), or ``phi`` on a
        non-uniform field.
    """
    return lens.set_value(scene, name, value, _WHAT)


def system_function(solver: EquilibriumSolver, name: str) -> ca.Function:
    """CasADi ``(u, λ, P) -> (g, H, g_λ)`` of the reduced system in ``name`` (cached per structure,
    transcription and name): :attr:`actuator_design.reduced.ReducedSystem.f_system`."""
    _check_name(name)
    return reduced_system(solver, [name]).f_system


def _pointwise(fn: ca.Function, Z: np.ndarray, Ps: np.ndarray) -> np.ndarray:
    """``fn(z_k, P_k)`` for every row k, its scalar outputs side by side, shape (N, n_out).

    Through CasADi's buffer interface, one call per point: about 5× cheaper than ``fn.map(N)``
    on numpy inputs (whose conversion to DM dominates for a few thousand points)."""
    N = Z.shape[0]
    buf, call = fn.buffer()
    z, P = np.zeros(Z.shape[1]), np.zeros(Ps.shape[1])
    res = np.zeros(fn.n_out())
    buf.set_arg(0, memoryview(z))
    buf.set_arg(1, memoryview(P))
    for i in range(fn.n_out()):
        buf.set_res(i, memoryview(res[i:i + 1]))
    out = np.empty((N, fn.n_out()))
    for k in range(N):
        z[:], P[:] = Z[k], Ps[k]
        call()
        out[k] = res
    return out


class Continuation:
    """Pseudo-arclength continuation in parameter ``name`` for one scene structure.

    Parameters
    ----------
    scene : Scene
        Uniform or non-uniform field; the other parameters stay at their values in ``scene``.
    name : str
        A name of the parameter lens (:mod:`actuator_design.physics.parameters`).
    options : SolverOptions, optional
        Transcription and tolerance (``tol`` is the corrector's stationarity tolerance).

    Attributes
    ----------
    problem : BifurcationProblem
        The engine's problem; ``ev``, ``mass``, ``W`` and the correctors are its.
    """

    def __init__(self, scene: Scene, name: str, options: Optional[SolverOptions] = None):
        _check_name(name)
        self.name = name
        self.scene = set_param(scene, name, get_param(scene, name))  # the term exists
        self.options = replace(options or SolverOptions(), ensure_stable=False)
        self.solver = get_solver(self.scene, self.options)
        self.P = self.solver.parameter_vector(self.scene)
        self.system = reduced_system(self.solver, [name])
        self.fn = self.system.f_system
        sl = self.solver.layout.slices
        self._theta0 = float(self.P[sl["theta0"]][0])
        self.problem = BifurcationProblem(self.system, self.P, theta0=self._theta0)
        self.ev = self.problem.ev
        self.mass, self.n, self.W, self.Ms = (self.problem.mass, self.problem.n, self.problem.W,
                                              self.problem.Ms)
        self.tol = self.options.tol
        self.theta0_fixed = name != "theta0"

    # -- helpers ------------------------------------------------------------------------------
    def params(self, lam: float) -> np.ndarray:
        """The NLP parameter vector at λ (for the solver's own functions)."""
        return self.solver.parameter_vector(set_param(self.scene, self.name, lam))

    def scene_at(self, lam: float) -> Scene:
        return set_param(self.scene, self.name, lam)

    def full(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Node vector z = (θ0, u)."""
        return self.problem.full(u, lam)

    def correct_fixed(self, u, lam, max_iter: int = 20):
        """Newton at fixed λ. Returns (u, converged, iterations)."""
        return self.problem.correct_fixed(u, lam, self.tol, max_iter)

    def correct(self, xp, t, max_iter: int = 8):
        """Newton on [G(x); tᵀW(x − xp)] = 0 from xp. Returns (x, converged, iterations)."""
        return self.problem.correct(xp, t * self.W, self.tol, 1e-9, max_iter)

    def tangent(self, x, t_prev=None, evaluate: bool = True) -> Tuple[np.ndarray, float]:
        """Unit tangent (W-norm) at a converged x and the sign of det [G_x; tᵀW]."""
        return self.problem.tangent(x, t_prev, evaluate)

    def inertia(self, x, evaluate: bool = True) -> Tuple[int, float, float]:
        """(Morse index, smallest eigenvalue, (−1)^index · min|μ|) of M^{-1/2} H M^{-1/2} at x."""
        return self.problem.inertia(x, evaluate)

    def fast_inertia(self) -> Tuple[int, float]:
        """(Morse index, smallest eigenvalue) at the last evaluation (certified warm eigenpair,
        :meth:`BifurcationProblem.fast_inertia`)."""
        return self.problem.fast_inertia()

    # -- starting -----------------------------------------------------------------------------
    def start(self, lam0: float, initial=None) -> np.ndarray:
        """A converged point x = (u, λ0): Newton from ``initial`` (node vector, EquilibriumResult or
        None for the state :func:`~actuator_design.equilibrium.pipeline.solve` reaches from rest at λ0)."""
        if isinstance(initial, EquilibriumResult):  # (interpolated when solved on another mesh)
            initial = warm_values(initial, self.solver.transcription.nodes)
        if initial is None:
            initial = self.rest_state(self.scene_at(lam0))
        u, ok, _ = self.correct_fixed(np.asarray(initial, float)[1:], lam0, max_iter=50)
        if not ok:
            raise RuntimeError(f"continuation: Newton did not converge at the start {self.name} = {lam0}")
        return np.append(u, lam0)

    def rest_state(self, scene: Scene) -> np.ndarray:
        """θ at this mesh's nodes of the state :func:`~actuator_design.equilibrium.pipeline.solve`
        reaches from rest in ``scene`` (on the mesh solve chooses, interpolated onto this one). A state
        that misses solve's accuracy on that mesh is used all the same: the branch's own check
        (:attr:`ContinuationResult.accuracy`) reports it."""
        res, converged = solve_from_rest(scene, self.options)
        if not converged:
            raise RuntimeError(f"continuation: no equilibrium found at {self.name} = "
                               f"{get_param(scene, self.name)}: {res.message}")
        return warm_values(res, self.solver.transcription.nodes)

    # -- the main loop ------------------------------------------------------------------------
    def run(self, x0: np.ndarray, window: Tuple[float, float], *, direction: float = 1.0,
            t0: Optional[np.ndarray] = None, ds: float = 0.05, ds_min: float = 1e-7,
            ds_max: float = 0.5, max_points: int = 2000, locate: bool = True,
            origin: Optional[str] = None, stop_events: Sequence[UserEvent] = ()) -> Branch:
        """Continue from the converged point ``x0`` until λ leaves ``window`` (the end point is
        placed on the window's edge), the branch closes, ``max_points`` is reached or the step
        underflows.

        Parameters
        ----------
        x0 : ndarray, shape (n + 1,)
            (u, λ) at a converged equilibrium.
        window : (float, float)
            λ interval.
        direction : float
            Initial direction: sign of dλ (ignored when ``t0`` is given).
        t0 : ndarray, optional
            Initial tangent (e.g. for branch switching).
        ds, ds_min, ds_max : float
            Initial, minimal and maximal arclength steps (W-norm).
        locate : bool
            Detect and locate folds and branch points.
        stop_events : sequence of UserEvent
            Events (made with ``stop=True``) that end the run where they are located.
        """
        settings = ContinuationSettings(
            ds=ds, ds_min=min(ds_min, ds, ds_max), ds_max=ds_max, max_steps=max(int(max_points), 2),
            window=(float(min(window)), float(max(window))), direction=1.0 if direction >= 0 else -1.0,
            tol=self.tol)
        events = ((Fold(), BranchPoint()) if locate else ()) + tuple(stop_events)
        res = continuation(self.problem, PALC(), settings, events, x0=x0, tangent=t0)
        n = self.n
        if locate:
            insert_stability_changes(self.problem, settings, res)
        Xa = res.x
        z = np.column_stack([np.where(self.theta0_fixed, self._theta0, Xa[:, n]), Xa[:, :n]])
        crit = [CriticalPoint(e.kind, self.name, e.lam, self.full(e.x[:n], e.lam),
                              {"angle": float(e.x[n - 1]), "x": float("nan"), "y": float("nan")},
                              e.index_before, e.index_after, e.located, e.tangent, interval=e.interval)
                for e in res.events]
        br = Branch(self.name, Xa[:, n].copy(), z, res.morse_index, res.min_eig,
                    [c for c in crit if c.kind == "fold"], [c for c in crit if c.kind == "branch_point"],
                    res.status, res.message, res.stats, origin=origin)
        br._tangents = res.tangents
        stopped = [e for e in res.events if e.kind == "user"] if res.status == "event" else []
        if stopped:  # the branch ends at the stopping event itself (the touch), not the step before
            e = stopped[-1]
            idx, mu, _ = self.inertia(e.x)
            br.lam = np.append(br.lam, e.lam)
            br.z = np.vstack([br.z, self.full(e.x[:n], e.lam)])
            br.morse_index, br.min_eig = np.append(br.morse_index, idx), np.append(br.min_eig, mu)
        self._decorate(br)
        return br

    def _decorate(self, br: Branch) -> None:
        """Tip, energy and θ'(0) at every point (buffered CasADi calls, :func:`_pointwise`)."""
        N = len(br)
        Ps = np.column_stack([self.params(l) for l in br.lam]) if N < 50 else self._params_matrix(br.lam)
        br.tips = _pointwise(self.solver.f_tip, br.z, Ps.T)
        br.energy = _pointwise(self.solver.f_energy, br.z, Ps.T)[:, 0]
        br.gamma = br.z @ self._gamma_row()
        for cp in br.folds + br.branch_points:
            P = self.params(cp.value)
            vals = self.solver.f_tip(cp.z, P)
            cp.tip = {"angle": float(vals[0]), "x": float(vals[1]), "y": float(vals[2])}
            cp.energy = float(self.solver.f_energy(cp.z, P))

    def _gamma_row(self) -> np.ndarray:
        """Row r with θ'(0) = r · z (θ'(0) of the transcription's interpolant is linear in z)."""
        if getattr(self, "_grow", None) is None:
            tr, nn = self.solver.transcription, self.n + 1
            self._grow = np.array([tr.theta_dense(e, np.array([0.0]))[1][0] for e in np.eye(nn)])
        return self._grow

    def _params_matrix(self, lams):
        base = self.P.copy()
        sl = self.solver.layout.slices[lens.parameter(self.name).slot]
        out = np.repeat(base[:, None], len(lams), axis=1)
        vals = np.asarray(lens.parameter(self.name).to_slot(np.asarray(lams, float)))
        out[sl, :] = vals[None, :]
        return out

    # -- branch switching ---------------------------------------------------------------------
    def switch(self, bp: CriticalPoint, window, *, ds: float = 0.05, **kw) -> List[Branch]:
        """Continue the branch bifurcating at branch point ``bp`` in both directions.

        The second null vector of [G_u G_λ] at ``bp`` (W-orthogonal to the primary tangent) is the
        tangent of the bifurcating branch; each half starts from a corrected point at distance
        ``ds`` along ±that vector.
        """
        xb = np.append(bp.z[1:], bp.value)
        K = self.problem.null_directions(xb)
        t1 = bp.tangent
        cands = [k - float(t1 @ (self.W * k)) * t1 for k in K]
        t2 = max(cands, key=lambda v: float(v @ (self.W * v)))
        t2 /= math.sqrt(float(t2 @ (self.W * t2)))
        out = []
        for sgn in (1.0, -1.0):
            d = sgn * t2
            xs, ok, _ = self.correct(xb + ds * d, d, max_iter=20)
            if not ok:
                continue
            out.append(self.run(xs, window, t0=d, ds=ds,
                                origin=f"branch point at {self.name} = {bp.value:.10g}", **kw))
        return out


def _touch_event(least) -> UserEvent:
    """The event where the branch's rod first touches an obstacle (``least`` changes sign)."""
    return UserEvent("touch", lambda state: least(state.z), stop=True)


def _free_start(cont: "Continuation", scene: Scene, param: str, start: float, initial, least,
                through_contact: bool = False):
    """The start of a branch on a scene with obstacles: the equilibrium without them (the branch is
    followed while it keeps clear), which must keep clear of them (``least`` > 0); ``initial``
    when given. None when it does not and ``through_contact``: the start is in contact."""
    if initial is None:
        initial = cont.rest_state(replace(set_param(scene, param, start), obstacles=()))
    z = np.asarray(warm_values(initial, cont.solver.transcription.nodes), float)
    if least(z) <= 0.0:
        if through_contact:
            return None
        raise RuntimeError(f"continuation: the equilibrium at {param} = {start} touches or enters an obstacle; "
                           "a start in contact is not continued: use path, which follows contact from rest")
    return z


def default_ds_max(window: Sequence[float]) -> float:
    """The largest arclength step of a branch over ``window``: 0.5, or 1/400 of a wider (finite)
    window — the parameter counts with weight 1 in the arclength, so a branch in p to 1e4 would
    otherwise need 2e4 points (at most ~400 at the largest step, plus the adaptive ones)."""
    width = float(window[1]) - float(window[0])
    return max(0.5, width / 400.0) if math.isfinite(width) else 0.5


def continue_branch(scene: Scene, param: str, start: float, stop: float, *,
                    options: Optional[SolverOptions] = None, initial=None, ds: float = 0.05,
                    ds_max: Optional[float] = None, max_points: int = 2000, switch: bool = False,
                    window: Optional[Sequence[float]] = None, through_contact: bool = True) -> ContinuationResult:
    """Continue the equilibrium at ``param = start`` towards ``stop`` (through folds), within the
    window [min(start, stop), max(start, stop)] unless ``window`` is given.

    On a scene with obstacles, or a rod with a thickness, the branch of free states is continued
    until the rod first touches an obstacle or itself (located as an event, branch status
    ``touch``). From there, with ``through_contact``, the rest of the window is followed by a
    loading path of contact equilibria warm-started from the touching state
    (:func:`actuator_design.contact.path.follow_contact_path`: touch-down and lift-off located as events, snaps
    located at the contact branch's fold), the result's ``contact_path``. That path follows stable
    states in the direction the branch was moving; it does not turn round folds as the
    arclength continuation does.

    Parameters
    ----------
    scene : Scene
        Other parameters fixed at their values here.
    param : str
        A name of the parameter lens (:mod:`actuator_design.physics.parameters`).
    start, stop : float
        Parameter values (units of the parameter: rad for angles).
    initial : ndarray (n_nodes,) or EquilibriumResult, optional
        Start equilibrium guess; default: :func:`~actuator_design.equilibrium.pipeline.solve` at ``start``.
    ds, ds_max : float
        Initial and largest arclength steps (ds_max default: :func:`default_ds_max`).
    switch : bool
        Also continue every branch bifurcating at a branch point found (each up to its first touch).
    through_contact : bool
        Follow on with contact after the first touch (default); False stops there.

    Returns
    -------
    ContinuationResult
        With ``accuracy``: why the branches' most demanding states miss the accuracy of
        :func:`~actuator_design.equilibrium.pipeline.solve`, or None
        (:func:`~actuator_design.continuation.branch_accuracy.branch_accuracy`).

    Notes
    -----
    The branch is followed on one mesh, graded for the most demanding end of the window
    (:func:`~actuator_design.equilibrium.acceptance.graded_for_scenes`, with ``options.adapt``), unless
    ``initial`` is given as node values (they hold on the mesh ``options`` make).
    """
    win = (min(start, stop), max(start, stop)) if window is None else tuple(window)
    ds_max = default_ds_max(win) if ds_max is None else ds_max
    if not isinstance(initial, np.ndarray):
        options = branch_options(scene, param, (start, stop, *win), options)
    cont = Continuation(scene, param, options or SolverOptions())
    touch, itself = (), None
    if scene.obstacles:  # the free branch, followed until the rod first touches an obstacle
        least = least_clearance(cont.solver, scene.obstacles, scene.contact_gap)
        free = _free_start(cont, scene, param, start, initial, least, through_contact)
        if free is None:  # the start presses on an obstacle: the whole window with contact
            return _in_contact_from_start(scene, cont.options, param, start, stop, win, initial, "an obstacle")
        initial = free
        touch = (_touch_event(least),)
    if scene.contact_gap > 0 and not cont.options.keep_self_intersecting:  # ... or itself
        itself = least_self_clearance(cont.solver, scene.contact_gap)
        touch += (UserEvent("self-touch", lambda state: itself(state.z), stop=True),)
    x0 = cont.start(start, initial)
    z0 = np.concatenate([[cont._theta0 if cont.theta0_fixed else x0[-1]], x0[:-1]])  # θ at the nodes
    if itself is not None and itself(z0) <= 0.0:
        if through_contact:
            return _in_contact_from_start(scene, cont.options, param, start, stop, win, initial, "itself")
        raise RuntimeError(f"continuation: the equilibrium at {param} = {start} touches or passes through "
                           "itself; a start in contact is not continued (solve finds the self-contact state "
                           "at one load, path follows it from rest)")
    br = cont.run(x0, win, direction=1.0 if stop >= start else -1.0, ds=ds, ds_max=ds_max,
                  max_points=max_points, stop_events=touch)
    contact = None
    if touch and br.status == "event":
        br.status = "touch"
        what = "itself" if itself is not None and itself(br.z[-1]) <= 1e-9 else "an obstacle"
        where = f"stopped where the rod first touches {what}, at {param} = {br.lam[-1]:.10g}"
        if through_contact:
            contact = _on_with_contact(scene, cont.options, param, br, win)
            br.message = (f"{where}; followed on with contact to {param} = "
                          f"{contact.schedule[-1, 0]:.10g} by a loading path of stable states "
                          f"({'converged' if contact.success else 'FAILED'}: {contact.message})")
        else:
            br.message = f"{where} (through_contact off: the rod's contact states are not followed)"
    if br.status == "max_points":
        br.message += (f" at {param} = {br.lam[-1]:.6g}, short of the window [{win[0]:.6g}, {win[1]:.6g}]: "
                       "raise max_points (--max-points) or the largest step ds_max (--ds-max, arclength "
                       "in which the parameter counts with weight 1)")
    sec = []
    if switch:
        for bp in br.branch_points:
            sec += cont.switch(bp, win, ds=ds, ds_max=ds_max, max_points=max_points, stop_events=touch)
    points = [cp for b in [br] + sec for cp in b.folds + b.branch_points]
    critical = critical_accuracy(cont, points)  # (every located point gets its value_error)
    loose = unlocated_note(param, points)
    return ContinuationResult(param, br, sec, scene, win, contact,
                              notes=_alone_note(scene, param) + ([loose] if loose else []),
                              accuracy=branch_accuracy(cont, [br] + sec) or critical)


def _alone_note(scene: Scene, param: str) -> List[str]:
    """A note when ``param`` is the field magnitude and the scene has other groups the field drives
    (h_pos in a non-uniform field, h_r: ∝ H too, THEORY §5, §9): the branch moves ``param`` alone,
    which is not a change of the applied field (a loading path in it moves them all)."""
    if not lens.parameter(param).field_magnitude:
        return []
    table = lens.per_field(scene)  # (a physical scene at zero field has them per unit field)
    fixed = [p for p, _ in lens.field_groups(magnitude=False)
             if (p.get(scene) != 0.0 or table.get(p.name, 0.0) != 0.0)
             and (p.term is None or term_class(p.term).present(scene))]
    if not fixed:
        return []
    advice = (f"`actuator-design path --param {param}` ramps the field with every group it drives"
              if lens.soft_coupled(scene) else  # no h per field: the field acts through the others alone
              f"this rod's field acts through {', '.join(p.name for p in fixed)}: continue in that")
    return [f"{param} is continued alone: {', '.join(f'{p.name} = {p.get(scene):.6g}' for p in fixed)} "
            f"(∝ the field too) stay{'s' if len(fixed) == 1 else ''} fixed, so the branch is not a change of "
            f"the applied field; {advice}"]


def _in_contact_from_start(scene: Scene, options: SolverOptions, param: str, start: float, stop: float,
                           win, initial, what: str) -> ContinuationResult:
    """A start that touches ``what`` (an obstacle, or itself): the loading path with contact over the window from the
    contact equilibrium at ``start`` (from rest, or warm-started from ``initial``); the branch is
    that one state (status ``touch``)."""
    t0 = time.perf_counter()
    path = follow_contact_path(set_param(scene, param, start), options, {param: [start, float(stop)]},
                               initial=initial)
    r = path.point_states[0]
    br = Branch(param=param, lam=np.array([float(start)]), z=np.asarray(r.z, float)[None, :],
                morse_index=np.array([int(r.morse_index)]), min_eig=np.array([float(r.eigenvalues[0])]),
                folds=[], branch_points=[], status="touch",
                message=(f"the start at {param} = {start:.10g} touches {what}; followed with contact to "
                         f"{param} = {float(stop):.10g} by a loading path of stable states "
                         f"({'converged' if path.success else 'FAILED'}: {path.message})"),
                stats={"time_s": time.perf_counter() - t0},
                tips=np.array([[r.tip["angle"], r.tip["x"], r.tip["y"]]], float),
                energy=np.array([float(r.energy)]), gamma=np.array([float(r.gamma)]))
    return ContinuationResult(param, br, [], scene, win, path)


def _on_with_contact(scene: Scene, options: SolverOptions, param: str, br: Branch, win):
    """The loading path with contact from the branch's touching state to the window's end the
    branch was heading for (``LoadingPath``)."""
    lam = float(br.lam[-1])
    heading_up = len(br) < 2 or br.lam[-1] >= br.lam[-2]
    end = float(win[1] if heading_up else win[0])
    return follow_contact_path(set_param(scene, param, lam), options, {param: [lam, end]},
                               initial=np.asarray(br.z[-1], float))


@register("continuation")
def run_continuation(scene, options, **settings) -> dict:
    """Settings: ``param``, ``start``, ``stop``, optional ``ds``, ``max_points``, ``switch``."""
    try:
        param, start, stop = settings.pop("param"), settings.pop("start"), settings.pop("stop")
    except KeyError as err:
        raise ValueError(f"continuation needs the setting {err.args[0]!r}") from None
    return continue_branch(scene, param, start, stop, options=options, **settings).to_dict()
