"""The loading-path tracker: follow the stable equilibrium along one schedule segment, locate the
critical point where it loses stability and land on the state it snaps to (THEORY §7–8).

Used by :func:`~.loading.follow_path`; its numerics come from the reduced toolkit
(:mod:`actuator_design.reduced`): lowest eigenpairs of (H, M), and Newton on the augmented system
g = 0, μ_min = 0 for folds (derivatives of μ by Hellmann–Feynman from the reduced system's third
derivatives).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, List

import numpy as np
from scipy.optimize import brentq

from .. import parameters as lens
from ..equilibrium import solve
from ..reduced.linalg import lowest_eigenpairs_dense
from ..reduced.newton import newton
from ..result import EquilibriumResult
from ..scene import Scene
from ..solver import get_solver
from .loading_results import Bifurcation, Jump, PathPoint
from .stiffness import sensitivities

__all__ = ["MAX_TRIALS", "Segment", "Tracker"]

#: Trial steps allowed per schedule segment before the path gives up (a safeguard).
MAX_TRIALS = 20000


# -- the tracker ---------------------------------------------------------------------------------
class Segment:
    """Parameter values and NLP parameter vectors along one schedule segment, λ ∈ [0, 1]."""

    def __init__(self, base: Scene, names, va, vb, solver):
        self.base, self.names, self.va, self.vb, self.solver = base, names, va, vb, solver

    def values(self, lam: float) -> Dict[str, float]:
        v = self.va + lam * (self.vb - self.va)
        out = dict(zip(self.names, map(float, v)))
        for n in out:  # a λ slightly past a segment end must not leave the parameter's range
            par = lens.parameter(n)
            out[n] = min(max(out[n], par.lower), par.upper)
        return out

    def scene(self, lam: float) -> Scene:
        return lens.apply_values(self.base, self.values(lam), "path parameter")

    def params(self, lam: float) -> np.ndarray:
        return self.solver.parameter_vector(self.scene(lam))

    def dparams(self, lam: float, d: float = 1e-6) -> np.ndarray:
        """dP/dλ by central differences (exact for the parameters that enter P linearly)."""
        return (self.params(lam + d) - self.params(lam - d)) / (2.0 * d)


class Tracker:
    def __init__(self, base, options, names, vals, max_step, max_dtheta):
        self.base, self.names, self.vals = base, names, vals
        self.track_opts = replace(options, method="newton", ensure_stable=False)
        self.snap_opts = replace(options, method="ipopt", ensure_stable=True)
        self.solver = get_solver(base, self.track_opts)
        self.sens = sensitivities(self.solver)
        self.M = self.solver.transcription.mass[1:]
        self.max_step, self.max_dtheta = max_step, max_dtheta
        varying = [i for i in range(len(names)) if np.ptp(vals[:, i]) > 0]
        self.param_index = varying[0] if len(varying) == 1 else None
        self.param = names[self.param_index] if self.param_index is not None else None
        self.points: List[PathPoint] = []
        self.jumps: List[Jump] = []
        self.bifs: List[Bifurcation] = []
        self.states: List[EquilibriumResult] = []
        self.branch = 0

    # -- small helpers --------------------------------------------------------------------------
    def _param_value(self, seg, k, lam):
        if self.param_index is None:
            return float(k + lam)
        return float(seg.va[self.param_index] + lam * (seg.vb[self.param_index] - seg.va[self.param_index]))

    def _direction(self, seg):
        if self.param_index is None:
            return 0
        return int(np.sign(seg.vb[self.param_index] - seg.va[self.param_index]))

    def _record(self, seg, k, lam, r: EquilibriumResult, kind):
        self.points.append(PathPoint(
            t=float(k + lam), param=self._param_value(seg, k, lam), values=seg.values(lam),
            tip={kk: float(v) for kk, v in r.tip.items()}, energy=float(r.energy), stable=bool(r.stable),
            min_eigenvalue=float(r.eigenvalues[0]), morse_index=int(r.morse_index), branch=self.branch,
            direction=self._direction(seg), kind=kind))

    def _solve_track(self, seg, lam, z0):
        return solve(seg.scene(lam), self.track_opts, initial=z0, solver=self.solver)

    def _usable(self, r: EquilibriumResult) -> bool:
        """Converged, or (next to a critical point, where the Hessian is nearly singular and Newton
        cannot confirm convergence by a small step) stationary to 100 × tol."""
        return bool(r.success or (np.isfinite(r.stationarity)
                                  and r.stationarity <= 100.0 * self.solver.options.tol))

    def _eig(self, zr, P):
        """Smallest eigenvalue μ of (H_r, M_r), its eigenvector v (v = M^-1/2 u, |u| = 1), H, g."""
        _, g, H = self.solver.f_grad_hess(zr, P)
        H, g = np.asarray(H, float), np.asarray(g, float).ravel()
        lam, v = lowest_eigenpairs_dense(H, 1.0 / self.M, 1)
        return float(lam[0]), v, H, g

    def _tangent(self, seg, lam, z):
        """dz/dλ = −H⁻¹ ∂g/∂λ along the branch (free nodes; clamp node from dθ0/dλ)."""
        P, dP = seg.params(lam), seg.dparams(lam)
        _, g, H = self.solver.f_grad_hess(z[1:], P)
        gl = np.asarray(self.sens.g_P(z[1:], P), float) @ dP
        out = np.zeros_like(z)
        try:
            out[1:] = -np.linalg.solve(np.asarray(H, float), gl)
        except np.linalg.LinAlgError:
            return out
        out[0] = dP[self.solver.layout.slices["theta0"]][0]
        return out if np.all(np.isfinite(out)) else np.zeros_like(z)

    # -- critical points ------------------------------------------------------------------------
    def _fold_newton(self, seg, lam, z, lam_max, tol):
        """Newton on (g = 0, μ_min = 0) in (z_free, λ) from (λ, z).

        The Jacobian row of μ comes from Hellmann–Feynman: ∂μ = vᵀ ∂H v (v the M-normalised
        eigenvector), i.e. third derivatives of the energy contracted twice with v.

        Returns
        -------
        (λ_c, z_c, v, C, transversality) or None
            z_c the critical state (full node vector), v the null eigenvector (max |v| = 1, positive
            at the tip, 0 at the clamp), C = ∂³E[v, v, v] (its sign decides the snap direction),
            transversality = |v·∂g/∂λ| / (|v| |∂g/∂λ|): O(1) at a fold, 0 at a symmetric
            bifurcation.
        """
        m = self.M
        n = m.size

        def augmented(x):
            zr, lam = x[:n], x[n]
            P, dP = seg.params(lam), seg.dparams(lam)
            mu, v, H, g = self._eig(zr, P)
            gl = np.asarray(self.sens.g_P(zr, P), float) @ dP
            mz, mP = (np.asarray(a, float).ravel() for a in self.sens.third(zr, P, v))
            J = np.block([[H, gl[:, None]], [mz[None, :], np.array([[float(mP @ dP)]])]])
            return np.concatenate([g, [mu]]), J

        def left(x):
            return not (-0.5 < x[n] < lam_max + 0.5) or np.max(np.abs(x[:n] - z[1:])) > 3.0

        def small(F, dx):  # residual small at the last iterate and the step that left it tiny
            return (max(np.max(np.abs(F[:n] / m)), abs(F[n])) <= tol and np.max(np.abs(dx[:n])) <= 1e-9
                    and abs(dx[n]) <= 1e-12)

        x, ok, _ = newton(augmented, np.append(z[1:], lam), lambda x_, F: False, 40,
                          converged_after_step=small, reject=left)
        if not ok:
            return None
        zr, lam = x[:n], float(x[n])
        P = seg.params(lam)
        mu, v, H, g = self._eig(zr, P)
        if max(np.max(np.abs(g / m)), abs(mu)) > 1e3 * tol:
            return None
        v = v / np.max(np.abs(v)) * (1.0 if v[-1] >= 0 else -1.0)
        C = float(np.dot(np.asarray(self.sens.third(zr, P, v)[0], float).ravel(), v))
        zc = np.concatenate([[P[self.solver.layout.slices["theta0"]][0]], zr])
        vz = np.concatenate([[0.0], v])
        dP = seg.dparams(lam)
        gl = np.asarray(self.sens.g_P(zr, P), float) @ dP
        transversality = abs(float(v @ gl)) / (np.linalg.norm(v) * max(np.linalg.norm(gl), 1e-300))
        return lam, zc, vz, C, transversality

    def _bisect_mu(self, seg, lam_a, z_a, lam_b):
        """Root of μ_min(λ) on the followed branch in [lam_a, lam_b] (μ > 0 at a, < 0 at b)."""
        cache = {}
        tangent = self._tangent(seg, lam_a, z_a)

        def f(lam):
            r = self._solve_track(seg, lam, z_a + (lam - lam_a) * tangent)
            cache[lam] = r
            return float(r.eigenvalues[0]) if self._usable(r) else np.nan

        fa, fb = f(lam_a), f(lam_b)
        if not (fa > 0 > fb):
            return None
        try:
            lam_c = brentq(f, lam_a, lam_b, xtol=1e-13, rtol=1e-15, maxiter=100)
        except (ValueError, RuntimeError):  # a NaN (failed solve) inside the bracket
            return None
        r = cache.get(lam_c) or self._solve_track(seg, lam_c, z_a)
        return lam_c, r

    def _land(self, seg, lam, z_from, v, signs):
        """Relax from z_from ± ε v with IPOPT + ensure_stable at λ; first stable landing that left
        z_from (max |Δθ| > 1e-3), trying the signs in order."""
        sc = seg.scene(lam)
        for s in signs:
            for eps in (0.05, 0.2, 0.5):
                r = solve(sc, self.snap_opts, initial=z_from + s * eps * v, solver=self.solver)
                if r.success and r.stable and np.max(np.abs(r.z - z_from)) > 1e-3:
                    return r, s
        return None, 0

    # -- one segment -----------------------------------------------------------------------------
    def run_segment(self, k, seg: Segment, cur: EquilibriumResult):
        lam, step = 0.0, self.max_step
        tol = self.solver.options.tol
        min_step = 1e-10
        for _ in range(MAX_TRIALS):
            if lam >= 1.0:
                break
            step = min(step, 1.0 - lam)
            trial = lam + step
            tan = self._tangent(seg, lam, cur.z)
            pred = cur.z + step * tan
            r = self._solve_track(seg, trial, pred)
            mu0 = float(cur.eigenvalues[0])
            ok = (r.success and np.max(np.abs(r.z - cur.z)) <= self.max_dtheta
                  and np.max(np.abs(r.z - pred)) <= 0.5 * self.max_dtheta)
            if ok and r.stable and (float(r.eigenvalues[0]) >= 0.25 * mu0 or mu0 < 1e-6 * (1 + abs(mu0))
                                    or step <= 1e-6):
                lam, cur = trial, r
                self._record(seg, k, lam, r, "schedule" if lam >= 1.0 else "step")
                step = min(2.0 * step, self.max_step)
                continue
            if ok and r.stable:  # μ dropped steeply but is still positive: approach more slowly
                step *= 0.5
                continue
            # the step failed, left the branch, or crossed μ = 0: is there a critical point ahead?
            crit = None
            if mu0 < 0.5 or step <= 1e-3 or (ok and not r.stable):
                crit = self._fold_newton(seg, lam, cur.z, trial, max(tol, 1e-11))
                if crit is not None and not (lam - 1e-9 <= crit[0] <= trial + 1e-9):
                    crit = None
            if crit is not None and crit[0] >= 1.0 - 1e-12:
                # the fold lies at the segment end (within rounding): the schedule stops on it
                r = self._solve_track(seg, 1.0, crit[1])
                if r.success:
                    lam, cur = 1.0, r
                    self._record(seg, k, lam, r, "schedule")
                    continue
            if crit is not None and crit[4] > 1e-6:
                cur = self._handle_fold(k, seg, crit, cur)
                if cur is None:
                    return None, f"no stable state to land on after the fold at t = {k + crit[0]:.10g}"
                lam = min(max(crit[0], lam), 1.0)
                step = min(self.max_step, max(step, 1e-3))
                continue
            if ok and not r.stable:
                out = self._bisect_mu(seg, lam, cur.z, trial)
                if out is not None:
                    lam_c, rc = out
                    res = self._handle_bifurcation(k, seg, lam_c, rc)
                    if res is None:
                        return None, f"no stable state after the bifurcation at t = {k + lam_c:.10g}"
                    lam, cur = res
                    step = min(self.max_step, max(step, 1e-3))
                    continue
            if step <= min_step:
                return None, (f"the stable branch could not be followed past t = {k + lam:.10g} "
                              f"(smallest eigenvalue {mu0:.3g}): {r.message}")
            step *= 0.5
        else:
            return None, f"gave up after {MAX_TRIALS} trial steps in segment {k} (t = {k + lam:.10g})"
        return cur, ""

    def _handle_fold(self, k, seg, crit, cur):
        lam_c, z_c, v, C, _ = crit
        sc = seg.scene(lam_c)
        from_state = solve(sc, self.track_opts, initial=z_c, solver=self.solver)
        # push just past the fold; the energy along v is ~ t·(v·g) + C t³/6: descend where C t < 0
        lam_s = min(lam_c + 1e-7, 1.0)
        s0 = -1 if C > 0 else 1
        landing, sign = self._land(seg, lam_s, z_c, v, (s0, -s0))
        if landing is None:
            return None
        to_state = self._solve_track(seg, lam_c, landing.z)
        if not (to_state.success and to_state.stable):
            to_state = landing
        self._record(seg, k, lam_c, from_state, "critical")
        self.branch += 1
        self._record(seg, k, lam_c, to_state, "landing")
        self.jumps.append(Jump(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                               values=seg.values(lam_c), direction=self._direction(seg), kind="fold",
                               from_state=from_state, to_state=to_state,
                               energy_released=float(from_state.energy - to_state.energy)))
        return to_state

    def _handle_bifurcation(self, k, seg, lam_c, rc):
        """Leave the branch just past a bifurcation at λ_c; continuous (supercritical) or a jump."""
        # leave far enough that the unstable eigenvalue is well resolved, near enough that a
        # supercritical branch is still close (amplitude ~ √d)
        d = min(1e-4, 1.0 - lam_c)
        lam_s = lam_c + d
        ru = self._solve_track(seg, lam_s, rc.z + d * self._tangent(seg, lam_c, rc.z))
        if not self._usable(ru):
            return None
        P = seg.params(lam_s)
        _, v, _, _ = self._eig(ru.z[1:], P)
        v = np.concatenate([[0.0], v / np.max(np.abs(v))])
        v *= 1.0 if v[-1] >= 0 else -1.0
        cands = []
        for s in (1, -1):
            r, _ = self._land(seg, lam_s, ru.z, v, (s,))
            if r is not None:
                cands.append((r.energy, -s, r, s))
        if not cands:
            return None
        cands.sort(key=lambda c: (round(c[0], 10), c[1]))
        _, _, landing, sign = cands[0]
        released = float(ru.energy - landing.energy)
        self._record(seg, k, lam_c, rc, "critical")
        if released <= 1e-6 * max(1.0, abs(ru.energy)):
            self.bifs.append(Bifurcation(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                                         values=seg.values(lam_c), direction=self._direction(seg),
                                         state=rc, sign=sign))
            self._record(seg, k, lam_s, landing, "landing")
            return lam_s, landing
        to_state = self._solve_track(seg, lam_c, landing.z)
        if not (to_state.success and to_state.stable):
            to_state = landing
        self.branch += 1
        self._record(seg, k, lam_c, to_state, "landing")
        self.jumps.append(Jump(t=float(k + lam_c), param=self._param_value(seg, k, lam_c),
                               values=seg.values(lam_c), direction=self._direction(seg),
                               kind="subcritical", from_state=rc, to_state=to_state,
                               energy_released=float(rc.energy - to_state.energy)))
        return lam_c, to_state
