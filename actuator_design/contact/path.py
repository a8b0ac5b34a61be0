"""Loading paths through contact: touch-down and lift-off as located events (issue 20 item 4).

A scene with obstacles is followed along its schedule by contact equilibria
(:func:`actuator_design.contact.equilibrium.solve_contact`), each warm-started from the state before it: the
quasi-static history, not a fresh start from rest. Steps are at most ``max_step`` of a segment and
move no nodal angle more than ``max_dtheta``; a step that moves more is halved, and a change that
stays large as the step shrinks to :data:`MIN_STEP` is a snap (a ``Jump`` of kind ``"contact"``),
located like a fold: the end of the followed branch, by bisection to :data:`EVENT_XTOL`.

**Events.** Between two states the set of obstacles in contact may change. Obstacle k's event is
located as the root of its gap function

    g_k(t) = min_s d_k(r(s; t)) − gap,

r(·; t) the equilibrium at path coordinate t *without* obstacle k (the other obstacles kept). On
the free side g_k > 0; on the contact side the rod would enter the obstacle, g_k < 0; at a
touch-down or a lift-off the contact force is zero, so the free state just touches: g_k = 0 at
both. g_k is smooth in t (one branch of free states), so Brent's method locates the event to
:data:`EVENT_XTOL` in t where a bisection of the contact solves would need ~30 of them. Where g_k
has the same sign at both ends of the step (over a long step the free rod may bend past a peg), it
is searched at :data:`SCAN` points from the free end for its first sign change; where it has none
(a grazing touch) the event is reported at the step, ``located`` False.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Dict, List, Optional

import numpy as np

from actuator_design.contact.nearest import nearest_pair
from actuator_design.contact.self_contact import REACH, self_penetration
from actuator_design.continuation.loading_results import Jump, LoadingPath, PathPoint
from actuator_design.continuation.loading_schedule import apply_values, checked_schedule
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult

__all__ = ["follow_contact_path", "EVENT_XTOL", "MIN_STEP"]

#: an event's path coordinate is located to this (in t: fractions of a schedule segment)
EVENT_XTOL = 1e-10
#: the smallest step, as a fraction of a segment: a state change above max_dtheta over it is a snap
MIN_STEP = 1e-4
#: steps a snap's bisection retries a solve in that overshot the end of the followed branch
SUBSTEPS = 4
#: samples of a step searched for the sign change of g_k when its two ends have the same sign
SCAN = 16
#: a free state whose gap function is within this of zero touches (rod lengths): a path started
#: at a continuation's located touch has its touch-down there
TOUCH_GTOL = 1e-9
_S = np.linspace(0.0, 1.0, 401)  # arc lengths at which shapes are compared and gaps measured


def follow_contact_path(scene, options: Optional[SolverOptions] = None, schedule=(), *,
                        max_step: Optional[float] = None, max_dtheta: float = 0.3,
                        initial=None) -> LoadingPath:
    """Follow the contact equilibrium of ``scene`` (with obstacles) quasi-statically along ``schedule``.

    Parameters
    ----------
    scene : Scene
        With at least one obstacle; values not named in the schedule stay fixed.
    options : SolverOptions, optional
    schedule : list of dict, or dict of lists
        As for :func:`~actuator_design.continuation.loading.follow_path` (names of the parameter lens, dimensionless, rad).
    max_step : float, optional
        Largest step, a fraction of a segment (0 < max_step ≤ 1); default min(1, n_segments/20).
    max_dtheta : float
        Largest change of θ(s) per step, rad.
    initial : ndarray of shape (n_nodes,) or EquilibriumResult, optional
        Warm start of the first state (a continuation's state where the rod touches, so the path
        goes on from that branch); default: the first state is solved from rest.

    Returns
    -------
    LoadingPath
        Its ``points`` include the located events (``kind`` ``"touch-down"`` or ``"lift-off"``),
        ``point_states`` holds each point's equilibrium (EquilibriumResult, in the order of ``points``),
        ``contact_events`` lists them (path coordinate, parameter values, obstacle, arc length of
        the touching point, ``located``), ``jumps`` the snaps. ``success`` False names the first
        state that could not be followed (not converged, or unstable).
    """
    options = options or SolverOptions()
    base, names, vals, max_step = checked_schedule(scene, schedule, max_step, max_dtheta)
    run = _Run(base, options, names, vals)
    return run.follow(max_step, max_dtheta, initial)


class _Run:
    """One contact path: the schedule as a function of t, the states and the records."""

    def __init__(self, base, options, names, vals):
        self.base, self.options, self.names, self.vals = base, options, names, vals
        self.n_seg = len(vals) - 1
        moving = [n for j, n in enumerate(names) if np.ptp(vals[:, j]) > 0]
        self.param = moving[0] if len(moving) == 1 else None
        self.points: List[PathPoint] = []
        self.jumps: List[Jump] = []
        self.events: List[dict] = []
        self.states: List[EquilibriumResult] = []
        self.point_states: List[EquilibriumResult] = []  # the state of each point, in record order

    # -- the schedule ---------------------------------------------------------------------------
    def values(self, t: float) -> Dict[str, float]:
        k = min(int(math.floor(t)), self.n_seg - 1)
        lam = t - k
        row = self.vals[k] + lam * (self.vals[k + 1] - self.vals[k])
        return dict(zip(self.names, (float(v) for v in row)))

    def scene(self, t: float, without: Optional[int] = None):
        sc = apply_values(self.base, self.values(t))
        if without is not None:
            sc = replace(sc, obstacles=tuple(ob for i, ob in enumerate(sc.obstacles) if i != without))
        return sc

    def direction(self, t: float) -> int:
        if self.param is None:
            return 0
        j = self.names.index(self.param)
        k = min(int(math.floor(t)), self.n_seg - 1)
        return int(np.sign(self.vals[k + 1, j] - self.vals[k, j]))

    def record(self, r: EquilibriumResult, t: float, kind: str) -> None:
        vals = self.values(t)
        self.point_states.append(r)
        self.points.append(PathPoint(
            t=float(t), param=float(vals[self.param]) if self.param else float(t), values=vals,
            tip={k: float(v) for k, v in r.tip.items()}, energy=float(r.energy), stable=bool(r.stable),
            min_eigenvalue=float(r.eigenvalues[0]), morse_index=int(r.morse_index), branch=len(self.jumps),
            direction=self.direction(t), kind=kind))

    # -- following --------------------------------------------------------------------------------
    def follow(self, max_step: float, max_dtheta: float, initial=None) -> LoadingPath:
        first = solve(self.scene(0.0), self.options, initial=initial)
        self.record(first, 0.0, "start")
        self.states.append(first)
        cur, t, step, msg = first, 0.0, max_step, ""
        ok = bool(first.success and first.stable)
        if not ok:
            msg = f"no stable starting state: {first.message}"
        while ok and t < self.n_seg:
            t_next = min(t + step, math.floor(t + 1e-12) + 1.0)
            r = solve(self.scene(t_next), self.options, initial=cur)
            change = _shape_change(cur, r) if r.success else math.inf
            if (not r.success or change > max_dtheta) and step > MIN_STEP:
                step = max(0.5 * step, MIN_STEP)
                continue
            if not r.success:
                ok, msg = False, f"no contact equilibrium at t = {t_next:.6g} ({self._where(t_next)}): {r.message}"
                break
            if not r.stable:
                ok, msg = False, (f"the followed state is unstable at t = {t_next:.6g} ({self._where(t_next)}): "
                                  f"Morse index {r.morse_index}")
                break
            if change > max_dtheta:  # large over the smallest step: the rod snapped
                t_snap, last = self._snap(cur, t, t_next, max_dtheta)
                if t_snap > t:
                    self.record(last, t_snap, "step")
                after = solve(self.scene(t_snap), self.options, initial=r)
                after = after if after.success and _shape_change(r, after) <= max_dtheta else r
                self.jumps.append(Jump(t=t_snap, param=self.points[-1].param if self.param is None
                                       else self.values(t_snap)[self.param], values=self.values(t_snap),
                                       direction=self.direction(t_snap), kind="contact", from_state=last,
                                       to_state=after, energy_released=float(last.energy - after.energy)))
            else:
                self._events(cur, r, t, t_next)
            at_schedule = abs(t_next - round(t_next)) <= 1e-12
            self.record(r, t_next, "schedule" if at_schedule else "step")
            if at_schedule:
                self.states.append(r)
            cur, t, step = r, t_next, min(max_step, 2.0 * step)
        if ok:
            msg = (f"followed {self.n_seg} segment(s) with contact: {len(self.events)} contact event(s) "
                   f"({_count(self.events, 'touch-down')} touch-down, {_count(self.events, 'lift-off')} lift-off), "
                   f"{len(self.jumps)} jump(s)")
        order = sorted(range(len(self.points)), key=lambda i: self.points[i].t)
        path = LoadingPath(names=self.names, schedule=self.vals, param=self.param,
                           points=[self.points[i] for i in order], jumps=self.jumps, bifurcations=[],
                           snap_free=bool(ok and not self.jumps),
                           hysteresis={"width": 0.0, "area": 0.0, "loops": [],
                                       "note": "hysteresis is not computed for paths with contact"},
                           states=self.states, final=cur, success=ok, message=msg)
        path.contact_events = sorted(self.events, key=lambda e: e["t"])
        path.point_states = [self.point_states[i] for i in order]
        return path

    def _snap(self, cur: EquilibriumResult, ta: float, tb: float, max_dtheta: float):
        """(t*, state): where the followed contact branch ends in [ta, tb] (its fold), by bisection
        to :data:`EVENT_XTOL`: the last t whose contact solve, warm-started from the state before,
        stays stable and on the branch (a change of θ within ``max_dtheta``)."""
        def on_branch(r, prev):
            return r.success and r.stable and _shape_change(prev, r) <= max_dtheta

        def reach(t_from, t_to, state):  # near a fold one IPOPT solve may overshoot the branch's
            r = solve(self.scene(t_to), self.options, initial=state)  # end: a miss is retried in
            if on_branch(r, state):  # SUBSTEPS steps before t_to counts as past the fold
                return r
            for t_k in np.linspace(t_from, t_to, SUBSTEPS + 1)[1:]:
                r = solve(self.scene(t_k), self.options, initial=state)
                if not on_branch(r, state):
                    return None
                state = r
            return state

        last = cur
        while tb - ta > EVENT_XTOL * max(1.0, abs(ta)):
            tm = 0.5 * (ta + tb)
            r = reach(ta, tm, last)
            if r is not None:
                ta, last = tm, r
            else:
                tb = tm
        return ta, last

    def _where(self, t: float) -> str:
        return ", ".join(f"{k} = {v:.6g}" for k, v in self.values(t).items())

    # -- events -----------------------------------------------------------------------------------
    def _events(self, a: EquilibriumResult, b: EquilibriumResult, ta: float, tb: float) -> None:
        before, after = _touching(a), _touching(b)
        for k in sorted(before ^ after, key=str):
            kind = "touch-down" if k in after else "lift-off"
            free_side, contact_side = (a, b) if kind == "touch-down" else (b, a)
            t_star, s_star, located = self._locate(k, ta, tb, a, free_side)
            state = solve(self.scene(t_star), self.options, initial=a) if located else b
            vals = self.values(t_star)
            self.events.append({"kind": kind, "t": float(t_star),
                                "param": float(vals[self.param]) if self.param else float(t_star),
                                "values": vals, "obstacle": None if k == SELF else int(k),
                                "obstacle_text": "rod itself" if k == SELF else self.base.obstacles[k].describe(),
                                "s": s_star, "located": located})
            if state.success:
                self.record(state, t_star, kind)

    def _locate(self, k: int, ta: float, tb: float, a: EquilibriumResult, free_side: EquilibriumResult):
        """(t*, s*, located): the root of g_k on [ta, tb] (module doc) and the touching point."""
        warm = {"state": free_side}

        def gap(t):
            if k == SELF:  # the rod solved without self-contact, the free branch through the event
                r = solve(self.scene(t), replace(self.options, self_contact=False, keep_self_intersecting=True),
                          initial=warm["state"])
            else:
                r = solve(self.scene(t, without=k), self.options, initial=warm["state"])
            if not r.success:
                raise _NoFreeState
            warm["state"] = r
            return _min_self_gap(r, self.base.contact_gap) if k == SELF else _min_gap(self.base, k, r)

        try:
            t_free = ta if free_side is a else tb
            g_free = gap(t_free)
            if abs(g_free[0]) <= TOUCH_GTOL:  # the step starts (or ends) touching: the event is there
                return t_free, g_free[1], True
            lo, hi = ta, tb
            if not gap(ta)[0] * gap(tb)[0] < 0:
                lo, hi = self._bracket(gap, ta if free_side is a else tb, tb if free_side is a else ta)
            from scipy.optimize import brentq  # on first use: scipy.optimize costs 0.1 s at start-up
            t_star = brentq(lambda t: gap(t)[0], min(lo, hi), max(lo, hi), xtol=EVENT_XTOL,
                            rtol=4 * np.finfo(float).eps)
            return t_star, gap(t_star)[1], True
        except _NoFreeState:
            return tb, None, False

    @staticmethod
    def _bracket(gap, t_free: float, t_contact: float):
        """Where g_k first changes sign walking from the free end of a step to its contact end
        (:data:`SCAN` steps): over a long step the free rod may pass the obstacle by and keep
        g_k > 0 at both ends (a rod bending past a peg)."""
        g_free, prev = gap(t_free)[0], t_free
        for t in np.linspace(t_free, t_contact, SCAN + 1)[1:]:
            if g_free * gap(t)[0] < 0:
                return prev, t
            prev = t
        raise _NoFreeState


class _NoFreeState(Exception):
    """The state without the obstacle could not be followed, or its gap does not change sign."""


def _min_gap(base, k: int, r: EquilibriumResult):
    """(g, s): the least distance of the centre line of ``r`` to obstacle k less the gap, and where:
    the best of :data:`_S`, refined by a bounded scalar minimisation between its neighbours."""
    ob, gap = base.obstacles[k], base.contact_gap

    def dist(s):
        d = r.evaluate(np.atleast_1d(s))
        return np.asarray(ob.distance(d["x"], d["y"]), float) - gap

    i = int(np.argmin(dist(_S)))
    lo, hi = _S[max(i - 1, 0)], _S[min(i + 1, _S.size - 1)]
    from scipy.optimize import minimize_scalar  # on first use, as brentq
    best = minimize_scalar(lambda s: float(dist(s)[0]), bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-13})
    cands = [(float(dist(_S[i])[0]), float(_S[i])), (float(best.fun), float(best.x)), (float(dist(1.0)[0]), 1.0)]
    return min(cands)


#: the key of the rod's contact with itself among the obstacles' indices (:func:`_touching`)
SELF = "self"


def _touching(r: EquilibriumResult) -> set:
    """Obstacles pressing on the rod (a strong contact: a positive force), and :data:`SELF` where
    the rod presses on itself."""
    return {SELF if p.get("self") else p["obstacle"] for p in (r.contact or {}).get("points", []) if not p["weak"]}


def _min_self_gap(r: EquilibriumResult, gap: float):
    """(g, s): the least distance between non-neighbouring points of ``r``'s centre line less twice
    the gap, and where (the point of lower arc length): the nearest pair of :data:`_S` (the clamp
    included), refined to the nearest points of the two curves; (REACH, None) when no pair is
    within 2·gap + REACH."""
    near = self_penetration(r, gap, n=_S.size, tol=-REACH)
    if near is None:
        return REACH, None
    a, b = nearest_pair(r, near[0], near[1], 2.0 / (_S.size - 1))
    d = r.evaluate(np.array([a, b]))
    return float(np.hypot(d["x"][1] - d["x"][0], d["y"][1] - d["y"][0])) - 2.0 * gap, float(a)


def _shape_change(a: EquilibriumResult, b: EquilibriumResult) -> float:
    """max_s |θ_b(s) − θ_a(s)| (rad)."""
    return float(np.max(np.abs(b.evaluate(_S)["theta"] - a.evaluate(_S)["theta"])))


def _count(events, kind: str) -> int:
    return sum(e["kind"] == kind for e in events)
