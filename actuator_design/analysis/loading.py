"""Quasi-static loading paths: follow the stable equilibrium along a schedule, snap at folds.

A *schedule* is a list of parameter settings, e.g. ``[{"h": 0}, {"h": 2}, {"h": 0}]`` (ramp the
field up and back down) or ``[{"h": 0, "phi": 1.2}, {"h": 1.5, "phi": 1.2}, {"h": 1.5, "phi": 1.6}]``
(a magnitude-and-angle field schedule). Between consecutive settings every named value changes
linearly in a segment coordinate λ ∈ [0, 1]. The rod follows its stable equilibrium
(THEORY §8): each step is a warm-started Newton solve of the one built NLP, predicted along the
branch tangent dz/dλ = −H_r⁻¹ ∂g/∂λ, with the step halved when Newton fails, when the state moves
too far, or when the smallest reduced-Hessian eigenvalue μ (THEORY §7) drops steeply towards zero.

When μ reaches zero the state loses stability:

* at a **fold** (saddle-node: the branch ends) the critical point is located by Newton's method on
  the augmented system g(z, λ) = 0, μ_min(z, λ) = 0 (quadratic convergence; derivatives of μ by
  Hellmann–Feynman from third derivatives of the energy), the rod is pushed just past it along the
  null eigenvector in the direction in which the energy decreases (the sign of the cubic term) and
  relaxed with IPOPT + ``ensure_stable``: a *jump* (snap-through) to the state it lands on;
* at a **bifurcation** (μ crosses zero while the branch continues, e.g. the pitchfork of the
  symmetric transverse scene) the crossing is located by root-finding on μ along the branch and the
  unstable state is left along ± its eigenvector; if the landing state joins continuously
  (supercritical: the energy released vanishes) the event is recorded in ``bifurcations``, not as a
  jump; otherwise (subcritical) it is a jump.

Parameters a schedule may name (dimensionless, THEORY §5; angles in rad)::

    h, h2 (= h²), phi, p (= fy), fx, fy, m_tip, alpha (constant fibre angle), theta0, qx, qy, h_pos

Public API: :func:`follow_path`, :func:`ramp`, :class:`LoadingPath`, :class:`PathPoint`,
:class:`Jump`, :func:`apply_values` (names: :mod:`actuator_design.parameters`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import scipy.linalg
from scipy.integrate import trapezoid as _trapezoid
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq

from .. import parameters as lens
from ..equilibrium import solve
from ..options import SolverOptions
from ..result import EquilibriumResult
from ..scene import Scene
from ..solver import get_solver
from .registry import register
from .stiffness import sensitivities

__all__ = ["apply_values", "scene_values", "ramp", "follow_path", "LoadingPath",
           "PathPoint", "Jump", "Bifurcation"]

#: Trial steps allowed per schedule segment before the path gives up (a safeguard).
MAX_TRIALS = 20000

Schedule = Union[Sequence[Mapping[str, float]], Mapping[str, Sequence[float]]]


# -- parameters: the lens (actuator_design.parameters), with this analysis' wording ---------------
_WHAT = "path parameter"


def _check_name(name: str) -> None:
    lens.parameter(name, _WHAT)


def prepare_scene(scene: Scene, names: Sequence[str]) -> Scene:
    """``scene`` with every term a parameter in ``names`` needs present (added at value zero), so
    that the whole path shares one NLP structure."""
    return lens.prepare_scene(scene, names, _WHAT)


def scene_values(scene: Scene, names: Sequence[str]) -> Dict[str, float]:
    """The current values of the named parameters in ``scene``."""
    return lens.scene_values(scene, names, _WHAT)


def apply_values(scene: Scene, values: Mapping[str, float]) -> Scene:
    """A copy of ``scene`` with the named parameters set (names of the parameter lens).

    Setting ``h`` (or ``h2``) in a non-uniform field scales ``h_pos`` by the same factor (both
    groups are proportional to the field magnitude H, THEORY §5) unless ``h_pos`` is also given
    or the scene's h is 0: the lens' field-scaling rule (:func:`actuator_design.parameters.apply_values`).

    Raises
    ------
    ValueError
        Unknown name, non-finite value, h, h2 or h_pos negative, phi in a non-uniform field.
    """
    return lens.apply_values(scene, values, _WHAT)


def ramp(name: str, start: float, stop: float, back: bool = False) -> List[Dict[str, float]]:
    """The schedule ``[{name: start}, {name: stop}]`` (and back to ``start`` if ``back``)."""
    _check_name(name)
    out = [{name: float(start)}, {name: float(stop)}]
    if back:
        out.append({name: float(start)})
    return out


def normalise_schedule(schedule: Schedule) -> Tuple[List[str], np.ndarray]:
    """Names and an (n_points, n_names) array of values from a schedule.

    A schedule is a list of dicts with the same keys (``[{"h": 0}, {"h": 2}]``) or a dict of
    equal-length lists (``{"h": [0, 2, 0]}``).
    """
    if isinstance(schedule, Mapping):
        names = list(schedule)
        lengths = {len(list(v)) for v in schedule.values()}
        if len(lengths) != 1:
            raise ValueError("schedule: the lists of values must all have the same length")
        rows = [dict(zip(names, vals)) for vals in zip(*[list(schedule[n]) for n in names])]
    else:
        rows = [dict(r) for r in schedule]
    if len(rows) < 2:
        raise ValueError(f"schedule: needs at least 2 points, got {len(rows)}")
    names = list(rows[0])
    if not names:
        raise ValueError("schedule: the points name no parameter")
    for i, r in enumerate(rows):
        if set(r) != set(names):
            raise ValueError(f"schedule[{i}]: names {sorted(r)} differ from schedule[0]'s {sorted(names)}")
    for n in names:
        _check_name(n)
    vals = np.array([[float(r[n]) for n in names] for r in rows])
    if not np.all(np.isfinite(vals)):
        raise ValueError("schedule: every value must be a finite number")
    return names, vals


# -- results -----------------------------------------------------------------------------------
@dataclass
class PathPoint:
    """One state on the path.

    Attributes
    ----------
    t : float
        Path coordinate: segment index + λ (schedule point k is at t = k).
    param : float
        Value of the ramped parameter for a one-parameter schedule, else ``t``.
    values : dict
        All scheduled parameter values at this point.
    tip : dict
        x, y (units of ℓ), angle (rad).
    energy : float
        Units of B0/ℓ.
    stable : bool
    min_eigenvalue : float
        Smallest reduced-Hessian eigenvalue (THEORY §7); 0 at a critical point.
    morse_index : int
    branch : int
        Counts the jumps before this point (a new branch after each snap).
    direction : int
        Sign of the change of the ramped parameter along this segment (one-parameter schedules;
        0 otherwise).
    kind : str
        "start", "step", "schedule" (a schedule point), "critical" (fold or bifurcation), "landing".
    """

    t: float
    param: float
    values: Dict[str, float]
    tip: Dict[str, float]
    energy: float
    stable: bool
    min_eigenvalue: float
    morse_index: int
    branch: int
    direction: int
    kind: str

    def to_dict(self) -> dict:
        return {"t": self.t, "param": self.param, "values": dict(self.values), "tip": dict(self.tip),
                "energy": self.energy, "stable": self.stable, "min_eigenvalue": self.min_eigenvalue,
                "morse_index": self.morse_index, "branch": self.branch, "direction": self.direction,
                "kind": self.kind}


def _state_dict(r: EquilibriumResult) -> dict:
    return {"tip": {k: float(v) for k, v in r.tip.items()}, "energy": float(r.energy),
            "stable": bool(r.stable), "min_eigenvalue": float(r.eigenvalues[0]),
            "morse_index": int(r.morse_index), "gamma": r.gamma}


@dataclass
class Jump:
    """A snap-through: the followed state lost stability and the rod jumped to another one.

    Attributes
    ----------
    t, param : float
        Where (path coordinate; value of the ramped parameter, or t).
    values : dict
        Parameter values at the jump.
    direction : int
        Sign of the ramp there (one-parameter schedules).
    kind : str
        "fold" (saddle-node) or "subcritical" (a bifurcation without a nearby stable branch).
    from_state, to_state : EquilibriumResult
        Both at the jump's parameter values (the critical state and the stable state it jumps to).
    energy_released : float
        from_state.energy − to_state.energy, units of B0/ℓ (≥ 0).
    """

    t: float
    param: float
    values: Dict[str, float]
    direction: int
    kind: str
    from_state: EquilibriumResult
    to_state: EquilibriumResult
    energy_released: float

    def to_dict(self) -> dict:
        return {"t": self.t, "param": self.param, "values": dict(self.values),
                "direction": self.direction, "kind": self.kind,
                "from": _state_dict(self.from_state), "to": _state_dict(self.to_state),
                "energy_released": self.energy_released}


@dataclass
class Bifurcation:
    """A continuous loss of stability (supercritical bifurcation): the rod leaves the followed
    branch without a jump, onto one of the bifurcating stable branches (chosen by the sign of
    the unstable eigenvector: positive at the tip, ``sign``)."""

    t: float
    param: float
    values: Dict[str, float]
    direction: int
    state: EquilibriumResult
    sign: int

    def to_dict(self) -> dict:
        return {"t": self.t, "param": self.param, "values": dict(self.values),
                "direction": self.direction, "state": _state_dict(self.state), "sign": self.sign}


@dataclass
class LoadingPath:
    """A quasi-static loading path (result of :func:`follow_path`).

    Attributes
    ----------
    names : list of str
        Scheduled parameter names.
    schedule : ndarray, shape (n_schedule, len(names))
    param : str or None
        The ramped parameter for one-parameter schedules (the only name that changes), else None.
    points : list of PathPoint
        Every accepted state in path order (critical states and landings included).
    jumps : list of Jump
    bifurcations : list of Bifurcation
    snap_free : bool
        True when the whole path converged and the rod never jumped.
    hysteresis : dict
        ``width`` (distance in the parameter between the two jumps of a loop), ``area`` (of the loop
        in the (param, tip angle) plane, units of param × rad) — of the first loop; ``loops``: every
        loop (a jump followed by a jump in the opposite ramp direction) with its ``width``, ``area``,
        ``jumps`` (the two parameter values), ``branch_before`` and ``branch_between`` (the two
        stable branches of the loop as [param, tip angle] pairs, sorted by param) and ``complete``
        (both branches cover the loop).
        Zeros and an empty list when there is no loop.
    states : list of EquilibriumResult
        The state at each schedule point.
    final : EquilibriumResult
        The state at the last schedule point (the last state reached when ``success`` is False).
    success : bool
        Every step converged (a non-converged step stops the path: ``message`` says where).
    message : str
    """

    names: List[str]
    schedule: np.ndarray
    param: Optional[str]
    points: List[PathPoint]
    jumps: List[Jump]
    bifurcations: List[Bifurcation]
    snap_free: bool
    hysteresis: dict
    states: List[EquilibriumResult]
    final: EquilibriumResult
    success: bool
    message: str

    def column(self, key: str) -> np.ndarray:
        """A column of ``points``: "t", "param", "x", "y", "angle", "energy", "stable",
        "min_eigenvalue", "branch", "direction"."""
        if key in ("x", "y", "angle"):
            return np.array([p.tip[key] for p in self.points])
        return np.array([getattr(p, key) for p in self.points])

    def reaches(self, target: EquilibriumResult, tol: float = 1e-6) -> bool:
        """Whether the final state is ``target`` (max nodal |Δθ| ≤ tol on equal discretisations)."""
        a, b = self.final.z, target.z
        return bool(a is not None and b is not None and a.shape == b.shape
                    and np.max(np.abs(a - b)) <= tol)

    def to_dict(self) -> dict:
        """The JSON contract of ``actuator-design path --json``: ``points``, ``jumps``, ``snap_free``,
        ``hysteresis`` (and more)."""
        return {"param": self.param, "names": list(self.names),
                "schedule": [dict(zip(self.names, map(float, row))) for row in self.schedule],
                "success": self.success, "message": self.message, "snap_free": self.snap_free,
                "points": [p.to_dict() for p in self.points],
                "jumps": [j.to_dict() for j in self.jumps],
                "bifurcations": [b.to_dict() for b in self.bifurcations],
                "hysteresis": self.hysteresis, "final": _state_dict(self.final),
                "units": {"tip": "x, y in rod lengths l, angle in rad", "energy": "B0/l",
                          "angles": "rad"}}

    def summary(self) -> str:
        lines = [f"loading path over {', '.join(self.names)} ({len(self.schedule)} schedule points, "
                 f"{len(self.points)} states): {'converged' if self.success else 'FAILED'} — {self.message}",
                 f"  snap-free: {'yes' if self.snap_free else 'no'}"]
        for j in self.jumps:
            lines.append(f"  jump ({j.kind}) at {self.param or 't'} = {j.param:.10g}: tip angle "
                         f"{j.from_state.tip['angle']:.6f} -> {j.to_state.tip['angle']:.6f} rad, "
                         f"energy released {j.energy_released:.6g} B0/l")
        for b in self.bifurcations:
            lines.append(f"  continuous bifurcation at {self.param or 't'} = {b.param:.10g} "
                         f"(branch sign {b.sign:+d})")
        hy = self.hysteresis
        if hy.get("loops"):
            lines.append(f"  hysteresis: width {hy['width']:.8g}, loop area {hy['area']:.6g} "
                         f"({len(hy['loops'])} loop(s))")
        f = self.final
        lines.append(f"  final state: tip ({f.tip['x']:.6f}, {f.tip['y']:.6f}), angle {f.tip['angle']:.6f} rad, "
                     f"energy {f.energy:.8g}, {'stable' if f.stable else 'UNSTABLE'}")
        return "\n".join(lines)


# -- the tracker ---------------------------------------------------------------------------------
class _Segment:
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
        return apply_values(self.base, self.values(lam))

    def params(self, lam: float) -> np.ndarray:
        return self.solver.parameter_vector(self.scene(lam))

    def dparams(self, lam: float, d: float = 1e-6) -> np.ndarray:
        """dP/dλ by central differences (exact for the parameters that enter P linearly)."""
        return (self.params(lam + d) - self.params(lam - d)) / (2.0 * d)


class _Tracker:
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
        Ms = 1.0 / np.sqrt(self.M)
        A = Ms[:, None] * H * Ms[None, :]
        lam, U = scipy.linalg.eigh(0.5 * (A + A.T), subset_by_index=[0, 0])
        return float(lam[0]), Ms * U[:, 0], H, g

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
        zr = z[1:].copy()
        m = self.M
        for _ in range(40):
            P, dP = seg.params(lam), seg.dparams(lam)
            mu, v, H, g = self._eig(zr, P)
            gl = np.asarray(self.sens.g_P(zr, P), float) @ dP
            mz, mP = (np.asarray(a, float).ravel() for a in self.sens.third(zr, P, v))
            ml = float(mP @ dP)
            res = max(np.max(np.abs(g / m)), abs(mu))
            J = np.block([[H, gl[:, None]], [mz[None, :], np.array([[ml]])]])
            try:
                step = -np.linalg.solve(J, np.concatenate([g, [mu]]))
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(step)):
                return None
            zr, lam = zr + step[:-1], lam + step[-1]
            if not (-0.5 < lam < lam_max + 0.5) or np.max(np.abs(zr - z[1:])) > 3.0:
                return None
            if res <= tol and np.max(np.abs(step[:-1])) <= 1e-9 and abs(step[-1]) <= 1e-12:
                break
        else:
            return None
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
    def run_segment(self, k, seg: _Segment, cur: EquilibriumResult):
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


def follow_path(scene: Scene, options: Optional[SolverOptions] = None, schedule: Schedule = (), *,
                initial: Union[None, np.ndarray, EquilibriumResult] = None,
                max_step: Optional[float] = None, max_dtheta: float = 0.3) -> LoadingPath:
    """Follow the stable equilibrium of ``scene`` quasi-statically along ``schedule``.

    Parameters
    ----------
    scene : Scene
        The scene; its values not named in the schedule stay fixed. Terms a scheduled parameter
        needs (a tip force for ``p``, a uniform field for ``h``/``phi``, …) are added at value zero.
    options : SolverOptions, optional
        Transcription and resolution (default ``SolverOptions()``). Tracking steps use Newton
        without ``ensure_stable``; the start and the snaps use IPOPT with ``ensure_stable``.
    schedule : list of dict, or dict of lists
        Parameter settings in order (names of the parameter lens, dimensionless, angles in rad),
        e.g. ``[{"h": 0, "phi": 1.2}, {"h": 1.5, "phi": 1.2}]`` or ``{"p": [0.5, -2, 0.5]}``;
        :func:`ramp` builds up/down ramps. At least two points.
    initial : ndarray of shape (n_nodes,) or EquilibriumResult, optional
        Warm start of the first state (default: the straight rod); the first state is made stable.
    max_step : float, optional
        Largest step, as a fraction of a schedule segment (0 < max_step ≤ 1). Default
        min(1, n_segments/20): about 20 steps over the whole path at least, and one per segment
        for fine schedules (steps are further limited by ``max_dtheta`` and the step control).
    max_dtheta : float
        Largest change of any nodal angle per step, rad (smaller steps draw smoother curves).

    Returns
    -------
    LoadingPath
        ``points``, ``jumps``, ``bifurcations``, ``snap_free``, ``hysteresis``, ``states``,
        ``final`` (the state at the last schedule point), ``success``/``message``.

    Raises
    ------
    ValueError
        Invalid schedule (unknown name, fewer than 2 points, non-finite or out-of-range values) or
        step settings.
    """
    options = options or SolverOptions()
    names, vals = normalise_schedule(schedule)
    if max_step is None:
        max_step = min(1.0, (len(vals) - 1) / 20.0)
    if not (0.0 < max_step <= 1.0):
        raise ValueError(f"max_step: must lie in (0, 1], got {max_step!r}")
    if not (max_dtheta > 0.0):
        raise ValueError(f"max_dtheta: must be > 0, got {max_dtheta!r}")
    base = prepare_scene(scene, names)
    for i, row in enumerate(vals):
        try:
            apply_values(base, dict(zip(names, row)))
        except ValueError as err:
            raise ValueError(f"schedule[{i}].{err}") from None
    tr = _Tracker(base, options, names, vals, max_step, max_dtheta)

    seg0 = _Segment(base, names, vals[0], vals[min(1, len(vals) - 1)], tr.solver)
    first = solve(seg0.scene(0.0), replace(options, ensure_stable=True), initial=initial, solver=tr.solver)
    tr._record(seg0, 0, 0.0, first, "start")
    tr.states.append(first)
    cur, msg, ok = first, "", bool(first.success and first.stable)
    if not ok:
        msg = f"no stable starting state: {first.message}"
    else:
        for k in range(len(vals) - 1):
            seg = _Segment(base, names, vals[k], vals[k + 1], tr.solver)
            nxt, msg = tr.run_segment(k, seg, cur)
            if nxt is None:
                ok = False
                break
            cur = nxt
            tr.states.append(cur)
    if ok:
        msg = (f"followed {len(vals) - 1} segment(s): {len(tr.jumps)} jump(s), "
               f"{len(tr.bifs)} continuous bifurcation(s)")
    hyst = _hysteresis(tr) if tr.param is not None else {
        "width": 0.0, "area": 0.0, "loops": [],
        "note": "hysteresis is defined for one-parameter schedules only"}
    return LoadingPath(names=names, schedule=vals, param=tr.param, points=tr.points, jumps=tr.jumps,
                       bifurcations=tr.bifs, snap_free=bool(ok and not tr.jumps), hysteresis=hyst,
                       states=tr.states, final=cur, success=ok, message=msg)


def _hysteresis(tr: _Tracker) -> dict:
    """Loops of a one-parameter path: each jump followed by the next jump in the opposite ramp
    direction. Width = distance between the two jump values; area = ∫ |angle_B − angle_A| dparam
    between them, A the branch before the first jump (and after the second), B the branch between,
    each interpolated (PCHIP) through the path's states: its accuracy is set by the step
    (``max_dtheta``), typically 1e-3 relative."""
    pts, jumps = tr.points, tr.jumps
    loops = []
    for i in range(len(jumps) - 1):
        j1, j2 = jumps[i], jumps[i + 1]
        if j1.direction == 0 or j1.direction != -j2.direction:
            continue
        lo, hi = sorted((j1.param, j2.param))
        before = jumps[i - 1].t if i > 0 else -np.inf
        after = jumps[i + 2].t if i + 2 < len(jumps) else np.inf
        A = [(p.param, p.tip["angle"]) for p in pts
             if (before <= p.t <= j1.t and not (p.t == j1.t and p.kind == "landing"))
             or (j2.t <= p.t <= after and not (p.t == j2.t and p.kind == "critical"))]
        A = [a for a in A if a is not None]
        B = [(p.param, p.tip["angle"]) for p in pts
             if j1.t <= p.t <= j2.t and not (p.t == j1.t and p.kind == "critical")
             and not (p.t == j2.t and p.kind == "landing")]
        grid = np.linspace(lo, hi, 2001)
        fa, ca_ = _branch_interp(A, grid)
        fb, cb = _branch_interp(B, grid)
        area = float(_trapezoid(np.abs(fb - fa), grid)) if hi > lo else 0.0
        inside = lambda pts_: [[float(a), float(b)] for a, b in sorted(pts_) if lo <= a <= hi]
        loops.append({"jumps": [j1.param, j2.param], "width": hi - lo, "area": area,
                      "complete": bool(ca_ and cb), "branch_before": inside(A),
                      "branch_between": inside(B)})
    first = loops[0] if loops else {"width": 0.0, "area": 0.0}
    return {"width": float(first["width"]), "area": float(first["area"]), "loops": loops}


def _branch_interp(points, grid):
    """Tip angle of one branch on ``grid`` (sorted, duplicates averaged); covers the grid?"""
    if not points:
        return np.full(grid.shape, np.nan), False
    arr = np.array(sorted(points))
    x, idx = np.unique(arr[:, 0], return_inverse=True)
    y = np.bincount(idx, weights=arr[:, 1]) / np.bincount(idx)
    covered = x[0] <= grid[0] + 1e-9 * (1 + abs(grid[0])) and x[-1] >= grid[-1] - 1e-9 * (1 + abs(grid[-1]))
    if x.size >= 3:  # shape-preserving cubic through the branch points
        return PchipInterpolator(x, y, extrapolate=False)(np.clip(grid, x[0], x[-1])), bool(covered)
    return np.interp(grid, x, y), bool(covered)


@register("path")
def run_path(scene, options, param: str = "h", schedule: Sequence[float] = (), **settings) -> dict:
    """Registered analysis: a one-parameter loading path (flat summary)."""
    path = follow_path(scene, options, {param: list(schedule)}, **settings)
    out = {"success": path.success, "snap_free": path.snap_free, "n_jumps": len(path.jumps),
           "jump_params": [j.param for j in path.jumps],
           "energy_released": [j.energy_released for j in path.jumps],
           "hysteresis_width": path.hysteresis["width"], "hysteresis_area": path.hysteresis["area"],
           "final_tip_angle": path.final.tip["angle"]}
    return out
