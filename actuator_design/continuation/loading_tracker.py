"""The loading-path tracker: follow the stable equilibrium along each schedule segment on the
continuation engine, locate where it loses stability and land on the state it snaps to (THEORY §7–8).

Used by :func:`~actuator_design.continuation.loading.follow_path`. Each segment is a :class:`~actuator_design.continuation.segment.SegmentProblem`
(its parameter the segment coordinate λ, every scheduled and following NLP slot moving at once, exact
G_λ) continued by pseudo-arclength steps (:func:`~actuator_design.continuation.continuation`) with the
fold and branch-point events made to stop the run. A fold is then located by the one fold locator
(:func:`~actuator_design.reduced.fold.locate_fold`, Moore–Spence along the segment); the jump lands
by IPOPT + ``ensure_stable``. A branch point (the branch continues, e.g. the symmetric pitchfork)
is left along ± the unstable eigenvector: continuous when the landing state joins (supercritical),
a jump otherwise.
"""
from __future__ import annotations

from dataclasses import replace
from typing import List, Optional, Tuple

import numpy as np

from actuator_design.continuation import PALC, BranchPoint, ContinuationSettings, Fold, continuation
from actuator_design.continuation.loading_results import Bifurcation, Jump, PathPoint
from actuator_design.continuation.segment import LensSegment, SegmentProblem, followers
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.solver import get_solver
from actuator_design.reduced.fold import locate_fold
from actuator_design.reduced.linalg import lowest_eigenpairs_dense
from actuator_design.reduced.system import reduced_system

__all__ = ["MAX_TRIALS", "Tracker"]

#: Continuation steps allowed per schedule segment before the path gives up (a safeguard).
MAX_TRIALS = 20000
#: Past a fold the landing is sought this far along the segment (λ), as before.
_PAST_FOLD = 1e-7
#: Past a branch point the unstable state is left this far in the scheduled values (far enough that
#: the unstable eigenvalue is well resolved, near enough that a supercritical branch is still close:
#: ~√d); in λ, this over the segment's span (a path in h from 0 to 300 stepped 0.03 past the
#: supercritical pitchfork at h = 1.11 and called it a snap).
_PAST_BRANCH_POINT = 1e-4
#: A stable state past a branch point this close to the critical state (max nodal |Δθ|, rad;
#: ~√(_PAST_BRANCH_POINT) with room) continues the path without a jump.
_MERGE_DTHETA = 0.1


