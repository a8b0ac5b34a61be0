"""The reduced system of a built NLP: the energy in the free unknowns with the clamp eliminated.

For an :class:`~actuator_design.equilibrium.solver.EquilibriumSolver` and a list of parameter names λ =
(λ_1, …, λ_k) (each replacing the NLP entries it controls — by √λ for ``h2``, every quadrature
point for ``alpha``), the reduced energy Ê(u; λ, P) with u = (θ_1, …, θ_n) (θ_0 = θ0 substituted)
gives, all as CasADi functions built once and cached per (structure, transcription, names):

* g = ∇_u Ê (n,), H = ∇²_u Ê (n, n; its band structure is kept: ``hessian_pattern``), G_λ = ∂g/∂λ (n, k);
* the Moore–Spence fold system F = [g; H v; cᵀMv − 1] and its Jacobian (directional third
  derivatives ∂(Hv)/∂u, ∂(Hv)/∂λ), with ∂F/∂λ_2.. for fold curves;
* the tip map (θ(1), x(1), y(1)) and its Jacobians in u and λ;
* with no names: ∂g/∂P and ∂(vᵀHv)/∂(u, P) in the full NLP parameter vector (sensitivities).

Evaluation through CasADi's buffer interface into preallocated arrays (:class:`SystemEvaluator`).
"""
from __future__ import annotations

from functools import cached_property
from typing import Dict, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.physics.parameters import parameter  # the parameter lens

__all__ = ["ReducedSystem", "reduced_system", "substituted_energy", "params_at", "SystemEvaluator",
           "KernelSystemEvaluator"]

_CACHE: Dict[tuple, "ReducedSystem"] = {}


def _slot(name: str) -> Tuple[str, object]:
    """(NLP parameter slot, slot expression of the symbol) of a lens parameter name."""
    par = parameter(name, "continuation parameter")
    return par.slot, par.slot_expr


def substituted_energy(solver, names: Sequence[str]):
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
    lay = solver.layout
    for name in names:
        slot, _ = _slot(name)
        if slot not in lay.slices:
            raise ValueError(f"{name}: this scene has no {slot!r} parameter (add the term to the scene)")
    lams = [ca.SX.sym(f"lam_{name}") for name in names]
    u, P, Er, _ = solver.reduced_energy  # θ_0 = θ0(P): with θ0 among the names, θ0(λ) below
    if lams:
        Er = ca.substitute(Er, P, params_at(P, lay, names, lams))
    return u, lams, P, Er


def params_at(P: ca.SX, layout, names: Sequence[str], lams: Sequence[ca.SX]) -> ca.SX:
    """The NLP parameters ``P`` with every entry each name controls set from its symbol (by √λ for
    ``h2``, every quadrature-point entry for ``alpha``)."""
    Pl = P
    for name, lam in zip(names, lams):
        slot, slot_expr = _slot(name)
        sl = layout.slices[slot]
        Pl = ca.vertcat(Pl[:sl.start], ca.repmat(slot_expr(lam), sl.stop - sl.start, 1), Pl[sl.stop:])
    return Pl


