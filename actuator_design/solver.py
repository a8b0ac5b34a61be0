"""Equilibria as minimisers of the discrete energy: one built NLP per scene structure.

:class:`EquilibriumSolver` transcribes the scene's energy terms once, with every number (h, φ, p,
the fibre angles at the quadrature points, …) in the NLP parameter vector, and builds

* an IPOPT solver for  min_θ Ê(θ; params)  s.t.  θ_0 = θ0  (the clamp as a constraint),
* CasADi functions for the gradient and Hessian of Ê in the free unknowns (θ_0 = θ0 eliminated),
  used for the Newton path, for polishing and for the stability verdict,
* a low-overhead kernel (:class:`FastKernel`) for the Newton paths: the gradient and Hessian are
  evaluated through CasADi's buffer interface into preallocated numpy arrays (optionally JIT-compiled
  C), and the Newton system is factorised by LAPACK directly — dense (``getrf``) for the small
  spectral systems, tridiagonal (``gttrf``) or banded
  (``gbtrf``) when no term needs positions (midpoint, multi-element LGL), so N = 2000 costs O(N)
  per iteration; stability uses the banded eigensolver there.

IPOPT and the classic CasADi functions (``f_grad_hess``, ``f_energy``, ``f_tip``) are built on
first use. Newton convergence needs a small gradient *and* a small Newton step (near bifurcations
and folds a small gradient alone does not locate the equilibrium).

Re-solving with new values is a parameter change and a warm start, never a rebuild;
:func:`get_solver` caches solvers by (structure, transcription, resolution).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, Optional

import casadi as ca
import numpy as np
from scipy.linalg import lapack

from .options import SolverOptions
from .physics.kinematics import PlanarKinematics, PlanarTip
from .physics.terms import (build_terms, node_field_sources, residual_slots, scalar_parameter_values,
                            structure_key)
from .reduced.linalg import lowest_eigenpairs as _lowest_eigenpairs
from .reduced.newton import RawSolution, damped_newton, fast_newton
from .scene import Scene
from .transcription import make_transcription

__all__ = ["EquilibriumSolver", "get_solver", "RawSolution", "StabilityVerdict", "FastKernel"]

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


def _jit_options() -> dict:
    return {"jit": True, "compiler": "shell", "jit_cleanup": True,
            "jit_options": {"flags": ["-O2"], "verbose": False}}


class FastKernel:
    """Gradient, Hessian and Newton steps in the free unknowns with minimal per-call overhead.

    Two CasADi functions, ``[θ_free, params] -> ∇Ê`` and ``-> (∇Ê, ∇²Ê)``, are called through their
    buffer interface (no argument conversion: inputs and outputs are preallocated float64 arrays
    shared by both), and the Newton system is factorised and solved with direct LAPACK calls chosen
    from the Hessian's sparsity: ``getrf/getrs`` (dense), ``gttrf/gttrs`` (tridiagonal) or
    ``gbtrf/gbtrs`` (banded, bandwidth ≪ n). The gradient alone costs a fraction of the Hessian,
    which lets :meth:`EquilibriumSolver.solve_fast` reuse a factorisation over several steps.

    Not thread-safe (one set of buffers per solver); processes build their own.

    Parameters
    ----------
    f_g, f_gh : casadi.Function
        ``[θ_free (n,), params (n_p,)] -> [g (n,), r]`` and ``-> [g (n,), r, H (n, n) sparse]``,
        r = max_i |g_i| / m_i.
    mass : ndarray, shape (n,)
        Lumped mass of the free nodes: the residual is max_i |g_i| / m_i.
    """

    def __init__(self, f_g: ca.Function, f_gh: ca.Function, mass: np.ndarray):
        self.n = n = int(f_gh.size1_in(0))
        self.z = np.zeros(n)
        self.p = np.zeros(int(f_gh.nnz_in(1)))
        self.g = np.zeros(n)
        sp = f_gh.sparsity_out(2)
        self.hnz = np.zeros(sp.nnz())
        self.r = np.zeros(1)
        self._buf_g, self._eval_g = f_g.buffer()
        self._buf_gh, self._eval_gh = f_gh.buffer()
        for buf in (self._buf_g, self._buf_gh):
            buf.set_arg(0, memoryview(self.z))
            buf.set_arg(1, memoryview(self.p))
            buf.set_res(0, memoryview(self.g))
            buf.set_res(1, memoryview(self.r))
        self._buf_gh.set_res(2, memoryview(self.hnz))
        rows, cols = (np.asarray(v, dtype=np.intp) for v in sp.get_triplet())
        self.rows, self.cols = rows, cols
        self.inv_mass = 1.0 / np.asarray(mass, float)
        bw = int(np.max(np.abs(rows - cols), initial=0))
        self.bandwidth = bw
        self._lu = None
        if bw <= 1 and n > 2:
            self.kind = "tridiagonal"
            diag, lower, upper = rows == cols, rows == cols + 1, cols == rows + 1
            self._idx_d = np.flatnonzero(diag)[np.argsort(rows[diag])]
            self._idx_l = np.flatnonzero(lower)[np.argsort(cols[lower])]
            self._idx_u = np.flatnonzero(upper)[np.argsort(rows[upper])]
        elif n >= 64 and 4 * bw < n:
            self.kind = "banded"
            self._ab = np.zeros((3 * bw + 1, n), order="F")
            self._ab_rows = 2 * bw + rows - cols  # LAPACK gbtrf storage: ab[kl+ku+i-j, j]
        else:
            self.kind = "dense"
            # a structurally dense Hessian comes column by column: view it as a Fortran matrix
            self._H = (self.hnz.reshape((n, n), order="F") if sp.nnz() == n * n
                       else np.zeros((n, n), order="F"))
            self._H_is_view = sp.nnz() == n * n

    # -- evaluation ---------------------------------------------------------------------------
    def set_params(self, params: np.ndarray) -> None:
        self.p[:] = params

    def evaluate(self, zr: np.ndarray, hessian: bool = True) -> float:
        """Evaluate ∇Ê (and ∇²Ê) at ``zr`` (free unknowns); returns max_i |g_i|/m_i."""
        self.z[:] = zr
        if hessian:
            self._eval_gh()
        else:
            self._eval_g()
        return float(self.r[0])

    def rounding_floor(self, zr: np.ndarray) -> float:
        """The residual that rounding alone produces at ``zr``: 16 ε max_i Σ_j |H_ij| |z|∞ / m_i
        (last evaluated H). For fine meshes (midpoint N ≳ 1000) it reaches 1e-10. The solvers
        accept a residual above tolerance on this ground only up to 1e4 × tolerance (a huge
        Hessian, e.g. a rod touching a dipole's singularity, must not excuse a large residual)."""
        rowsum = np.bincount(self.rows, weights=np.abs(self.hnz), minlength=self.n)
        return float(16.0 * np.finfo(float).eps * np.max(rowsum * self.inv_mass)
                     * max(1.0, float(np.abs(zr).max(initial=0.0))))

    def hessian_dense(self) -> np.ndarray:
        """The last evaluated Hessian as a dense array, shape (n, n)."""
        H = np.zeros((self.n, self.n))
        H[self.rows, self.cols] = self.hnz
        return H

    def factorize(self) -> bool:
        """LU-factorise the last evaluated Hessian; False when it is singular."""
        h = self.hnz
        if self.kind == "dense":
            H = self._H
            if not self._H_is_view:
                H[self.rows, self.cols] = h
            lu, piv, info = lapack.dgetrf(H)
            self._lu = (lu, piv)
        elif self.kind == "tridiagonal":
            dl, d, du, du2, piv, info = lapack.dgttrf(h[self._idx_l], h[self._idx_d], h[self._idx_u])
            self._lu = (dl, d, du, du2, piv)
        else:
            ab = self._ab
            ab[self._ab_rows, self.cols] = h
            lu, piv, info = lapack.dgbtrf(ab, self.bandwidth, self.bandwidth)
            self._lu = (lu, piv)
        if info != 0:
            self._lu = None
        return self._lu is not None

    def solve(self) -> Optional[np.ndarray]:
        """The Newton step H⁻¹ g for the current gradient and the last factorisation."""
        if self._lu is None:
            return None
        if self.kind == "dense":
            x, info = lapack.dgetrs(self._lu[0], self._lu[1], self.g)
        elif self.kind == "tridiagonal":
            x, info = lapack.dgttrs(*self._lu, self.g)
        else:
            bw = self.bandwidth
            x, info = lapack.dgbtrs(self._lu[0], bw, bw, self.g, self._lu[1])
        if info != 0:
            return None
        return x.ravel()  # non-finite values are caught by the callers' residual tests

    def newton_step(self) -> Optional[np.ndarray]:
        """Factorise the last evaluated Hessian and return H⁻¹ g (``None`` if singular)."""
        return self.solve() if self.factorize() else None

    def lowest_eigenpairs(self, k: int):
        """Smallest ``k`` eigenvalues of M^-1/2 H M^-1/2 (last evaluated H), ascending, and the
        eigenvector of the smallest, shape (n,): :func:`~actuator_design.reduced.linalg.lowest_eigenpairs`
        on banded storage for band Hessians (n ≥ 64), dense otherwise."""
        banded = self.kind in ("tridiagonal", "banded") and self.n >= 64
        return _lowest_eigenpairs(self.rows, self.cols, self.hnz, self.inv_mass, k, banded,
                                  self.bandwidth)


class EquilibriumSolver:
    """Everything that is built once for a scene structure and a transcription.

    Parameters
    ----------
    scene : Scene
        Any scene of the structure; its numbers are not baked in.
    options : SolverOptions

    Attributes
    ----------
    kernel : FastKernel
        Low-overhead gradient/Hessian/Newton-step evaluation (``solve_fast``, ``solve_newton``,
        ``stability``).
    build_time : float
        Seconds spent building (IPOPT's construction is added when it is first used).
    jit_note : str
        "JIT-compiled", or why the CasADi VM is used although ``options.jit`` was set.
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
        gr = ca.gradient(Er, zr)
        Hr = ca.jacobian(gr, zr, {"symmetric": True})  # = ca.hessian, faster to build when large
        self._sym = (z, zr, P, E, Er, gr, Hr)
        self._f_energy = self._f_grad_hess = self._f_tip = None
        self._node_fields = node_field_sources(self.terms)
        self._pointwise = self._pointwise_functions(de)
        self._theta0_index = self.layout.slices["theta0"].start
        sl = self.layout.slices
        scales = residual_slots(self.terms)  # each term says how its values size the residual
        self._scale_lin = [sl[k].start for k, how in scales.items() if how == "linear" and k in sl]
        self._scale_sq = [sl[k].start for k, how in scales.items() if how == "squared" and k in sl]
        self.jit_note = ""
        self.kernel = self._build_kernel(zr, P, gr, Hr, options.jit)
        summary = ca.Function("summary", [z, P], [ca.vertcat(E, *de.tip)])
        self._summary_in = (np.zeros(z.numel()), np.zeros(self.layout.size))
        self._summary_out = np.zeros(4)
        self._summary_buf, self._summary_eval = summary.buffer()
        self._summary_buf.set_arg(0, memoryview(self._summary_in[0]))
        self._summary_buf.set_arg(1, memoryview(self._summary_in[1]))
        self._summary_buf.set_res(0, memoryview(self._summary_out))

        self._nlp = {"x": z, "p": P, "f": E, "g": z[0] - theta0}
        self._nlpsol = None
        self.build_time = time.perf_counter() - t0

    # CasADi functions in the classic calling convention, built on first use
    @property
    def f_energy(self) -> ca.Function:
        """``[z (n_nodes,), params] -> Ê``."""
        if self._f_energy is None:
            z, _, P, E, _, _, _ = self._sym
            self._f_energy = ca.Function("energy", [z, P], [E])
        return self._f_energy

    @property
    def f_grad_hess(self) -> ca.Function:
        """``[θ_free (n,), params] -> [Ê, ∇Ê (n,), ∇²Ê (n, n)]`` with θ_0 = θ0 eliminated."""
        if self._f_grad_hess is None:
            _, zr, P, _, Er, gr, Hr = self._sym
            self._f_grad_hess = ca.Function("grad_hess", [zr, P], [Er, gr, Hr])
        return self._f_grad_hess

    @property
    def f_tip(self) -> ca.Function:
        """``[z, params] -> [θ(1), x(1), y(1)]``."""
        if self._f_tip is None:
            z, _, P, _, _, _, _ = self._sym
            self._f_tip = ca.Function("tip", [z, P], list(self.discrete.tip))
        return self._f_tip

    @property
    def nlpsol(self):
        """The IPOPT solver, built on first use (its construction time is added to build_time)."""
        if self._nlpsol is None:
            t0 = time.perf_counter()
            ipopt_opts = {
                "print_time": False,
                "ipopt.print_level": 0,
                "ipopt.sb": "yes",
                "ipopt.tol": max(self.options.tol, 1e-14),
                "ipopt.max_iter": int(self.options.max_iter),
                "ipopt.hessian_constant": "no",
            }
            self._nlpsol = ca.nlpsol("equilibrium", "ipopt", self._nlp, ipopt_opts)
            self.build_time += time.perf_counter() - t0
        return self._nlpsol

    def _build_kernel(self, zr, P, g, H, jit: bool) -> FastKernel:
        # the residual max_i |g_i|/m_i is computed inside the function (no numpy work per call)
        r = ca.mmax(ca.fabs(g * ca.DM(1.0 / self.transcription.mass[1:])))
        fs = None
        if jit:
            try:
                fs = (ca.Function("grad_fast", [zr, P], [g, r], _jit_options()),
                      ca.Function("grad_hess_fast", [zr, P], [g, r, H], _jit_options()))
                self.jit_note = "JIT-compiled"
            except Exception as exc:  # no compiler, or it failed: the VM gives the same numbers
                self.jit_note = f"JIT compilation failed ({type(exc).__name__}); CasADi VM used"
        if fs is None:
            fs = (ca.Function("grad_fast", [zr, P], [g, r]),
                  ca.Function("grad_hess_fast", [zr, P], [g, r, H]))
            if fs[1].n_instructions() <= 20000:
                # common-subexpression elimination: ~25 % faster evaluation of small systems; on big
                # expressions (positions, dense Hessians) it costs seconds of build time
                fs = (ca.Function("grad_fast", [zr, P], [g, r], {"cse": True}),
                      ca.Function("grad_hess_fast", [zr, P], [g, r, H], {"cse": True}))
        return FastKernel(*fs, self.transcription.mass[1:])

    def summary(self, z: np.ndarray, params: np.ndarray):
        """(Ê, θ(1), x(1), y(1)) at the full node vector ``z``, through a low-overhead buffer."""
        self._summary_in[0][:] = z
        self._summary_in[1][:] = params
        self._summary_eval()
        o = self._summary_out
        return float(o[0]), float(o[1]), float(o[2]), float(o[3])

    def residual_scale(self, params: np.ndarray) -> float:
        """max(1, h², h_pos², |f|, |m|, |q|, …): the size of the forces in the stationarity equations,
        each slot entering linearly or squared as its term declares (``EnergyTerm.residual_scale``).

        Convergence is tested on the residual relative to this scale, so that huge fields or loads
        (whose rounding floor is ε times their size) are not held to an absolute 1e-10.
        """
        out = 1.0
        for i in self._scale_lin:
            out = max(out, abs(float(params[i])))
        for i in self._scale_sq:
            out = max(out, float(params[i]) ** 2)
        return out

    # -- parameters --------------------------------------------------------------------------
    def parameter_vector(self, scene: Scene) -> np.ndarray:
        """Pack a scene's numbers into the NLP parameter vector (named, never by stride)."""
        values = scalar_parameter_values(self.terms, scene)
        s = self.transcription.quadrature_points
        for name, field_values in self._node_fields.items():  # per-point fields the terms read
            values[name] = field_values(scene, s)
        out = np.empty(self.layout.size)
        for name, sl in self.layout.slices.items():
            if name not in values:
                raise KeyError(f"missing NLP parameter {name!r}")
            out[sl] = values[name]  # a scalar or an array of the slice's length
        return out

    def check_structure(self, scene: Scene) -> None:
        key = structure_key(build_terms(scene))
        if key != self.key:
            raise ValueError(f"scene structure {key} does not match this solver's {self.key}")

    # -- pointwise physics for residuals and reactions ----------------------------------------
    def _pointwise_functions(self, de):
        """Pointwise loads of all terms at single points (THEORY §4), for residuals and reactions.

        Returns ``dens``: (θ, x, y, κ, *fields, params) -> (τ, Fx, Fy, M) with τ = −∂V/∂θ the
        distributed torque, F = −∂V/∂r the distributed force and M = ∂V/∂κ the internal bending
        moment of the densities V (M = bθ' for the bending term), the fields in the order of
        ``node_field_sources``; and ``tip``: (θ, x, y, params) -> (m, fx, fy), the tip loads.
        """
        th, x, y, kap = ca.SX.sym("th"), ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("k")
        fsyms = {name: ca.SX.sym(name) for name in self._node_fields}
        P = ca.SX.sym("P", self.layout.size)
        Pd = {**self.layout.symbols(P), **fsyms}
        kin = PlanarKinematics(theta=th, kappa=kap, fields=fsyms, positions=(x, y))
        V = 0
        for t in self.terms:
            d = t.density(kin, Pd)
            if d is not None:
                V = V + d
        tip_st = PlanarTip(theta=th, x=x, y=y)
        T = 0
        for t in self.terms:
            e = t.tip(tip_st, Pd)
            if e is not None:
                T = T + e
        V, T = ca.SX(V), ca.SX(T)
        dens = ca.Function("dens", [th, x, y, kap, *fsyms.values(), P],
                           [-ca.gradient(V, th), -ca.gradient(V, x), -ca.gradient(V, y),
                            ca.gradient(V, kap)])
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
        self.kernel.set_params(params)
        return self.kernel.evaluate(np.asarray(z, float)[1:])

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
        """Damped Newton on ∇Ê = 0 in the free unknowns (exact Hessian, backtracking on |∇Ê|).

        Converged when max_i |∂Ê/∂θ_i|/m_i ≤ tol · :meth:`residual_scale` and the Newton step there
        is ≤ 10 · tol (the point after that step is returned), or when a full step is below
        rounding with the residual within 1e3 of the tolerance. Near bifurcations a small gradient
        alone does not locate the equilibrium: the step test does.
        """
        tol = self.options.tol if tol is None else tol
        max_iter = self.options.max_iter if max_iter is None else max_iter
        self.kernel.set_params(params)
        return damped_newton(self.kernel, z0, params[self._theta0_index],
                             tol * self.residual_scale(params), 10.0 * tol, max_iter)

    def solve_fast(self, z0: np.ndarray, params: np.ndarray, max_iter: int = 30,
                   tol: Optional[float] = None) -> RawSolution:
        """Newton on ∇Ê = 0 from a warm start with the exact Hessian, reused while it contracts:
        the fast path (``method="fast"``).

        The Hessian is evaluated and LU-factorised once; later steps reuse the factorisation (each
        costs one gradient evaluation and one triangular solve or matrix-vector product) as long
        as the residual r = max_i |∂Ê/∂θ_i|/m_i falls at least tenfold per step; otherwise the
        Hessian is re-evaluated at the current iterate (a full Newton step).

        Converged means r ≤ tol · :meth:`residual_scale` **and** a Newton step of size ≤ 10 · tol
        (rad) at that point: near bifurcations and folds the energy is so flat that a small
        gradient alone does not locate the equilibrium. The returned point is the one after that
        last small step, its residual evaluated there. Safeguards, so that it never returns a wrong
        answer as converged: a step computed with a fresh Hessian must reduce r (while r is above
        tolerance), the Hessian must be non-singular and every value finite — otherwise it stops
        with ``converged=False`` (``solve`` then falls back to :meth:`solve_newton` and IPOPT).

        Parameters
        ----------
        z0 : ndarray, shape (n_nodes,)
            Warm start (θ at the nodes; θ_0 is reset to the clamp angle).
        params : ndarray, shape (n_params,)
        max_iter : int
            Maximum number of steps.
        tol : float, optional
            Default ``options.tol``.
        """
        tol = self.options.tol if tol is None else tol
        self.kernel.set_params(params)
        return fast_newton(self.kernel, z0, params[self._theta0_index],
                           tol * self.residual_scale(params), 10.0 * tol, max_iter)

    def stability(self, z: np.ndarray, params: np.ndarray, k: int = 3, tol: float = 1e-9) -> StabilityVerdict:
        """Generalised eigenvalues of the reduced Hessian against the lumped mass (THEORY §7)."""
        ker = self.kernel
        ker.set_params(params)
        ker.evaluate(np.asarray(z, float)[1:])
        lam, v0 = ker.lowest_eigenpairs(k)
        Ms = np.sqrt(ker.inv_mass)
        vec = np.zeros(np.size(z))
        vec[1:] = Ms * v0
        vec /= np.max(np.abs(vec))
        scale = tol * max(1.0, abs(lam[0]))
        return StabilityVerdict(eigenvalues=lam[:k], eigenvector=vec, morse_index=int(np.sum(lam < -scale)),
                                stable=bool(lam[0] > scale), marginal=bool(abs(lam[0]) <= scale))


def get_solver(scene: Scene, options: SolverOptions) -> EquilibriumSolver:
    """A cached :class:`EquilibriumSolver` for the scene's structure (built on first use)."""
    key = (structure_key(build_terms(scene)), options.transcription, options.elements,
           options.degree if options.transcription == "lgl" else None, options.tol, options.max_iter,
           bool(options.jit))
    solver = _CACHE.get(key)
    if solver is None:
        solver = _CACHE[key] = EquilibriumSolver(scene, options)
        solver.cached = False
    else:
        solver.cached = True
    return solver