class Tracker:
    """State of one loading path: the built solver and reduced system, the points, jumps and
    bifurcations found so far.

    Parameters
    ----------
    base : Scene
        The prepared scene (every term a scheduled parameter needs present).
    options : SolverOptions
    names : list of str
        Scheduled parameter names.
    vals : ndarray, shape (n_schedule, len(names))
    max_step : float
        Largest step (segment fraction, and arclength in the metric diag(M, 1)).
    max_dtheta : float
        Largest change of any nodal angle per step, rad.
    """

    def __init__(self, base, options, names, vals, max_step, max_dtheta):
        self.base, self.names, self.vals = base, names, vals
        self.track_opts = replace(options, method="newton", ensure_stable=False)
        self.snap_opts = replace(options, method="ipopt", ensure_stable=True)
        self.solver = get_solver(base, self.track_opts)
        self.follow = followers(base, names, vals)
        self.system = reduced_system(self.solver, list(names) + self.follow)
        self.max_step, self.max_dtheta = max_step, max_dtheta
        varying = [i for i in range(len(names)) if np.ptp(vals[:, i]) > 0]
        self.param_index = varying[0] if len(varying) == 1 else None
        self.param = names[self.param_index] if self.param_index is not None else None
        self.points: List[PathPoint] = []
        self.jumps: List[Jump] = []
        self.bifs: List[Bifurcation] = []
        self.states: List[EquilibriumResult] = []
        self.branch = 0

    # -- segments and records -------------------------------------------------------------------
    def problem(self, k: int) -> SegmentProblem:
        """The continuation problem of segment k (schedule point k to k + 1)."""
        seg = LensSegment(self.base, self.names, self.vals[k], self.vals[min(k + 1, len(self.vals) - 1)],
                          self.follow)
        return SegmentProblem(self.system, self.solver.parameter_vector(seg.scene(0.0)), seg)

    def _param_value(self, seg: LensSegment, k, lam):
        if self.param_index is None:
            return float(k + lam)
        return float(seg.values(lam)[self.names[self.param_index]])

    def _direction(self, seg: LensSegment):
        if self.param_index is None:
            return 0
        return int(np.sign(seg.vb[self.param_index] - seg.va[self.param_index]))

    def _point(self, seg, k, lam, tip, energy, mu, index, kind):
        self.points.append(PathPoint(
            t=float(k + lam), param=self._param_value(seg, k, lam), values=seg.values(lam),
            tip=tip, energy=float(energy), stable=bool(mu > 1e-9 * max(1.0, abs(mu))),
            min_eigenvalue=float(mu), morse_index=int(index), branch=self.branch,
            direction=self._direction(seg), kind=kind))

    def record(self, prob: SegmentProblem, k, lam, r: EquilibriumResult, kind):
        """Record a solved state (start, schedule point, critical state, landing)."""
        self._point(prob.segment, k, lam, {kk: float(v) for kk, v in r.tip.items()}, r.energy,
                    float(r.eigenvalues[0]), r.morse_index, kind)

    def _record_branch(self, prob: SegmentProblem, k, br, last: int):
        """Record the engine's points 1..last-1 of ``br`` (index and μ from the engine)."""
        for x, idx, mu in zip(br.x[1:last], br.morse_index[1:last], br.min_eig[1:last]):
            lam = float(x[-1])
            energy, angle, tx, ty = self.solver.summary(prob.full(x[:-1], lam), prob.params(lam))
            self._point(prob.segment, k, lam, {"x": tx, "y": ty, "angle": angle}, energy, mu, idx, "step")

    def _solve_track(self, prob, lam, z0):
        return solve(prob.segment.scene(lam), self.track_opts, initial=z0, solver=self.solver)

    def _usable(self, r: EquilibriumResult) -> bool:
        """Converged, or (next to a critical point, where the Hessian is nearly singular and Newton
        cannot confirm convergence by a small step) stationary to 100 × tol."""
        return bool(r.success or (np.isfinite(r.stationarity)
                                  and r.stationarity <= 100.0 * self.solver.options.tol))

    def _settings(self, prob: SegmentProblem) -> ContinuationSettings:
        scale = max(self.solver.residual_scale(prob.params(0.0)), self.solver.residual_scale(prob.params(1.0)))
        # steps bounded as λ ≤ max_step and max |Δθ| ≤ max_dtheta; the arclength bound never binds harder
        ds = float(np.hypot(self.max_step, self.max_dtheta))
        return ContinuationSettings(ds=ds, ds_min=1e-9, ds_max=ds, max_steps=MAX_TRIALS,
                                    window=(-np.inf, 1.0), direction=1.0, tol=self.solver.options.tol * scale,
                                    max_du=self.max_dtheta, max_dlam=self.max_step)

    @staticmethod
    def _start_tangent(prob: SegmentProblem, x0: np.ndarray) -> np.ndarray:
        """(dz/dλ, 1) = (−H⁻¹ G_λ, 1) at a stable start (H regular), shape (n + 1,)."""
        _, H, gl = prob.ev(x0[:-1], x0[-1])
        try:
            return np.append(-np.linalg.solve(H, gl), 1.0)
        except np.linalg.LinAlgError:  # a singular start: the engine's null vector instead
            return None

    # -- one segment -----------------------------------------------------------------------------
    def run_segment(self, k: int, cur: EquilibriumResult) -> Tuple[Optional[EquilibriumResult], str]:
        """Follow the stable state ``cur`` (at λ = 0 of segment k) to λ = 1.

        Returns (state at λ = 1, "") or (None, why it stopped)."""
        prob = self.problem(k)
        st = self._settings(prob)
        events = (Fold(stop=True), BranchPoint(stop=True))
        lam = 0.0
        for _ in range(MAX_TRIALS):
            if lam >= 1.0:
                break
            x0 = np.append(cur.z[1:], lam)
            br = continuation(prob, PALC(), st, events, x0=x0, tangent=self._start_tangent(prob, x0))
            if br.status == "left_window" and br.lam[-1] == 1.0:
                self._record_branch(prob, k, br, len(br) - 1)
                end = self._solve_track(prob, 1.0, prob.full(br.x[-1, :-1], 1.0))
                if not end.success:
                    return None, f"no equilibrium at the schedule point t = {k + 1}: {end.message}"
                self.record(prob, k, 1.0, end, "schedule")
                return end, ""
            self._record_branch(prob, k, br, len(br))
            stuck = br.status == "step_too_small"
            if br.status != "event" and not stuck:
                return None, (f"the stable branch could not be followed past t = {k + br.lam[-1]:.10g} "
                              f"(smallest eigenvalue {br.min_eig[-1]:.3g}): {br.message}")
            # the steps shrank to nothing in front of a fold PALC could not turn: try the locator there
            ev = br.events[-1] if not stuck else None
            if stuck or ev.kind == "fold":
                guess = br.x[-1] if stuck else ev.x
                out = self._fold(k, prob, guess, float(br.lam[-1]))
                if out is None:
                    if stuck:
                        return None, (f"the stable branch could not be followed past t = {k + br.lam[-1]:.10g} "
                                      f"(smallest eigenvalue {br.min_eig[-1]:.3g}): {br.message}")
                    return None, f"no stable state to land on after the fold at t = {k + ev.lam:.10g}"
            else:
                out = self._bifurcation(k, prob, ev, float(br.lam[-1]))
                if out is None:
                    return None, f"no stable state after the bifurcation at t = {k + ev.lam:.10g}"
            lam, cur = out
        else:
            return None, f"gave up after {MAX_TRIALS} critical points in segment {k} (t = {k + lam:.10g})"
        return cur, ""

    # -- critical points ------------------------------------------------------------------------
    def _fold(self, k, prob: SegmentProblem, guess: np.ndarray, lam_last: float):
        """Locate the fold by Moore–Spence from ``guess`` = (u, λ) (the engine's event), then jump (or
        stop on it when it lies at the segment's end); ``lam_last`` is the last accepted λ.
        Returns (λ, state) to continue from, or None."""
        tol = max(self.solver.options.tol, 1e-11)
        n = prob.n
        _, H, _ = prob.ev(guess[:n], guess[n])  # null-vector guess: the lowest mode (the one at zero)
        v0 = lowest_eigenpairs_dense(np.array(H), 1.0 / prob.mass, 1)[1]
        fp = locate_fold(self.system, prob.P, guess[:n], guess[n], v0, path=prob.segment.point, tol=tol)
        if not (fp.converged and lam_last - 1e-9 <= fp.lam <= 1.0 + 1e-9):
            return None
        lam_c = min(fp.lam, 1.0)
        z_c = prob.full(fp.u, lam_c)
        if lam_c >= 1.0 - 1e-12:  # the fold is the schedule point (within rounding): stop on it
            r = self._solve_track(prob, 1.0, z_c)
            if not r.success:
                return None
            self.record(prob, k, 1.0, r, "schedule")
            return 1.0, r
        p = prob.segment.point(lam_c)[0]
        v = fp.v / np.max(np.abs(fp.v)) * (1.0 if fp.v[-1] >= 0 else -1.0)
        _, J, _ = self.system.f_fold(fp.u, p, v, v, prob.P)
        # C = ∂³Ê[v, v, v]: the energy along v is ~ t (v·g) + C t³/6 past the fold
        C = float(v @ (np.asarray(J)[n:2 * n, :n] @ v))
        from_state = self._solve_track(prob, lam_c, z_c)
        s0 = -1 if C > 0 else 1
        landing, _ = self._land(prob, min(lam_c + _PAST_FOLD, 1.0), z_c, np.concatenate([[0.0], v]), (s0, -s0))
        if landing is None:
            return None
        to_state = self._solve_track(prob, lam_c, landing.z)
        if not (to_state.success and to_state.stable):
            to_state = landing
        self.record(prob, k, lam_c, from_state, "critical")
        self.branch += 1
        self.record(prob, k, lam_c, to_state, "landing")
        seg = prob.segment
        self.jumps.append(Jump(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                               values=seg.values(lam_c), direction=self._direction(seg), kind="fold",
                               from_state=from_state, to_state=to_state,
                               energy_released=float(from_state.energy - to_state.energy)))
        return lam_c, to_state

    def _land(self, prob, lam, z_from, v, signs):
        """Relax from z_from ± ε v with IPOPT + ensure_stable at λ; first stable landing that left
        z_from (max |Δθ| > 1e-3), trying the signs in order."""
        sc = prob.segment.scene(lam)
        for s in signs:
            for eps in (0.05, 0.2, 0.5):
                r = solve(sc, self.snap_opts, initial=z_from + s * eps * v, solver=self.solver)
                if r.success and r.stable and np.max(np.abs(r.z - z_from)) > 1e-3:
                    return r, s
        return None, 0

    def _merge_point(self, prob: SegmentProblem, ru: EquilibriumResult, lam_s: float, lam_last: float):
        """Where the branch the path merges onto (stable at ``lam_s``, the state ``ru``) loses
        stability: the pitchfork itself. The engine's event is located on the step of the ending
        branch, whose corrected points jump onto this one somewhere in between (a path lowering h
        through the buckling field placed it 1.2e-3 off); here this branch is continued back from
        ``ru`` towards ``lam_last`` and its own branch point located by the engine (as on a path
        that meets the pitchfork from this side). (λ, state) there, or None when that finds none."""
        n = prob.n
        settings = replace(self._settings(prob), window=(min(lam_last, lam_s), lam_s), direction=-1.0)
        x0 = np.append(ru.z[1:], lam_s)
        t0 = self._start_tangent(prob, x0)
        br = continuation(prob, PALC(), settings, (BranchPoint(stop=True),), x0=x0,
                          tangent=None if t0 is None else -t0)
        ev = br.events[-1] if br.status == "event" and br.events else None
        if ev is None or not ev.located:
            return None
        lam = float(ev.lam)
        r = self._solve_track(prob, lam, prob.full(ev.x[:n], lam))
        return (lam, r) if self._usable(r) else None

    def _bifurcation(self, k, prob: SegmentProblem, ev, lam_last: float):
        """Leave the branch just past a branch point at λ_c; continuous (supercritical) or a jump
        (``lam_last``: the last accepted λ before it). Returns (λ, state) to continue from, or None."""
        n, seg = prob.n, prob.segment
        lam_c = float(ev.lam)
        rc = self._solve_track(prob, lam_c, prob.full(ev.x[:n], lam_c))
        d = min(_PAST_BRANCH_POINT / seg.span, 1.0 - lam_c)  # (a step of the scheduled values, not of λ)
        lam_s = lam_c + d
        t = ev.tangent
        slope = t[:n] / t[n] if t is not None and abs(t[n]) > 1e-12 else np.zeros(n)
        ru = self._solve_track(prob, lam_s, prob.full(ev.x[:n] + d * slope, lam_s))
        if not self._usable(ru):  # a tangent nearly normal to λ (the branch ends here): from the point
            ru = self._solve_track(prob, lam_s, prob.full(ev.x[:n], lam_s))
        if not self._usable(ru):
            return None
        if ru.stable and np.max(np.abs(ru.z - rc.z)) <= _MERGE_DTHETA:
            # the followed branch ends on a branch that is stable past λ_c (a supercritical pitchfork
            # crossed from its bent side, e.g. a field lowered through the buckling field): the rod
            # goes on continuously on that branch; nothing to choose (sign 0)
            merged = self._merge_point(prob, ru, lam_s, lam_last)
            located = merged is not None
            lam_c, rc = merged if located else (lam_c, rc)
            self.record(prob, k, lam_c, rc, "critical")
            self.bifs.append(Bifurcation(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                                         values=seg.values(lam_c), direction=self._direction(seg),
                                         state=rc, sign=0, located=located))
            self.record(prob, k, lam_s, ru, "landing")
            return lam_s, ru
        _, H, _ = prob.ev(ru.z[1:], lam_s)
        _, v = lowest_eigenpairs_dense(np.array(H), 1.0 / prob.mass, 1)
        v = np.concatenate([[0.0], v / np.max(np.abs(v))])
        v *= 1.0 if v[-1] >= 0 else -1.0
        cands = []
        for s in (1, -1):
            r, _ = self._land(prob, lam_s, ru.z, v, (s,))
            if r is not None:
                cands.append((r.energy, -s, r, s))
        if not cands:
            return None
        cands.sort(key=lambda c: (round(c[0], 10), c[1]))
        _, _, landing, sign = cands[0]
        released = float(ru.energy - landing.energy)
        self.record(prob, k, lam_c, rc, "critical")
        if released <= 1e-6 * max(1.0, abs(ru.energy)):
            self.bifs.append(Bifurcation(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                                         values=seg.values(lam_c), direction=self._direction(seg),
                                         state=rc, sign=sign, located=bool(ev.located)))
            self.record(prob, k, lam_s, landing, "landing")
            return lam_s, landing
        to_state = self._solve_track(prob, lam_c, landing.z)
        if not (to_state.success and to_state.stable):
            to_state = landing
        self.branch += 1
        self.record(prob, k, lam_c, to_state, "landing")
        self.jumps.append(Jump(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                               values=seg.values(lam_c), direction=self._direction(seg),
                               kind="subcritical", from_state=rc, to_state=to_state,
                               energy_released=float(rc.energy - to_state.energy)))
        return lam_c, to_state