class ReducedSystem:
    """Derivatives of the reduced energy of one built solver in the parameters ``names``.

    Parameters
    ----------
    solver : EquilibriumSolver
    names : sequence of str
        Continuation parameter names; the first is the one the Newton systems solve for.

    Attributes
    ----------
    n : int
        Number of free unknowns.
    mass : ndarray, shape (n,)
        Lumped mass of the free nodes (the metric of residuals and eigenproblems).
    hessian_pattern : (rows, cols)
        Structural nonzeros of H; ``bandwidth`` = max |i − j|.
    """

    def __init__(self, solver, names: Sequence[str] = ()):
        self.solver = solver
        self.names = tuple(names)
        self.mass = np.asarray(solver.transcription.mass[1:], float).copy()
        self.n = self.mass.size
        self.u, self.lams, self.P, self.Er = substituted_energy(solver, self.names)
        self.lam = ca.vertcat(*self.lams) if self.lams else ca.SX(0, 1)
        self.g = ca.gradient(self.Er, self.u)
        self.H = ca.jacobian(self.g, self.u)
        rows, cols = self.H.sparsity().get_triplet()
        self.hessian_pattern = (np.asarray(rows, np.intp), np.asarray(cols, np.intp))
        self.bandwidth = int(np.max(np.abs(self.hessian_pattern[0] - self.hessian_pattern[1]),
                                    initial=0))

    # -- functions, built on first use ----------------------------------------------------------
    @cached_property
    def f_system(self) -> ca.Function:
        """``(u, λ (k,), P) -> (g (n,), H (n, n) dense, G_λ (n, k) dense)``."""
        return ca.Function("reduced_system", [self.u, self.lam, self.P],
                           [self.g, ca.densify(self.H), ca.densify(ca.jacobian(self.g, self.lam))])

    @cached_property
    def f_fold(self) -> ca.Function:
        """Moore–Spence: ``(u, λ (k,), v, c, P) -> (F, J, F_μ)`` with F = [g; H v; cᵀ M v − 1]
        (2n + 1,), J = ∂F/∂(u, λ_1, v) dense, F_μ = ∂F/∂(λ_2..λ_k) (2n + 1, k − 1)."""
        u, lam, n = self.u, self.lam, self.n
        v, c = ca.SX.sym("v", n), ca.SX.sym("c", n)
        Hv = ca.mtimes(self.H, v)
        cM = ca.DM(self.mass) * c
        F = ca.vertcat(self.g, Hv, ca.dot(cM, v) - 1)
        lam1 = self.lams[0]
        # J by blocks: one Jacobian of all of F would colour the dense row cᵀM against every v
        # column (n sweeps, quadratic in n: 1.6 s at n = 160); ∂(Hv)/∂u is the Hessian of v·g.
        J = ca.blockcat([
            [self.H, ca.jacobian(self.g, lam1), ca.SX(n, n)],
            [ca.hessian(ca.dot(v, self.g), u)[0], ca.jacobian(Hv, lam1), self.H],
            [ca.SX(1, n), ca.SX(1, 1), cM.T]])
        others = ca.vertcat(*self.lams[1:]) if len(self.lams) > 1 else ca.SX(0, 1)
        return ca.Function("moore_spence", [u, lam, v, c, self.P],
                           [F, ca.densify(J), ca.densify(ca.jacobian(F, others))])

    @cached_property
    def f_tip(self) -> ca.Function:
        """``(u, λ, P) -> (tip (3,) = (θ(1), x(1), y(1)), ∂tip/∂u (3, n), ∂tip/∂λ (3, k))``."""
        de, lay = self.solver.discrete, self.solver.layout
        Pl = self._substituted_params()
        z = ca.vertcat(Pl[lay.slices["theta0"]], self.u)
        tip = ca.substitute(ca.vertcat(*de.tip), ca.vertcat(de.z, de.params), ca.vertcat(z, Pl))
        return ca.Function("tip_map", [self.u, self.lam, self.P],
                           [tip, ca.densify(ca.jacobian(tip, self.u)),
                            ca.densify(ca.jacobian(tip, self.lam))])

    def _substituted_params(self):
        return params_at(self.P, self.solver.layout, self.names, self.lams)

    @cached_property
    def f_g_P(self) -> ca.Function:
        """``(u, P) -> ∂g/∂P`` (n, n_P): sensitivity of the gradient to every NLP parameter."""
        return ca.Function("g_P", [self.u, self.P], [ca.jacobian(self.g, self.P)])

    @cached_property
    def f_tip_jacobian_P(self) -> ca.Function:
        """``(u, P) -> ∂(x(1), y(1), θ(1))/∂u`` (3, n) at the NLP parameters P."""
        z = ca.vertcat(self.P[self.solver.layout.slices["theta0"]], self.u)
        tip_theta, tip_x, tip_y = self.solver.f_tip(z, self.P)
        return ca.Function("tip_jac", [self.u, self.P],
                           [ca.jacobian(ca.vertcat(tip_x, tip_y, tip_theta), self.u)])

    @cached_property
    def f_params(self) -> ca.Function:
        """``(λ (k,), P) -> P(λ)``: the NLP parameters with the entries λ controls set from it."""
        return ca.Function("params_at", [self.lam, self.P], [self._substituted_params()])

    @cached_property
    def f_g_lam(self) -> ca.Function:
        """``(u, λ, P) -> G_λ (n, k) dense`` alone (beside the solver's kernel for g and H)."""
        return ca.Function("g_lam", [self.u, self.lam, self.P], [ca.densify(ca.jacobian(self.g, self.lam))])

    def evaluator(self, P: np.ndarray):
        """An evaluator of ``(u, λ) -> (g, H, G_λ)`` at the NLP parameters ``P``: the solver's own
        kernel for g and H when it assembles a position-reading energy's dense Hessian by its
        structure (:mod:`.positional`: ~10× cheaper than :attr:`f_system` in a fitted coil field),
        else :attr:`f_system` evaluated zero-copy."""
        kernel = getattr(self.solver, "kernel", None)
        if kernel is not None and kernel.structured:
            return KernelSystemEvaluator(self, kernel, P)
        return SystemEvaluator(self.f_system, P)


