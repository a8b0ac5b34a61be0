"""Pseudo-arclength continuation of equilibrium branches in any scalar parameter (THEORY §7–8).

The branch is the solution set of G(u, λ) = ∇_u Ê(u; P(λ)) = 0, u = (θ_1, …, θ_n) the free node
values of the collocation (θ_0 = θ0 eliminated), λ one scalar parameter mapped onto the NLP's
parameter vector P (``h``, ``h2`` = h², ``phi``, ``p`` (= ``fy``), ``fx``, ``m_tip``, ``qx``,
``qy``, ``theta0``, and ``alpha``: a constant fibre angle, which sets every quadrature-point entry
of α together). One CasADi function (g, H = ∂g/∂u, g_λ = ∂g/∂λ) is built per scene structure,
transcription and parameter name, from the solver's discrete energy with P(λ) substituted
symbolically (so ``h2`` enters as (√λ)² = λ exactly), and evaluated through a zero-copy buffer.

Algorithm (Keller's pseudo-arclength method, Allgower & Georg ch. 2): predictor
x_p = x_k + Δs t_k, x = (u, λ); corrector Newton on [G(x); t_kᵀW(x − x_p)] = 0 with the
mass-weighted metric W = diag(m_1, …, m_n, 1) (‖δu‖_W approximates the L² norm of δθ, so steps do
not depend on the resolution); new tangent from [G_x; t_kᵀW] t = e_{n+1}; step size adapted to the
number of Newton iterations and the turn of the tangent.

Along the branch: stability from the eigenvalues of the mass-scaled reduced Hessian
M^{-1/2} H M^{-1/2} (THEORY §7; Morse index = number of negative ones); a **fold** (limit point) where
the λ-component of the tangent changes sign; a **branch point** where the determinant of the
bordered Jacobian [G_x; tᵀW] changes sign (with a continuously oriented tangent it changes sign at
a simple branch point and not at a fold). Both are located by ``brentq`` on
σ ↦ (−1)^{Morse index} · min|μ_i| along the step (a continuous function that vanishes exactly where
an eigenvalue of H crosses zero), so the critical parameter value is accurate to the corrector
tolerance. Branch switching takes the second null vector of [G_u G_λ] at a branch point
(W-orthogonal to the branch tangent) as the direction of the bifurcating branch.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np
import scipy.linalg
from scipy.optimize import brentq

from .. import parameters as lens
from ..equilibrium import solve
from ..options import SolverOptions
from ..parameters import Parameter
from ..result import EquilibriumResult
from ..scene import Scene
from ..solver import EquilibriumSolver, get_solver
from .registry import register

__all__ = ["get_param", "set_param", "Continuation", "Branch", "CriticalPoint",
           "continue_branch", "ContinuationResult", "system_function", "substituted_energy"]

_WHAT = "continuation parameter"


def _check_name(name: str) -> Parameter:
    return lens.parameter(name, _WHAT)


def get_param(scene: Scene, name: str) -> float:
    """The value of continuation parameter ``name`` in ``scene`` (0 for an absent term); a thin
    name for :func:`actuator_design.parameters.get_value`."""
    return lens.get_value(scene, name, _WHAT)


def set_param(scene: Scene, name: str, value: float) -> Scene:
    """A copy of ``scene`` with parameter ``name`` set to ``value`` (adding the term if absent);
    a thin name for :func:`actuator_design.parameters.set_value`.

    Raises
    ------
    ValueError
        Unknown name, a value outside the parameter's range (e.g. ``h2 < 0``), or ``phi`` on a
        non-uniform field.
    """
    return lens.set_value(scene, name, value, _WHAT)


# -- the system function, built once per (structure, transcription, parameter) --------------------
_FN_CACHE: Dict[tuple, ca.Function] = {}


def substituted_energy(solver: EquilibriumSolver, names: Sequence[str]):
    """The reduced energy with parameters ``names`` as separate symbols.

    Returns
    -------
    u : SX (n,)
        Free unknowns θ_1..θ_n (θ_0 = θ0 substituted).
    lams : list of SX scalars
        One symbol per name; the NLP entries it controls are replaced by it (by √λ for ``h2``,
        every quadrature-point entry for ``alpha``).
    P : SX
        The solver's parameter vector symbol (the other entries).
    Er : SX scalar
        Ê(u; P(λ…)).
    """
    de, lay = solver.discrete, solver.layout
    P = de.params
    Pl = P
    lams = []
    for name in names:
        par = _check_name(name)
        slot = par.slot
        if slot not in lay.slices:
            raise ValueError(f"{name}: this scene has no {slot!r} parameter (add the term to the scene)")
        sl = lay.slices[slot]
        lam = ca.SX.sym(f"lam_{name}")
        expr = par.slot_expr(lam)
        Pl = ca.vertcat(Pl[:sl.start], ca.repmat(expr, sl.stop - sl.start, 1), Pl[sl.stop:])
        lams.append(lam)
    u = ca.SX.sym("u", de.z.numel() - 1)
    z_sub = ca.vertcat(Pl[lay.slices["theta0"]], u)
    Er = ca.substitute(de.energy, ca.vertcat(de.z, P), ca.vertcat(z_sub, Pl))
    return u, lams, P, Er


def system_function(solver: EquilibriumSolver, name: str) -> ca.Function:
    """CasADi ``(u, λ, P) -> (g, H, g_λ)``: gradient of Ê in the free unknowns, its (dense)
    Hessian, and ∂g/∂λ, with the entries of P that ``name`` controls replaced by λ (√λ for
    ``h2``, so that h² = λ exactly). Cached per (structure, transcription, name)."""
    _check_name(name)
    key = (solver.key, solver.transcription.structure(), name)
    fn = _FN_CACHE.get(key)
    if fn is not None:
        return fn
    u, (lam,), P, Er = substituted_energy(solver, [name])
    g = ca.gradient(Er, u)
    H = ca.jacobian(g, u)
    gl = ca.jacobian(g, lam)
    fn = ca.Function(f"landscape_{name}", [u, lam, P], [g, ca.densify(H), ca.densify(gl)])
    _FN_CACHE[key] = fn
    return fn


class _Evaluator:
    """Zero-copy evaluation of :func:`system_function` into preallocated numpy arrays."""

    def __init__(self, fn: ca.Function, P: np.ndarray):
        n = fn.size1_in(0)
        self.u, self.lam, self.P = np.zeros(n), np.zeros(1), np.ascontiguousarray(P, float).copy()
        self.g, self.H, self.gl = np.zeros(n), np.zeros((n, n)), np.zeros(n)
        self.buf, self.ev = fn.buffer()
        for i, a in enumerate((self.u, self.lam, self.P)):
            self.buf.set_arg(i, memoryview(a))
        for i, a in enumerate((self.g, self.H, self.gl)):
            self.buf.set_res(i, memoryview(a))
        self.calls = 0

    def __call__(self, u, lam):
        self.u[:] = u
        self.lam[0] = lam
        self.ev()
        self.calls += 1
        return self.g, self.H, self.gl


_dsytrf, _dsyevr = scipy.linalg.lapack.dsytrf, scipy.linalg.lapack.dsyevr


def _lu_det_sign(lu, piv) -> float:
    d = np.sign(np.diag(lu)).prod()
    swaps = np.count_nonzero(piv != np.arange(piv.size))
    return float(d * (-1.0) ** swaps)


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

    def to_dict(self) -> dict:
        return {"kind": self.kind, "param": self.param, "value": float(self.value),
                self.param: float(self.value), "tip_angle": float(self.tip["angle"]),
                "tip": {k: float(v) for k, v in self.tip.items()}, "energy": float(self.energy),
                "morse_index_before": int(self.morse_before), "morse_index_after": int(self.morse_after),
                "located": bool(self.located)}


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
        ``"step_too_small"``.
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


class Continuation:
    """Pseudo-arclength continuation in parameter ``name`` for one scene structure.

    Parameters
    ----------
    scene : Scene
        Uniform or non-uniform field; the other parameters stay at their values in ``scene``.
    name : str
        A name of the parameter lens (:mod:`actuator_design.parameters`).
    options : SolverOptions, optional
        Transcription and tolerance (``tol`` is the corrector's stationarity tolerance).
    """

    def __init__(self, scene: Scene, name: str, options: Optional[SolverOptions] = None):
        _check_name(name)
        self.name = name
        self.scene = set_param(scene, name, get_param(scene, name))  # the term exists
        self.options = replace(options or SolverOptions(), ensure_stable=False)
        self.solver = get_solver(self.scene, self.options)
        self.P = self.solver.parameter_vector(self.scene)
        self.fn = system_function(self.solver, name)
        self.ev = _Evaluator(self.fn, self.P)
        m = self.solver.transcription.mass
        self.mass = m[1:].copy()
        self.n = self.mass.size
        self.W = np.append(self.mass, 1.0)
        self.Ms = 1.0 / np.sqrt(self.mass)
        self.tol = self.options.tol
        sl = self.solver.layout.slices
        self.theta0_fixed = name != "theta0"
        self._theta0 = float(self.P[sl["theta0"]][0])

    # -- helpers ------------------------------------------------------------------------------
    def params(self, lam: float) -> np.ndarray:
        """The NLP parameter vector at λ (for the solver's own functions)."""
        return self.solver.parameter_vector(set_param(self.scene, self.name, lam))

    def scene_at(self, lam: float) -> Scene:
        return set_param(self.scene, self.name, lam)

    def full(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Node vector z = (θ0, u)."""
        return np.concatenate(([lam if self.name == "theta0" else self._theta0], u))

    def _res(self, g):
        return float(np.max(np.abs(g / self.mass)))

    def correct_fixed(self, u, lam, max_iter: int = 20):
        """Newton at fixed λ. Returns (u, converged, iterations)."""
        u = np.array(u, float)
        for it in range(max_iter + 1):
            g, H, _ = self.ev(u, lam)
            if not np.all(np.isfinite(g)):
                return u, False, it
            if self._res(g) <= self.tol:
                return u, True, it
            try:
                step = -np.linalg.solve(H, g)
            except np.linalg.LinAlgError:
                return u, False, it
            big = np.max(np.abs(step))
            u = u + (step if big <= 1.0 else step / big)
        return u, False, max_iter

    def correct(self, xp, t, max_iter: int = 8):
        """Newton on [G(x); tᵀW(x − xp)] = 0 from xp. Returns (x, converged, iterations)."""
        x = np.array(xp, float)
        n = self.n
        Jb = np.empty((n + 1, n + 1))
        Jb[n] = t * self.W
        rhs = np.empty(n + 1)
        for it in range(max_iter + 1):
            g, H, gl = self.ev(x[:n], x[n])
            if not np.all(np.isfinite(g)):
                return x, False, it
            arc = float(Jb[n] @ (x - xp))
            if self._res(g) <= self.tol and abs(arc) <= 1e-9:
                return x, True, it
            if it == max_iter:
                break
            Jb[:n, :n] = H
            Jb[:n, n] = gl
            rhs[:n] = g
            rhs[n] = arc
            try:
                dx = np.linalg.solve(Jb, -rhs)
            except np.linalg.LinAlgError:
                return x, False, it
            if not np.all(np.isfinite(dx)) or np.max(np.abs(dx)) > 2.0:
                return x, False, it
            x = x + dx
        return x, False, max_iter

    def tangent(self, x, t_prev=None, evaluate: bool = True) -> Tuple[np.ndarray, float]:
        """Unit tangent (W-norm) at a converged x, oriented along ``t_prev`` (or +λ), and the sign of
        det [G_x; tᵀW]. ``evaluate=False`` reuses the last evaluation (which must be at x)."""
        n = self.n
        g, H, gl = self.ev(x[:n], x[n]) if evaluate else (self.ev.g, self.ev.H, self.ev.gl)
        J = np.empty((n + 1, n + 1))
        J[:n, :n], J[:n, n] = H, gl
        if t_prev is None:
            # null vector of [H gl] by SVD (robust also at a singular H)
            _, _, Vt = np.linalg.svd(J[:n] / np.sqrt(self.W)[None, :])
            t = Vt[-1] / np.sqrt(self.W)
            if t[n] < 0:
                t = -t
        else:
            # [G_x; t_prevᵀW] t = e_{n+1}. det[G_x; cᵀ] = κ (c·t) for any row c (the row space of
            # G_x is t^⊥), so det[G_x; t_prevᵀW] and det[G_x; tᵀW] share the sign of κ: t_prevᵀW t
            # = 1 > 0 and tᵀW t > 0.
            J[n] = t_prev * self.W
            lu, piv = scipy.linalg.lu_factor(J, check_finite=False)
            e = np.zeros(n + 1)
            e[n] = 1.0
            t = scipy.linalg.lu_solve((lu, piv), e, check_finite=False)
            t /= math.sqrt(float(t @ (self.W * t)))
            return t, _lu_det_sign(lu, piv)
        t /= math.sqrt(float(t @ (self.W * t)))
        J[n] = t * self.W
        lu, piv = scipy.linalg.lu_factor(J, check_finite=False)
        return t, _lu_det_sign(lu, piv)

    def inertia(self, x, evaluate: bool = True) -> Tuple[int, float, float]:
        """(Morse index, smallest eigenvalue, (−1)^index · min|μ|) of M^{-1/2} H M^{-1/2} at x
        (``evaluate=False`` reuses the last evaluation, which must be at x)."""
        H = self.ev(x[: self.n], x[self.n])[1] if evaluate else self.ev.H
        A = self.Ms[:, None] * H * self.Ms[None, :]
        mu = np.linalg.eigvalsh(0.5 * (A + A.T))
        scale = 1e-9 * max(1.0, abs(mu[0]))
        idx = int(np.sum(mu < -scale))
        return idx, float(mu[0]), float((-1) ** int(np.sum(mu < 0)) * np.min(np.abs(mu)))

    def fast_inertia(self) -> Tuple[int, float]:
        """(Morse index, smallest eigenvalue) at the last evaluation, cheaply: the index from the
        inertia of a Bunch–Kaufman LDLᵀ factorisation (Sylvester's law of inertia), the smallest
        eigenvalue alone by LAPACK ``dsyevr``."""
        A = self.Ms[:, None] * self.ev.H * self.Ms[None, :]
        A = 0.5 * (A + A.T)
        ldu, ipiv, info = _dsytrf(A)
        d, off = np.diag(ldu), np.diag(ldu, 1)
        neg, k = 0, A.shape[0] - 1
        while k >= 0:  # upper storage: a 2×2 block sits at (k−1, k) when ipiv[k] = ipiv[k−1] < 0
            if ipiv[k] > 0 or k == 0:
                neg += d[k] < 0
                k -= 1
            else:
                a, b, c = d[k - 1], off[k - 1], d[k]
                det = a * c - b * b
                neg += 1 if det < 0 else (2 if a + c < 0 else 0)
                k -= 2
        w = _dsyevr(A, compute_v=0, range="I", il=1, iu=1)[0]
        return int(neg), float(w[0])

    # -- starting -----------------------------------------------------------------------------
    def start(self, lam0: float, initial=None) -> np.ndarray:
        """A converged point x = (u, λ0): Newton from ``initial`` (node vector, EquilibriumResult or
        None for a solve of the scene at λ0 with the solver's own strategy)."""
        if isinstance(initial, EquilibriumResult):
            initial = initial.z
        if initial is None:
            res = solve(self.scene_at(lam0), replace(self.options, ensure_stable=True), solver=self.solver)
            if not res.success:
                raise RuntimeError(f"continuation: no equilibrium found at {self.name} = {lam0}: {res.message}")
            initial = res.z
        u, ok, _ = self.correct_fixed(np.asarray(initial, float)[1:], lam0, max_iter=50)
        if not ok:
            raise RuntimeError(f"continuation: Newton did not converge at the start {self.name} = {lam0}")
        return np.append(u, lam0)

    # -- the main loop ------------------------------------------------------------------------
    def run(self, x0: np.ndarray, window: Tuple[float, float], *, direction: float = 1.0,
            t0: Optional[np.ndarray] = None, ds: float = 0.05, ds_min: float = 1e-7,
            ds_max: float = 0.5, max_points: int = 2000, locate: bool = True,
            origin: Optional[str] = None) -> Branch:
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
        """
        tstart = time.perf_counter()
        lo, hi = float(min(window)), float(max(window))
        n = self.n
        calls0 = self.ev.calls
        x = np.array(x0, float)
        if t0 is None:
            t, dsign = self.tangent(x)
            if t[n] * direction < 0 or (abs(t[n]) < 1e-12 and direction < 0):
                t = -t
                t, dsign = self.tangent(x, t)
        else:
            t, dsign = self.tangent(x, np.asarray(t0, float) / math.sqrt(float(t0 @ (self.W * t0))))
        self.ev(x[:n], x[n])
        idx, mu0 = self.fast_inertia()
        X, T, IDX, MU, F, D = [x], [t], [idx], [mu0], [None], [dsign]
        folds, bps = [], []
        status, msg = "max_points", f"stopped after {max_points} points"
        iters = 0
        while len(X) < max_points:
            xp = x + ds * t
            xn, ok, it = self.correct(xp, t)
            iters += it
            if ok:
                idx, mu = self.fast_inertia()
                fv = None
                tn, dn = self.tangent(xn, t, evaluate=False)
                cosang = float(tn @ (self.W * t))
                if cosang < 0.95 and ds > 10 * ds_min:
                    ok = False
            if not ok:
                ds *= 0.5
                if ds < ds_min:
                    status, msg = "step_too_small", f"the corrector failed with steps below {ds_min:g}"
                    break
                continue
            # detections on the step x -> xn
            turned, crossed = tn[n] * t[n] < 0, dn * D[-1] < 0
            if locate and (turned or crossed):
                # both at once: the branch passes through a branch point where it turns in λ
                # (the vertex of a pitchfork's bifurcating branch): a branch point, located by t_λ = 0
                kind = "branch_point" if crossed else "fold"
                cp = self._locate(x, t, ds, kind, IDX[-1], idx, by_tangent=turned and crossed)
                if cp is not None and lo <= cp.value <= hi:
                    (bps if crossed else folds).append(cp)
            if not (lo <= xn[n] <= hi):
                edge = hi if xn[n] > hi else lo
                xe = self._to_edge(x, xn, edge)
                if xe is not None:
                    self.ev(xe[:n], xe[n])
                    ie, me = self.fast_inertia()
                    fe = None
                    X.append(xe), T.append(tn), IDX.append(ie), MU.append(me), F.append(fe), D.append(dn)
                status, msg = "left_window", f"reached {self.name} = {edge:g}"
                break
            X.append(xn), T.append(tn), IDX.append(idx), MU.append(mu), F.append(fv), D.append(dn)
            x, t = xn, tn
            if len(X) > 10 and math.sqrt(float((x - X[0]) @ (self.W * (x - X[0])))) < 0.5 * ds \
                    and float(t @ (self.W * T[0])) > 0.9:
                status, msg = "closed_loop", "the branch closed on itself (an isola or a loop)"
                break
            ds = min(ds * 1.5, ds_max) if it <= 2 else (ds * 0.6 if it >= 5 else ds)
        Xa = np.array(X)
        z = np.column_stack([np.where(self.theta0_fixed, self._theta0, Xa[:, n]), Xa[:, :n]])
        br = Branch(self.name, Xa[:, n].copy(), z, np.array(IDX), np.array(MU), folds, bps, status, msg,
                    {"points": len(X), "newton_evaluations": self.ev.calls - calls0,
                     "time_s": time.perf_counter() - tstart}, origin=origin)
        br._tangents = np.array(T)
        self._decorate(br)
        return br

    def _decorate(self, br: Branch) -> None:
        """Tip, energy and θ'(0) at every point (one mapped CasADi call each)."""
        N = len(br)
        Z = br.z.T
        Ps = np.column_stack([self.params(l) for l in br.lam]) if N < 50 else self._params_matrix(br.lam)
        tip = self.solver.f_tip.map(N)(Z, Ps)
        br.tips = np.column_stack([np.asarray(v, float).ravel() for v in tip])
        br.energy = np.asarray(self.solver.f_energy.map(N)(Z, Ps), float).ravel()
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

    def _to_edge(self, x, xn, edge):
        """The branch point at λ = edge between x and xn (Newton at fixed λ from interpolation)."""
        n = self.n
        w = (edge - x[n]) / (xn[n] - x[n])
        u, ok, _ = self.correct_fixed((1 - w) * x[:n] + w * xn[:n], edge, max_iter=20)
        return np.append(u, edge) if ok else None

    def _locate(self, x, t, ds, kind, idx_before, idx_after, by_tangent=False) -> Optional[CriticalPoint]:
        """Locate the critical point inside the step from x along t (length ds)."""
        n = self.n
        cache = {}

        def point(sig):
            if sig not in cache:
                xs, ok, _ = self.correct(x + sig * t, t, max_iter=20)
                cache[sig] = (xs, ok)
            return cache[sig]

        def f(sig):
            xs, ok = point(sig)
            if not ok:
                raise RuntimeError("corrector failed")
            return self.inertia(xs)[2]

        def tl(sig):
            xs, ok = point(sig)
            if not ok:
                raise RuntimeError("corrector failed")
            return self.tangent(xs, t)[0][n]

        located = True
        try:
            fa, fb = (1.0, 1.0) if by_tangent else (f(0.0), f(ds))
            if fa * fb < 0:
                sig = brentq(f, 0.0, ds, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=100)
            elif (kind == "fold" or by_tangent) and tl(0.0) * tl(ds) < 0:
                sig = brentq(tl, 0.0, ds, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=100)
            else:
                sig, located = 0.5 * ds, False
            xs, ok = point(sig)
        except (RuntimeError, ValueError):
            xs, ok, located = x + 0.5 * ds * t, True, False
        tc, _ = self.tangent(xs, t)
        xe = point(ds)[0] if ds in cache else x + ds * t
        return CriticalPoint(kind, self.name, float(xs[n]), self.full(xs[:n], xs[n]),
                             {"angle": float(xs[n - 1]), "x": float("nan"), "y": float("nan")},
                             int(idx_before), int(idx_after), located, tc,
                             interval=(float(min(x[n], xe[n]) - ds), float(max(x[n], xe[n]) + ds)))

    # -- branch switching ---------------------------------------------------------------------
    def switch(self, bp: CriticalPoint, window, *, ds: float = 0.05, **kw) -> List[Branch]:
        """Continue the branch bifurcating at branch point ``bp`` in both directions.

        The second null vector of [G_u G_λ] at ``bp`` (W-orthogonal to the primary tangent) is the
        tangent of the bifurcating branch; each half starts from a corrected point at distance
        ``ds`` along ±that vector.
        """
        n = self.n
        xb = np.append(bp.z[1:], bp.value)
        g, H, gl = self.ev(xb[:n], xb[n])
        J = np.column_stack([H, gl]) / np.sqrt(self.W)[None, :]
        _, _, Vt = np.linalg.svd(J)
        K = (Vt[-2:] / np.sqrt(self.W)[None, :])
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
            br = self.run(xs, window, t0=d, ds=ds, origin=f"branch point at {self.name} = {bp.value:.10g}", **kw)
            # prepend the branch point itself
            out.append(br)
        return out


@dataclass
class ContinuationResult:
    """The branch from the start and, with switching, the branches bifurcating from it."""

    param: str
    branch: Branch
    secondary: List[Branch]
    scene: Scene
    window: tuple

    def to_dict(self) -> dict:
        """The ``continue --json`` contract: ``branch`` (points with the parameter value, tip angle,
        stable), ``folds`` and ``branch_points`` (value and tip angle each)."""
        b = self.branch.to_dict()
        return {"param": self.param, "window": list(self.window), "branch": b["points"],
                "folds": b["folds"], "branch_points": b["branch_points"], "status": b["status"],
                "message": b["message"], "stats": b["stats"],
                "secondary_branches": [s.to_dict() for s in self.secondary],
                "groups": self.scene.describe_groups()}


def continue_branch(scene: Scene, param: str, start: float, stop: float, *,
                    options: Optional[SolverOptions] = None, initial=None, ds: float = 0.05,
                    ds_max: float = 0.5, max_points: int = 2000, switch: bool = False,
                    window: Optional[Sequence[float]] = None) -> ContinuationResult:
    """Continue the equilibrium at ``param = start`` towards ``stop`` (through folds), within the
    window [min(start, stop), max(start, stop)] unless ``window`` is given.

    Parameters
    ----------
    scene : Scene
        Other parameters fixed at their values here.
    param : str
        A name of the parameter lens (:mod:`actuator_design.parameters`).
    start, stop : float
        Parameter values (units of the parameter: rad for angles).
    initial : ndarray (n_nodes,) or EquilibriumResult, optional
        Start equilibrium guess; default: :func:`~actuator_design.equilibrium.solve` at ``start``.
    switch : bool
        Also continue every branch bifurcating at a branch point found.

    Returns
    -------
    ContinuationResult
    """
    cont = Continuation(scene, param, options)
    win = (min(start, stop), max(start, stop)) if window is None else tuple(window)
    x0 = cont.start(start, initial)
    br = cont.run(x0, win, direction=1.0 if stop >= start else -1.0, ds=ds, ds_max=ds_max,
                  max_points=max_points)
    sec = []
    if switch:
        for bp in br.branch_points:
            sec += cont.switch(bp, win, ds=ds, ds_max=ds_max, max_points=max_points)
    return ContinuationResult(param, br, sec, scene, win)


@register("continuation")
def run_continuation(scene, options, **settings) -> dict:
    """Settings: ``param``, ``start``, ``stop``, optional ``ds``, ``max_points``, ``switch``."""
    try:
        param, start, stop = settings.pop("param"), settings.pop("start"), settings.pop("stop")
    except KeyError as err:
        raise ValueError(f"continuation needs the setting {err.args[0]!r}") from None
    return continue_branch(scene, param, start, stop, options=options, **settings).to_dict()
