"""Equilibria as minimisers of the discrete energy: one built NLP per scene structure.

:class:`EquilibriumSolver` transcribes the scene's energy terms once, with every number (h, φ, p,
the fibre angles at the quadrature points, …) in the NLP parameter vector, and builds

* an IPOPT solver for  min_θ Ê(θ; params)  s.t.  θ_0 = θ0  (the clamp as a constraint),
* CasADi functions for the gradient and Hessian of Ê in the free unknowns (θ_0 = θ0 eliminated),
  used for the Newton path, for polishing and for the stability verdict.

Re-solving with new values is a parameter change and a warm start, never a rebuild;
:func:`get_solver` caches solvers by (structure, transcription, resolution).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, Optional

import casadi as ca
import numpy as np
import scipy.linalg

from .options import SolverOptions
from .physics.terms import build_terms, scalar_parameter_values, structure_key
from .scene import Scene
from .transcription import make_transcription

__all__ = ["EquilibriumSolver", "get_solver", "RawSolution", "StabilityVerdict"]

_CACHE: Dict[tuple, "EquilibriumSolver"] = {}


@dataclass
class StabilityVerdict:
    """Inertia of the reduced Hessian (THEORY §7).

    eigenvalues : smallest generalised eigenvalues of (H_r, M_r), ascending; they approximate the
        eigenvalues of the second-variation operator −(bη')' + q η with η(0) = 0, free end.
    eigenvector : the eigenvector of the smallest one (full node vector, 0 at the clamp).
    morse_index : number of eigenvalues < −tol.
    stable : all eigenvalues > tol.
    """

    eigenvalues: np.ndarray
    eigenvector: np.ndarray
    morse_index: int
    stable: bool
    marginal: bool


@dataclass
class RawSolution:
    z: np.ndarray
    converged: bool
    status: str
    message: str
    iterations: int
    stationarity: float


class EquilibriumSolver:
    """Everything that is built once for a scene structure and a transcription.

    Parameters
    ----------
    scene : Scene
        Any scene of the structure; its numbers are not baked in.
    options : SolverOptions
    """

    def __init__(self, scene: Scene, options: SolverOptions):
        t0 = time.perf_counter()
        self.options = options
        self.terms = build_terms(scene)
        self.key = structure_key(self.terms)
        self.transcription = make_transcription(options)
        de = self.transcription.transcribe(self.terms)
        self.discrete = de
        self.layout = de.layout
        z, P, E = de.z, de.params, de.energy

        # Reduced unknowns: θ_1..θ_n, with θ_0 = theta0 substituted (the clamp).
        zr = ca.SX.sym("theta_free", z.numel() - 1)
        theta0 = P[self.layout.slices["theta0"]]
        Er = ca.substitute(E, z, ca.vertcat(theta0, zr))
        gr, Hr = ca.gradient(Er, zr), ca.hessian(Er, zr)[0]
        self.f_energy = ca.Function("energy", [z, P], [E])
        self.f_grad_hess = ca.Function("grad_hess", [zr, P], [Er, gr, Hr])
        self.f_tip = ca.Function("tip", [z, P], list(de.tip))
        self._pointwise = self._pointwise_functions(de)

        nlp = {"x": z, "p": P, "f": E, "g": z[0] - theta0}
        ipopt_opts = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": max(options.tol, 1e-14),
            "ipopt.max_iter": int(options.max_iter),
            "ipopt.hessian_constant": "no",
        }
        self.nlpsol = ca.nlpsol("equilibrium", "ipopt", nlp, ipopt_opts)
        self.build_time = time.perf_counter() - t0

    # -- parameters --------------------------------------------------------------------------
    def parameter_vector(self, scene: Scene) -> np.ndarray:
        """Pack a scene's numbers into the NLP parameter vector (named, never by stride)."""
        values = scalar_parameter_values(self.terms, scene)
        fields = [n for n in ("alpha", "b") if n in self.layout.slices]
        values.update(self.transcription.node_field_values(scene, fields))
        return self.layout.pack(values)

    def check_structure(self, scene: Scene) -> None:
        key = structure_key(build_terms(scene))
        if key != self.key:
            raise ValueError(f"scene structure {key} does not match this solver's {self.key}")

    # -- pointwise physics for residuals and reactions ----------------------------------------
    def _pointwise_functions(self, de):
        """Torque density τ = −∂V/∂θ and force density F = −∂V/∂r of the non-bending densities,
        as functions of (θ, x, y, α, b, params) at single points (THEORY §4)."""
        th, x, y, kap = ca.SX.sym("th"), ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("k")
        al, b = ca.SX.sym("alpha"), ca.SX.sym("b")
        P = ca.SX.sym("P", self.layout.size)
        Pd = self.layout.symbols(P)
        from .physics.terms import PointState, TipState

        st = PointState(theta=th, kappa=kap, x=x, y=y, fields={"alpha": al, "b": b})
        V = 0
        for t in self.terms:
            if t.name == "bending":
                continue
            d = t.density(st, {**Pd, "alpha": al, "b": b})
            if d is not None:
                V = V + d
        tip_st = TipState(theta=th, x=x, y=y)
        T = 0
        for t in self.terms:
            e = t.tip(tip_st, Pd)
            if e is not None:
                T = T + e
        V, T = ca.SX(V), ca.SX(T)
        dens = ca.Function("dens", [th, x, y, al, b, P],
                           [-ca.gradient(V, th), -ca.gradient(V, x), -ca.gradient(V, y)])
        tip = ca.Function("tipload", [th, x, y, P],
                          [-ca.gradient(T, th), -ca.gradient(T, x), -ca.gradient(T, y)])
        return dens, tip

    # -- solving -----------------------------------------------------------------------------
    def initial_guess(self, params: np.ndarray, guess=None) -> np.ndarray:
        n = self.transcription.nodes.size
        theta0 = params[self.layout.slices["theta0"]][0]
        if guess is None:
            return np.full(n, theta0)
        guess = np.asarray(guess, float)
        if guess.shape == (n,):
            return guess.copy()
        raise ValueError(f"initial guess has shape {guess.shape}, expected ({n},)")

    def stationarity(self, z: np.ndarray, params: np.ndarray) -> float:
        """max_i |∂Ê/∂θ_i| / m_i over the free nodes: a discrete strong-form residual."""
        _, g, _ = self.f_grad_hess(z[1:], params)
        return float(np.max(np.abs(np.asarray(g).ravel() / self.transcription.mass[1:]), initial=0.0))

    def solve_ipopt(self, z0: np.ndarray, params: np.ndarray) -> RawSolution:
        sol = self.nlpsol(x0=z0, p=params, lbg=0, ubg=0)
        st = self.nlpsol.stats()
        z = np.asarray(sol["x"], float).ravel()
        ok = bool(st.get("success", False))
        return RawSolution(z, ok, st.get("return_status", "unknown"),
                           "IPOPT: " + str(st.get("return_status", "")), int(st.get("iter_count", -1)),
                           self.stationarity(z, params) if np.all(np.isfinite(z)) else np.inf)

    def solve_newton(self, z0: np.ndarray, params: np.ndarray, max_iter: Optional[int] = None,
                     tol: Optional[float] = None) -> RawSolution:
        """Damped Newton on ∇Ê = 0 in the free unknowns (exact Hessian, backtracking on |∇Ê|)."""
        tol = self.options.tol if tol is None else tol
        max_iter = self.options.max_iter if max_iter is None else max_iter
        m = self.transcription.mass[1:]
        z = z0.copy()
        z[0] = params[self.layout.slices["theta0"]][0]
        zr = z[1:].copy()
        _, g, H = self.f_grad_hess(zr, params)
        g = np.asarray(g).ravel()
        res = np.max(np.abs(g / m))
        for it in range(max_iter + 1):
            if not np.isfinite(res):
                break
            if res <= tol:
                z[1:] = zr
                return RawSolution(z, True, "converged", "Newton: converged", it, float(res))
            if it == max_iter:
                break
            try:
                step = -np.linalg.solve(np.asarray(H), g)
            except np.linalg.LinAlgError:
                break
            t = 1.0
            while t > 1e-4:
                _, g_new, H_new = self.f_grad_hess(zr + t * step, params)
                g_new = np.asarray(g_new).ravel()
                res_new = np.max(np.abs(g_new / m))
                if np.isfinite(res_new) and res_new < (1 - 1e-4 * t) * res + 1e-14:
                    break
                t *= 0.5
            else:
                break
            zr, g, H, res = zr + t * step, g_new, H_new, res_new
            if (t == 1.0 and res <= 1e3 * tol
                    and np.max(np.abs(step)) <= 1e-14 * (1.0 + np.max(np.abs(zr)))):
                z[1:] = zr  # a full Newton step below rounding: converged to machine precision
                return RawSolution(z, True, "converged", "Newton: converged (step below rounding)",
                                   it + 1, float(res))
        z[1:] = zr
        return RawSolution(z, False, "not_converged",
                           f"Newton: stationarity {res:.3g} > tol {tol:.3g} after {it} iterations",
                           it, float(res))

    def stability(self, z: np.ndarray, params: np.ndarray, k: int = 3, tol: float = 1e-9) -> StabilityVerdict:
        """Generalised eigenvalues of the reduced Hessian against the lumped mass (THEORY §7)."""
        _, _, H = self.f_grad_hess(z[1:], params)
        H = np.asarray(H, float)
        M = self.transcription.mass[1:]
        Ms = 1.0 / np.sqrt(M)
        A = Ms[:, None] * H * Ms[None, :]
        A = 0.5 * (A + A.T)
        lam, V = scipy.linalg.eigh(A, subset_by_index=[0, min(k, A.shape[0]) - 1])
        vec = np.zeros(z.size)
        vec[1:] = Ms * V[:, 0]
        vec /= np.max(np.abs(vec))
        scale = tol * max(1.0, abs(lam[0]))
        return StabilityVerdict(eigenvalues=lam[:k], eigenvector=vec, morse_index=int(np.sum(lam < -scale)),
                                stable=bool(lam[0] > scale), marginal=bool(abs(lam[0]) <= scale))


def get_solver(scene: Scene, options: SolverOptions) -> EquilibriumSolver:
    """A cached :class:`EquilibriumSolver` for the scene's structure (built on first use)."""
    key = (structure_key(build_terms(scene)), options.transcription, options.elements,
           options.degree if options.transcription == "lgl" else None, options.tol, options.max_iter)
    solver = _CACHE.get(key)
    if solver is None:
        solver = _CACHE[key] = EquilibriumSolver(scene, options)
        solver.cached = False
    else:
        solver.cached = True
    return solver