class SystemEvaluator:
    """Zero-copy evaluation of ``(u, λ, P) -> (g, H, G_λ)`` into preallocated numpy arrays.

    Calling it with (u (n,), λ) returns (g (n,), H (n, n), g_λ) — g_λ has shape (n,) for one
    parameter and (n, k) for several; the arrays are overwritten by the next call.
    """

    def __init__(self, fn: ca.Function, P: np.ndarray):
        n, k = fn.size1_in(0), fn.size1_in(1)
        self.u, self.lam, self.P = np.zeros(n), np.zeros(k), np.ascontiguousarray(P, float).copy()
        self.g, self.H = np.zeros(n), np.zeros((n, n))
        gl = np.zeros((k, n))  # CasADi writes column-major: (n, k) Fortran = (k, n) C
        self.gl = gl[0] if k == 1 else gl.T
        self.buf, self.ev = fn.buffer()
        for i, a in enumerate((self.u, self.lam, self.P)):
            self.buf.set_arg(i, memoryview(a))
        for i, a in enumerate((self.g, self.H, gl)):
            self.buf.set_res(i, memoryview(a))
        self.calls = 0

    def __call__(self, u, lam):
        self.u[:] = u
        self.lam[:] = lam
        self.ev()
        self.calls += 1
        return self.g, self.H, self.gl


class KernelSystemEvaluator:
    """``(u, λ) -> (g, H, G_λ)`` like :class:`SystemEvaluator`, with g and H from the solver's
    :class:`~.kernel.FastKernel` at the parameters P(λ) and G_λ from :attr:`ReducedSystem.f_g_lam`
    (the same derivatives of the same energy; rounding aside, the same numbers)."""

    def __init__(self, system: ReducedSystem, kernel, P: np.ndarray):
        self.system, self.kernel = system, kernel
        self.P = np.ascontiguousarray(P, float).copy()
        self.k = system.lam.numel()
        self.g, self.H = np.zeros(system.n), np.zeros((system.n, system.n))
        self.gl = np.zeros(system.n) if self.k == 1 else np.zeros((system.n, self.k))
        self.calls = 0

    def __call__(self, u, lam):
        lam = np.atleast_1d(np.asarray(lam, float))
        Pl = np.asarray(self.system.f_params(lam, self.P), float).ravel()
        self.kernel.set_params(Pl)
        self.kernel.evaluate(np.asarray(u, float))
        self.g[:] = self.kernel.g
        self.H[:] = self.kernel.hessian_dense()
        gl = np.asarray(self.system.f_g_lam(u, lam, self.P), float)
        self.gl[...] = gl[:, 0] if self.k == 1 else gl
        self.calls += 1
        return self.g, self.H, self.gl


def reduced_system(solver, names: Sequence[str] = ()) -> ReducedSystem:
    """The cached :class:`ReducedSystem` of ``solver`` in ``names`` (built on first use)."""
    key = (solver.key, solver.transcription.structure(), tuple(names))
    sys_ = _CACHE.get(key)
    if sys_ is None:
        sys_ = _CACHE[key] = ReducedSystem(solver, names)
    return sys_
