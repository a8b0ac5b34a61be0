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
  per iteration; stability uses the banded eigensolver there. When a term reads positions (a
  dipole field, a distributed load) the Hessian is dense and is assembled from its structure
  Φᵀ K Φ (:mod:`.reduced.positional`: per-point second derivatives, the field through its jet)
  instead of being differentiated symbolically as a whole (O(n³) operations).

IPOPT and the classic CasADi functions (``f_grad_hess``, ``f_energy``, ``f_tip``) are built on
first use. Newton convergence needs a small gradient *and* a small Newton step (near bifurcations
and folds a small gradient alone does not locate the equilibrium).

Re-solving with new values is a parameter change and a warm start, never a rebuild;
:func:`get_solver` caches solvers by (structure, transcription, resolution).
"""
from __future__ import annotations

import time
from collections import OrderedDict
from typing import Optional, Tuple

import casadi as ca
import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene
from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.physics.registry import build_terms
from actuator_design.physics.term_protocol import (node_field_sources, residual_slots,
                                                   scalar_parameter_values, structure_key)
from actuator_design.reduced.descent import trust_region_descent
from actuator_design.reduced.kernel import FastKernel
from actuator_design.reduced.linalg import FLOOR_EXCUSE
from actuator_design.reduced.newton import RawSolution, damped_newton, fast_newton
from actuator_design.reduced.positional import positional_hessian
from actuator_design.reduced.stability import STABILITY_TOL, StabilityVerdict, kernel_verdict
from actuator_design.transcription import make_transcription

__all__ = ["EquilibriumSolver", "get_solver", "RawSolution", "StabilityVerdict", "FastKernel", "STALLED"]

#: solvers kept built (least recently used dropped first): each contact split round and each new
#: mesh builds one, and an unbounded cache grew a test session past 3 GB
SOLVER_CACHE_SIZE = 32
_CACHE: "OrderedDict[tuple, EquilibriumSolver]" = OrderedDict()


def _jit_options() -> dict:
    return {"jit": True, "compiler": "shell", "jit_cleanup": True,
            "jit_options": {"flags": ["-O2"], "verbose": False}}


#: IPOPT's status when its steps fell below round-off before its error met the tolerance
STALLED = "Search_Direction_Becomes_Too_Small"


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
        self._sym = (z, zr, P, E, Er, gr)
        self._Hr = None
        self._f_energy = self._f_grad_hess = self._f_tip = None
        self._node_fields = node_field_sources(self.terms)
        self._pointwise = self._pointwise_functions(de)
        self._theta0_index = self.layout.slices["theta0"].start
        sl = self.layout.slices
        scales = residual_slots(self.terms)  # each term says how its values size the residual
        self._scale_lin = [sl[k].start for k, how in scales.items() if how == "linear" and k in sl]
        self._scale_sq = [sl[k].start for k, how in scales.items() if how == "squared" and k in sl]
        self.jit_note = ""
        self.hessian_mapped = False  # set by the positional kernel (see nlpsol)
        self.kernel = self._build_kernel(zr, P, gr, options.jit)
        summary = ca.Function("summary", [z, P], [ca.vertcat(E, *de.tip)])
        self._summary_in = (np.zeros(z.numel()), np.zeros(self.layout.size))
        self._summary_out = np.zeros(4)
        self._summary_buf, self._summary_eval = summary.buffer()
        self._summary_buf.set_arg(0, memoryview(self._summary_in[0]))
        self._summary_buf.set_arg(1, memoryview(self._summary_in[1]))
        self._summary_buf.set_res(0, memoryview(self._summary_out))

        # the objective's weight w (a parameter, 1 but for a rescue: see solve_ipopt)
        w = ca.SX.sym("objective_weight")
        self._nlp = {"x": z, "p": ca.vertcat(P, w), "f": w * E, "g": z[0] - theta0}
        self._nlpsol = None
        self.build_time = time.perf_counter() - t0

    @property
    def reduced_energy(self) -> Tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        """The package's one derivation of the reduced energy: ``(u, P, Ê, ∇Ê)``, symbolic, with
        u = θ_1..θ_n (SX (n,)) the free unknowns, θ_0 = θ0(P) substituted (the clamp), P the NLP
        parameters (SX (n_params,)), Ê(u; P) the energy and ∇_u Ê (n,) its gradient. The reduced
        system (:mod:`actuator_design.reduced.system`), fits and hardware maps build on it."""
        _, zr, P, _, Er, gr = self._sym
        return zr, P, Er, gr

    # CasADi functions in the classic calling convention, built on first use
    @property
    def f_energy(self) -> ca.Function:
        """``[z (n_nodes,), params] -> Ê``."""
        if self._f_energy is None:
            z, _, P, E, _, _ = self._sym
            self._f_energy = ca.Function("energy", [z, P], [E])
        return self._f_energy

    @property
    def f_grad_hess(self) -> ca.Function:
        """``[θ_free (n,), params] -> [Ê, ∇Ê (n,), ∇²Ê (n, n)]`` with θ_0 = θ0 eliminated."""
        if self._f_grad_hess is None:
            _, zr, P, _, Er, gr = self._sym
            self._f_grad_hess = ca.Function("grad_hess", [zr, P], [Er, gr, self._hessian_expr()])
        return self._f_grad_hess

    @property
    def f_tip(self) -> ca.Function:
        """``[z, params] -> [θ(1), x(1), y(1)]``."""
        if self._f_tip is None:
            z, _, P, _, _, _ = self._sym
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
                # a trial point where the energy is not finite (a rod point on a source's centre)
                # is IPOPT's to step back from, not a warning on the user's terminal
                "show_eval_warnings": False,
            }
            if self.hessian_mapped:  # the exact Hessian of the whole energy would take seconds to
                # build (a fitted field's jet at every point, O(n³)): quasi-Newton, then the Newton
                # polish with the structured Hessian
                ipopt_opts["ipopt.hessian_approximation"] = "limited-memory"
            self._nlpsol = ca.nlpsol("equilibrium", "ipopt", self._nlp, ipopt_opts)
            self.build_time += time.perf_counter() - t0
        return self._nlpsol

    def _hessian_expr(self) -> ca.SX:
        """∇²Ê in the free unknowns, symbolic (built on first use: O(n³) for positional terms)."""
        if self._Hr is None:
            _, zr, _, _, _, gr = self._sym
            self._Hr = ca.jacobian(gr, zr, {"symmetric": True})  # = ca.hessian, faster to build
        return self._Hr

    def _residual(self, g):
        """max_i |g_i|/m_i, computed inside the kernel's functions (no numpy work per call)."""
        return ca.mmax(ca.fabs(g * ca.DM(1.0 / self.transcription.mass[1:])))

    def _positional_kernel(self, P, jit: bool) -> Optional[FastKernel]:
        """The kernel of an energy that reads positions: the dense Hessian assembled as Φᵀ K Φ and
        the gradient as Φᵀ ∇F, the field through its jet (:mod:`.reduced.positional`); ``None``
        when the energy does not have that structure."""
        de = self.discrete
        structured = positional_hessian(self.transcription, self.terms, self.layout, P,
                                        ca.Function("energy", [de.z, P], [de.energy]))
        if structured is None:
            return None
        u, g = structured.u, structured.gradient
        self.hessian_mapped = g is None
        f_g = None
        if jit and g is None:
            self.jit_note = "not JIT-compiled: the field's per-point derivatives are mapped, not inlined"
        elif jit:
            try:
                f_g = ca.Function("grad_fast", [u, P], [g, self._residual(g)], _jit_options())
                structured.compile(_jit_options())
                self.jit_note = "JIT-compiled"
            except Exception as exc:  # no compiler, or it failed: the VM gives the same numbers
                f_g = None
                self.jit_note = f"JIT compilation failed ({type(exc).__name__}); CasADi VM used"
        if f_g is None:  # the matrix graph: ~20 % cheaper than the SX gradient in the VM
            f_g = structured.gradient_function(1.0 / self.transcription.mass[1:])
        return FastKernel(f_g, None, self.transcription.mass[1:], hessian=structured)

    def _build_kernel(self, zr, P, g, jit: bool) -> FastKernel:
        if self.discrete.uses_positions:
            kernel = self._positional_kernel(P, jit)
            if kernel is not None:
                return kernel
        r = self._residual(g)
        H = self._hessian_expr()
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
        """IPOPT on the energy from ``z0`` (θ at the nodes, rad).

        A clamp angle beyond ±π is solved in the frame turned back by the nearest whole number of
        turns 2πk, and the answer turned forward again, when every term is 2π-periodic in θ up to a
        constant (``EnergyTerm.periodic_in_theta``: every built-in term; a tip moment's −m θ(1)):
        IPOPT's step tests are relative to |θ| and stop it early when θ is far from 0 (a clamp angle
        of 3e4 deg failed where 0 deg converged)."""
        turns = 0.0
        if all(t.periodic_in_theta for t in self.terms):
            turns = 2.0 * np.pi * np.round(params[self._theta0_index] / (2.0 * np.pi))
        x0, shifted = np.asarray(z0, float) - turns, np.array(params, float)
        shifted[self._theta0_index] -= turns
        sol = self.nlpsol(x0=x0, p=np.append(shifted, 1.0), lbg=0, ubg=0)
        st = self.nlpsol.stats()
        if st.get("return_status") == STALLED:
            weight = self.objective_weight(x0, shifted)
            if weight < 1.0:
                # IPOPT stopped because its steps fell below round-off while its error was above its
                # tolerance, which was below the rounding of the gradient at the start (a rod close to
                # a magnet, where the forces are huge, started at or next to its equilibrium, where
                # IPOPT's own gradient scaling does not act): the same problem, with the energy scaled
                # so that its rounding is below the tolerance, from the same start
                sol = self.nlpsol(x0=x0, p=np.append(shifted, weight), lbg=0, ubg=0)
                first = int(st.get("iter_count", 0))
                st = dict(self.nlpsol.stats())
                st["iter_count"] = first + int(st.get("iter_count", 0))  # both runs
                st["note"] = f"{STALLED}, then with the energy weighted by {weight:.3g}: "
        z = np.asarray(sol["x"], float).ravel() + turns
        ok = bool(st.get("success", False))
        return RawSolution(z, ok, st.get("return_status", "unknown"),
                           "IPOPT: " + st.get("note", "") + str(st.get("return_status", "")), int(st.get("iter_count", -1)),
                           self.stationarity(z, params) if np.all(np.isfinite(z)) else np.inf)

    def objective_weight(self, z0: np.ndarray, params: np.ndarray) -> float:
        """min(1, tol / ρ), with ρ = 16 ε max_i Σ_j |∂²Ê/∂θ_i∂θ_j| · max(1, |θ|∞) the rounding of the
        gradient ∇Ê at ``z0`` (θ at the nodes, rad; a generous bound): the weight of the energy that
        lifts IPOPT's absolute tolerance on the gradient to that rounding."""
        self.kernel.set_params(params)
        self.kernel.evaluate(np.asarray(z0, float)[1:], hessian=True)
        rho = self.kernel.gradient_rounding(np.asarray(z0, float)[1:])
        tol = max(self.options.tol, 1e-14)
        return 1.0 if rho <= 0.0 else min(1.0, tol / rho)

    def descend(self, z0: np.ndarray, params: np.ndarray, admissible=None) -> RawSolution:
        """The minimum that descent of the energy from ``z0`` reaches, whatever the iteration cap.

        IPOPT where it has the exact Hessian; where it would run quasi-Newton (``hessian_mapped``: a
        fitted field), the trust-region Newton descent of
        :func:`~actuator_design.reduced.descent.trust_region_descent` with the kernel's exact
        Hessian, its end accepted only as a stable state (the stability rule) whose energy is not
        above the start's.

        Parameters
        ----------
        z0 : ndarray, shape (n_nodes,)
            Start (θ at the nodes, rad).
        params : ndarray, shape (n_params,)
        admissible : callable, optional
            ``z (n_nodes,) -> bool``, the states the descent may step to (the trust-region descent
            only; IPOPT is not asked).

        Returns
        -------
        RawSolution
        """
        if not self.hessian_mapped:
            return self.solve_ipopt(z0, params)
        tol = self.options.tol
        scale = self.residual_scale(params)
        self.kernel.set_params(params)
        start = self.summary(np.asarray(z0, float), params)[0]
        raw = trust_region_descent(self.kernel, lambda z: self.summary(z, params)[0], z0,
                                   params[self._theta0_index], tol * scale, 10.0 * tol, admissible=admissible)
        if raw.converged:
            end = self.summary(raw.z, params)[0]
            if not self.stability(raw.z, params).stable:
                raw.converged, raw.status = False, "not_a_minimum"
                raw.message += "; its end is not a stable state"
            elif end > start + 1e-12 * max(1.0, abs(start)):
                raw.converged, raw.status = False, "not_a_minimum"
                raw.message += f"; its end's energy {end:.12g} is above the start's {start:.12g}"
        return raw

    def solve_newton(self, z0: np.ndarray, params: np.ndarray, max_iter: Optional[int] = None,
                     tol: Optional[float] = None, floor_scale: Optional[float] = None) -> RawSolution:
        """Damped Newton on ∇Ê = 0 in the free unknowns (exact Hessian, backtracking on |∇Ê|).

        Converged when max_i |∂Ê/∂θ_i|/m_i ≤ tol · :meth:`residual_scale` and the Newton step there
        is ≤ 10 · tol (the point after that step is returned), or when a full step is below
        rounding with the residual within 1e3 of the tolerance. Near bifurcations a small gradient
        alone does not locate the equilibrium: the step test does. ``floor_scale``: as :meth:`solve_fast`.
        """
        tol = self.options.tol if tol is None else tol
        max_iter = self.options.max_iter if max_iter is None else max_iter
        self.kernel.set_params(params)
        return damped_newton(self.kernel, z0, params[self._theta0_index], tol * self.residual_scale(params),
                             10.0 * tol, max_iter, None if floor_scale is None else FLOOR_EXCUSE * tol * floor_scale)

    def solve_fast(self, z0: np.ndarray, params: np.ndarray, max_iter: int = 30,
                   tol: Optional[float] = None, floor_scale: Optional[float] = None) -> RawSolution:
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
        floor_scale : float, optional
            The residual scale whose tolerance caps what rounding may excuse (default ``params``'
            own): a path's states on a mesh graded for a larger load pass the load's.
        """
        tol = self.options.tol if tol is None else tol
        self.kernel.set_params(params)
        return fast_newton(self.kernel, z0, params[self._theta0_index], tol * self.residual_scale(params),
                           10.0 * tol, max_iter, None if floor_scale is None else FLOOR_EXCUSE * tol * floor_scale)

    def stability(self, z: np.ndarray, params: np.ndarray, k: int = 3, tol: float = STABILITY_TOL) -> StabilityVerdict:
        """Generalised eigenvalues of the reduced Hessian against the lumped mass (THEORY §7), judged
        by the one stability rule (:mod:`actuator_design.reduced.stability`)."""
        return kernel_verdict(self.kernel, z, params, k, tol)


def get_solver(scene: Scene, options: SolverOptions) -> EquilibriumSolver:
    """A cached :class:`EquilibriumSolver` for the scene's structure (built on first use)."""
    lgl = options.transcription == "lgl"
    key = (structure_key(build_terms(scene)), options.transcription, options.elements,
           options.degree if lgl else None,
           (options.clamp_levels, options.tip_levels, options.split_at) if lgl else None,
           options.tol, options.max_iter, bool(options.jit))
    solver = _CACHE.get(key)
    if solver is None:
        solver = _CACHE[key] = EquilibriumSolver(scene, options)
        solver.cached = False
        while len(_CACHE) > SOLVER_CACHE_SIZE:
            _CACHE.popitem(last=False)
    else:
        solver.cached = True
        _CACHE.move_to_end(key)
    return solver
