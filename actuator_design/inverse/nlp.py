"""The inverse-design NLP: equilibrium, stability and bounds as constraints on a design.

One CasADi NLP per (scene structure, design variables, fibre-series length):

    variables   x = (θ_1 … θ_n, d)         θ at the free nodes; d = (h, φ, c_0 … c_K, p, b_0 … b_K)
                                            as chosen (c: fibre layout α, b: magnetisation β)
    equilibrium ∇Ê(θ; P(d)) / m = 0         the forward transcription's stationarity (THEORY §4–5)
    stability   pivots of M^-½ H_r M^-½ − μ I ≥ 0
                                            an LDLᵀ certificate that λ_min(H_r, M) ≥ μ (THEORY §7)
    tip         tip(θ) − target ∈ [lo, hi]  free in stage A, pinned in stage B
    clearance   d_k(r(s_j)) − gap ≥ 0   at the points obstacles are imposed at (scenes with obstacles)
    bounds      0 ≤ h ≤ h_max, |α(s_q)| ≤ α_max and |β(s_q)| ≤ β_max at the quadrature points,
                |p| ≤ p_max
    objective   w_tip·½|W (tip − target)|² + w_eff·effort

Stage A (w_tip = 1, small w_eff, tip free) finds the nearest reachable pose; stage B (w_tip = 0,
w_eff = 1, tip pinned) finds the least-effort design that reaches it. The numbers (target, weights,
margin, bounds) are NLP parameters or bounds, so every multi-start and both stages share one build.
The fibre angle is a Legendre series α(s) = Σ c_k P_k(2s − 1) (a smooth few-parameter layout); so
is the remanent magnetisation angle β(s) = Σ b_k P_k(2s − 1) of a hard-magnetic rod (THEORY §9: the
shape-programming problem), with the same number of terms and the same smoothness effort.

Field scaling (THEORY §5, §9): h ∝ H, h_pos ∝ H and h_r ∝ H. The field is one physical field: the
design varies h, and every other group it drives moves with it, h_r = h·(h_r0/h0) and
h_pos = h·(h_pos0/h0) with the base scene's ratios (:mod:`actuator_design.inverse.design_map`, the
one map of every design NLP; a rod without soft coupling, h0 = 0, has no h to vary:
:func:`~actuator_design.inverse.design_map.prepare_scene` says so). The verification's loading path
ramps the field H from 0 to the design's, so all groups grow linearly along it, h = t·h_d and
h_r = t·h_r,d (:mod:`actuator_design.inverse.verify`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import EquilibriumSolver, get_solver
from actuator_design.inverse.design_map import DesignVector, certificate_matrix, coupled_scene
from actuator_design.inverse.gauge import has_fibre_gauge
from actuator_design.inverse.layout import Blocks, DesignStates, Variant, ipopt_options, outcome, profile_rows
from actuator_design.inverse.ldl import Certificate, CertificateTooLarge, check_certificate_size
from actuator_design.model.profiles import legendre_profile
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import build_terms
from actuator_design.physics.term_protocol import structure_key

__all__ = ["DESIGN_VARIABLES", "PROFILE_VARIABLES", "DesignNLP", "DesignPoint", "DesignRequest"]

#: Design variables a user may vary (the lens entries flagged designable, in registration order:
#: h, phi, alpha, p, magnetization) and what each means; a per-point entry (alpha, magnetization)
#: is designed as a profile, a Legendre series, the others are scalars written into their NLP slots.
DESIGN_VARIABLES = {n: (f"{n}(s), a Legendre series" if p.per_point else p.description) + f" ({p.unit})"
                    for n, p in lens.designable().items()}
_LENS_VARIABLES = tuple(n for n, p in lens.designable().items() if not p.per_point)
#: The designed profiles (per-point lens entries) and their bound's key in ``DesignRequest.bounds``.
PROFILE_VARIABLES = tuple(lens.designed_profiles())


def profile_bound(name: str) -> str:
    """The bound (a key of ``DesignSettings.bounds()``) of a designed profile: |profile(s)| ≤ <name>_max."""
    return f"{name}_max"

_CACHE: Dict[tuple, "DesignNLP"] = {}
#: Field group up to which stage A's effort weights apply as they are (the default h_max).
STRONG_FIELD = 10.0


def effort_scale(nlp: "DesignNLP", d0: np.ndarray) -> float:
    """The divisor of stage A's effort weights at a start ``d0``: max(1, h0/STRONG_FIELD)⁴.

    In a strong field the tip approaches its limit like 1/h (the clamp layer, THEORY §5), so
    dtip/dh ~ 1/h² and the bias of the regularised minimiser, ~ w·h³, grows with h: unscaled, the
    effort w·h² (9 at h = 300 for w = 1e-4) outweighs the tip error and drags a strong-field start
    back to h ~ 2.5. Below STRONG_FIELD the weights are unchanged.
    """
    h0 = float(np.asarray(d0)[nlp.dmap["h"]][0]) if "h" in nlp.vary else 0.0
    return max(1.0, h0 / STRONG_FIELD) ** 4
#: Stage A's effort weights w_eff (objective ½|tip − target|² + w_eff·effort): regularised, then
#: near zero from the regularised minimiser (see :meth:`DesignNLP._solve`).
STAGE_A_EFFORT = (1e-4, 1e-10)


@dataclass
class DesignPoint:
    """One local optimum of the design NLP (values of the design NLP's own state)."""

    h: float
    phi: float
    p: float
    z: np.ndarray  # θ at all nodes
    tip: np.ndarray  # (x, y, angle)
    converged: bool
    status: str
    stage: str
    #: the Legendre coefficients (rad) of each designed profile by its lens name (α(s), β(s):
    #: :data:`PROFILE_VARIABLES`); a profile not designed is absent
    profiles: Dict[str, np.ndarray] = field(default_factory=dict)

    def profile(self, name: str) -> np.ndarray:
        """The Legendre coefficients of the profile ``name`` (empty when it is not designed)."""
        return np.asarray(self.profiles.get(name, np.zeros(0)), float)

    @property
    def coefficients(self) -> np.ndarray:
        """The fibre layout α(s)'s Legendre coefficients (empty when it is not designed)."""
        return self.profile("alpha")


class DesignNLP:
    """The design NLP for one scene structure and one set of design variables.

    Parameters
    ----------
    scene : Scene
        Base scene; values not designed stay as given. Must have a uniform field to vary ``phi``
        and a tip force to vary ``p`` (:func:`~actuator_design.inverse.design_map.prepare_scene` adds one).
    vary : sequence of str
        Subset of :data:`DESIGN_VARIABLES`.
    options : SolverOptions
        Forward transcription (the design satisfies exactly its equilibrium equations).
    alpha_terms : int
        Number of Legendre coefficients of α(s) when ``"alpha"`` is varied, and of β(s) when
        ``"magnetization"`` is varied.
    clearance : float
        Extra distance (units of ℓ) beyond the contact gap kept from every obstacle.
    """

    def __init__(self, scene: Scene, vary: Sequence[str], options: SolverOptions, alpha_terms: int = 4,
                 clearance: float = 0.0):
        t0 = time.perf_counter()
        self.vary = tuple(v for v in DESIGN_VARIABLES if v in vary)
        self.profiles = tuple(v for v in self.vary if v in PROFILE_VARIABLES)
        self.alpha_terms = int(alpha_terms) if self.profiles else 0
        self.options = options
        self.solver: EquilibriumSolver = get_solver(scene, options)
        sv = self.solver
        lay = sv.layout
        tr = sv.transcription
        n = tr.nodes.size - 1
        self.n = n

        #: the design vector d: its values in design order (``dmap[name]`` their slices)
        self.dmap = DesignVector.single(self.vary, self.alpha_terms)
        d = ca.SX.sym("d", self.nd)
        P0 = ca.SX.sym("P0", lay.size)  # the base scene's parameters (numbers not designed)
        self.vandermonde = None
        if self.profiles:
            self.vandermonde = np.polynomial.legendre.legvander(2 * tr.quadrature_points - 1,
                                                                self.alpha_terms - 1)
        # a scene with obstacles: the designed rod keeps clear of them (issue 20, :mod:`actuator_design.contact.clearance`)
        self.obstacles, self.gap = tuple(scene.obstacles), float(scene.contact_gap) + float(clearance)
        states = DesignStates(sv, self.dmap, d, P0, self.vandermonde, obstacles=self.obstacles, gap=self.gap)
        zr, P, state = states.z[0], states.params[0], states.rows[0]
        H, m, tip, clear = state.hessian, state.mass, state.tip, state.clear  # tip: x, y, angle
        self.gauge = has_fibre_gauge(zr, d, P0, state.energy, self.dmap, sv.parameter_vector(scene))
        self._energy, self._effect = (zr, d, P0, state.energy), None  # ∂Ê/∂d when asked (idle_variables)

        target, weights = ca.SX.sym("target", 3), ca.SX.sym("weights", 3)
        w_tip, w_eff = ca.SX.sym("w_tip"), ca.SX.sym("w_eff")
        margin = ca.SX.sym("margin")
        effort = self.dmap.effort(d)
        err = weights * (tip - target)
        # rate of change against the previous design (field schedules through waypoints)
        d_prev, w_rate = ca.SX.sym("d_prev", self.nd), ca.SX.sym("w_rate")
        f = w_tip * 0.5 * ca.dot(err, err) + w_eff * effort + w_rate * ca.sumsqr(d - d_prev)

        # tip compliance dy(1)/dfy by the implicit function theorem: H w = −∂g/∂fy, c = ∂y(1)/∂θ · w
        # (built into the NLP only for stiffness targets; needs a tip-force term in the scene)
        self.has_fy = "fy" in lay.slices
        if self.has_fy:
            # differentiate at the actual fy in P (a designed p overwrites the base value's slot)
            fy = lay.slices["fy"]
            P_free = ca.SX.sym("P_free", lay.size)
            g_free = sv.f_grad_hess(zr, P_free)[1]
            dg_dfy = ca.substitute(ca.jacobian(g_free, P_free)[:, fy.start], P_free, P)
            w_sens = ca.SX.sym("w_sens", n)
            compliance = ca.dot(ca.gradient(tip[1], zr), w_sens)
            stiffness_target = ca.SX.sym("stiffness_target")
            sens_rows = (ca.mtimes(H, w_sens) + dg_dfy) / ca.DM(m)

        # profile bound rows: α at the quadrature points, then β (in the order of self.profiles)
        self.n_profile_rows = self.vandermonde.shape[0] if self.profiles else 0
        self._parts = dict(x=ca.vertcat(zr, d), theta=zr, d=d,
                           p=ca.vertcat(P0, target, weights, w_tip, w_eff, margin, d_prev, w_rate), f=f,
                           eq=state.eq, tip=tip - target,
                           alpha=profile_rows(self.vandermonde, self.values(d), self.profiles), clear=clear,
                           H=H, m=m, margin=margin, n=n)
        if self.has_fy:
            # stiffness k = 1/c: the constraint c·k_target − 1 = 0 (k_target an NLP parameter)
            self._parts.update(w_sens=w_sens, sens=sens_rows, stiff=compliance * stiffness_target - 1.0,
                               k_target=stiffness_target)
            self.f_sensitivity = ca.Function("sensitivity", [zr, d, P0], [H, dg_dfy, ca.gradient(tip[1], zr)])
        self._variants: Dict[tuple, Variant] = {}
        self.f_tip = ca.Function("design_tip", [zr, d, P0], [tip])
        self.build_time = time.perf_counter() - t0

    @property
    def nd(self) -> int:
        """Length of the design vector."""
        return self.dmap.size

    def nlpsol(self, certified: bool, stiffness: bool = False):
        """The NLP without (``certified=False``) or with the LDLᵀ stability certificate, and with
        the stiffness constraint when ``stiffness``; each variant is built on first use. Without the
        certificate, stability is checked at the solution (see :meth:`solve`). ``certified`` raises
        :class:`~actuator_design.inverse.ldl.CertificateTooLarge` for a dense Hessian too big to certify."""
        return self._variant(certified, stiffness).solver

    def _variant(self, certified: bool, stiffness: bool) -> Variant:
        key = (certified, stiffness)
        if key not in self._variants:
            q = self._parts
            xs, rows, p, cert, schur = Blocks(), Blocks(), q["p"], None, None
            xs.add("theta", q["theta"])
            xs.add("d", q["d"])
            rows.add("eq", q["eq"], 0.0, 0.0)
            if stiffness:
                if not self.has_fy:
                    raise ValueError("a stiffness target needs a tip-force term in the scene")
                xs.add("w_sens", q["w_sens"])
                p = ca.vertcat(p, q["k_target"])
                rows.add("sens", q["sens"], 0.0, 0.0)
                rows.add("stiff", q["stiff"], 0.0, 0.0)
            if certified:  # the pivots, and the Schur entries lifted at the element joints
                check_certificate_size(self.solver, self.n)
                cert = Certificate([certificate_matrix(q["H"], q["m"], q["margin"])])
                schur = ca.Function("schur", [q["x"], q["p"], cert.v], [cert.schur])
                xs.add("lifted", cert.v)
                rows.add("pivots", cert.pivots, 0.0, np.inf)
                rows.add("lifted", cert.rows, 0.0, 0.0)
            rows.add("tip", q["tip"])  # free in stage A, pinned in stage B (_solve_once)
            rows.add("profiles", q["alpha"])  # bounded by the request (profile_bounds)
            rows.add("clear", q["clear"], 0.0, np.inf)
            # exact Hessians, also of the pivot rows: with a quasi-Newton one the certified
            # solve wandered and its landing point (and whether it reached) depended on the
            # BLAS kernel; the iteration cap bounds the work, it is not a convergence test.
            # Starts are feasible stable equilibria: a small initial barrier keeps the
            # pivot constraints from outweighing the (small) tip objective at the start.
            opts = ipopt_options(tol=1e-10, max_iter=150 if certified else 400, acceptable_tol=1e-7,
                                 mu_init=1e-6, bound_push=1e-8, bound_frac=1e-8)
            self._variants[key] = Variant(ca.nlpsol("design", "ipopt", {"x": xs.vector(), "p": p, "f": q["f"],
                                                                        "g": rows.vector()}, opts), xs, rows, cert, schur)
        return self._variants[key]

    def state_function(self) -> ca.Function:
        """One state of this NLP, for NLPs that carry many (:mod:`actuator_design.schedules.schedule_ocp_nlp`):
        ``(θ (n,), d (nd,), P0) -> (g/m (n,), M^-1/2 H M^-1/2 (n, n))``, the mass-scaled
        stationarity rows and reduced Hessian (the certificate's matrix before the margin)."""
        q = self._parts
        return ca.Function("design_state", [q["x"][:self.n], q["x"][self.n:], q["p"][:self.solver.layout.size]],
                           [q["eq"], certificate_matrix(q["H"], q["m"])])

    def idle_variables(self, P_scene: np.ndarray, trials: int = 3) -> List[str]:
        """The design variables the rod's energy does not depend on, whatever the state and the other
        designed values, at the scene's parameters ``P_scene`` (∂Ê/∂d_v = 0 at ``trials`` random
        states and designs; e.g. a field angle or a fibre layout at zero field): they would have no
        physical effect on the actuator."""
        if self._effect is None:  # built on first use, then kept
            zr, d, P0, E = self._energy
            self._effect = ca.Function("design_effect", [zr, d, P0], [ca.gradient(E, d)])
        f = self._effect
        rng = np.random.default_rng(20261207)  # fixed seed: the same verdict on every run
        moved = np.zeros(self.nd)
        for _ in range(trials):
            g = np.abs(np.asarray(f(rng.uniform(-1.0, 1.0, self.n), rng.uniform(0.2, 1.5, self.nd), P_scene),
                                  float).ravel())
            moved = np.maximum(moved, g / (1.0 + float(np.max(g, initial=0.0))))
        return [v for v in self.vary if not np.max(moved[self.dmap[v]]) > 1e-12]

    # -- helpers --------------------------------------------------------------------------------
    def design_vector(self, h=None, phi=None, coefficients=None, p=None, profiles=None) -> np.ndarray:
        """The design vector, shape (nd,), from the design values (``profiles``: each designed
        profile's Legendre coefficients by lens name, ``coefficients`` α's alone; missing trailing
        coefficients are 0)."""
        d = np.zeros(self.nd)
        for name, val in (("h", h), ("phi", phi), ("p", p)):
            if name in self.vary:
                d[self.dmap[name]] = val
        given = dict(profiles or {})
        if coefficients is not None:
            given["alpha"] = coefficients
        for name in self.profiles:
            c = np.zeros(self.alpha_terms)
            if given.get(name) is not None:
                cc = np.asarray(given[name], float).ravel()[: self.alpha_terms]
                c[: cc.size] = cc
            d[self.dmap[name]] = c
        return d

    def point_vector(self, pt: "DesignPoint", phi=None) -> np.ndarray:
        """The design vector of a design point (its φ replaced by ``phi`` when given)."""
        return self.design_vector(h=pt.h, phi=pt.phi if phi is None else phi, p=pt.p, profiles=pt.profiles)

    def point(self, d: np.ndarray, base: Scene, z: np.ndarray, tip: np.ndarray, *, converged: bool,
              status: str, stage: str) -> DesignPoint:
        """The :class:`DesignPoint` of a design vector ``d`` (shape (nd,)); a value not designed is
        ``base``'s, a profile not designed is empty. ``z``: θ at all nodes; ``tip``: (x, y, angle)."""
        def scalar(name, default):
            return float(d[self.dmap[name]][0]) if name in self.vary else default

        return DesignPoint(h=scalar("h", base.h), phi=scalar("phi", base.phi), p=scalar("p", base.p), z=z, tip=tip,
                           converged=converged, status=status, stage=stage,
                           profiles={v: np.asarray(d[self.dmap[v]], float) for v in self.profiles})

    def fix_gauge(self, d: np.ndarray) -> np.ndarray:
        """The design vector moved along the gauge orbit to α's mean c_0 = 0 (φ − c_0, α − c_0: the
        same equilibrium, see :func:`has_fibre_gauge`); ``d`` itself when the scene has no gauge."""
        return self.dmap.fix_gauge(d) if self.gauge else np.array(d, float)

    def values(self, d) -> Dict[str, object]:
        """The design vector's values by name, in design order (scalars shape (1,), profiles their
        Legendre coefficients): what :func:`~actuator_design.inverse.design_map.design_params` writes."""
        return self.dmap.values(d)

    def variable_bounds(self, bounds: Dict[str, float]) -> Tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the design vector, shape (nd,) each: the scalars'
        (:func:`~actuator_design.inverse.design_map.scalar_bounds`); profiles are bounded by rows."""
        return self.dmap.bounds(bounds)

    def profile_bounds(self, bounds: Dict[str, float]) -> Tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the profile rows (|α(s_q)| ≤ α_max, |β(s_q)| ≤ β_max)."""
        lim = np.concatenate([np.full(self.n_profile_rows, bounds.get(profile_bound(v), np.inf))
                              for v in self.profiles] or [np.zeros(0)])
        return -lim, lim

    def scene_for(self, base: Scene, d: np.ndarray) -> Scene:
        """The forward scene of a design vector (fibres and magnetisation as exact Legendre
        profiles; h_r and h_pos moved with h, see the module docstring)."""
        sc = base
        for v in self.vary:  # h, phi, p written through the parameter lens
            if v in _LENS_VARIABLES:
                sc = lens.parameter(v).write(sc, float(d[self.dmap[v]][0]))
        if "h" in self.vary:
            sc = coupled_scene(base, sc)
        for v in self.profiles:  # α(s), β(s) as their exact Legendre series
            sc = lens.parameter(v).with_profile(sc, legendre_profile(d[self.dmap[v]]))
        return sc

    def solve(self, base: Scene, x0_theta: np.ndarray, d0: np.ndarray, req: "DesignRequest",
              certify: bool = True) -> DesignPoint:
        """Solve one stage of a design request from a start (θ at the nodes, design vector).

        The NLP without the stability certificate is tried first; when its solution violates
        λ_min(H_r, M) ≥ margin, the certified NLP (LDLᵀ pivots ≥ 0) is solved from the same start —
        unless ``certify`` is False, in which case the uncertified point is returned with
        ``certified = False`` (a probe: the constrained optimum is never closer to the target). A
        certificate too big to build (a dense Hessian) gives a point not converged whose status
        says so (:class:`~actuator_design.inverse.ldl.CertificateTooLarge`).
        """
        pt = self._solve(base, x0_theta, d0, req, certified=False)
        if pt.converged:
            P = self.solver.parameter_vector(self.scene_for(base, self._dvec(pt)))
            lam = self.solver.stability(pt.z, P).eigenvalues[0]
            if lam >= req.margin * (1 - 1e-9):
                return pt
        if not certify:
            pt.certified = False
            pt.start = (np.asarray(x0_theta, float), np.asarray(d0, float))
            return pt
        return self._solve(base, x0_theta, d0, req, certified=True)

    def stiffness(self, base: Scene, pt: "DesignPoint") -> float:
        """Tip stiffness dp/dv1 of the design NLP's state (units of B0/ℓ³), from the reduced Hessian:
        dθ/dfy = −H⁻¹ ∂g/∂fy, compliance = ∂y(1)/∂θ · dθ/dfy (used to rank optima; the design is
        judged by finite differences of independent forward solves)."""
        H, b, gy = (np.asarray(v, float) for v in self.f_sensitivity(pt.z[1:], self._dvec(pt),
                                                                      self.solver.parameter_vector(base)))
        try:
            compliance = float(gy.ravel() @ np.linalg.solve(H, -b.ravel()))
        except np.linalg.LinAlgError:
            return float("nan")  # singular reduced Hessian: a fold, no finite stiffness
        return 1.0 / compliance if compliance != 0.0 else float("inf")

    def _dvec(self, pt: DesignPoint) -> np.ndarray:
        return self.point_vector(pt)

    def _solve(self, base, x0_theta, d0, req: "DesignRequest", certified: bool) -> DesignPoint:
        """One stage from a start. Stage A is solved twice: first with a regularising effort
        weight (:data:`STAGE_A_EFFORT`), whose minimiser is isolated, then with the near-zero one
        from there. With the near-zero weight alone every design that reaches the target is a
        minimiser and IPOPT stops anywhere in that valley once its gradient (~1e-10) is below the
        tolerance: where, and hence the design stage B refines, was decided by round-off (target
        (0.7, 0.5): h = 3.09 with one BLAS kernel, 4.17 with another). If the regularised solve
        does not converge, the plain one is tried from the original start."""
        if req.stage != "A":
            return self._solve_once(base, x0_theta, d0, req, certified, w_eff=1.0)
        scale = effort_scale(self, d0)
        reg = self._solve_once(base, x0_theta, d0, req, certified, w_eff=STAGE_A_EFFORT[0] / scale)
        if reg.converged:
            x0_theta, d0 = reg.z, self._dvec(reg)
        return self._solve_once(base, x0_theta, d0, req, certified, w_eff=STAGE_A_EFFORT[1] / scale)

    def _solve_once(self, base, x0_theta, d0, req: "DesignRequest", certified: bool,
                    w_eff: float) -> DesignPoint:
        sv = self.solver
        P0 = sv.parameter_vector(base)
        if certified:
            try:
                check_certificate_size(sv, self.n)
            except CertificateTooLarge as err:  # not a solve: the start, marked as not converged
                tip = np.asarray(self.f_tip(np.asarray(x0_theta, float)[1:], d0, P0), float).ravel()
                return self.point(np.asarray(d0, float), base, np.asarray(x0_theta, float), tip, converged=False,
                                  status=str(err), stage=req.stage + "+certificate")
        use_angle = req.target is not None and len(req.target) > 2
        tgt = np.zeros(3) if req.target is None else np.array(
            [req.target[0], req.target[1], req.target[2] if use_angle else 0.0])
        weights = np.array([1.0, 1.0, 1.0 if use_angle else 0.0])
        w_tip = 1.0 if req.stage == "A" else 0.0
        d_prev = np.zeros(self.nd) if req.d_prev is None else np.asarray(req.d_prev, float)
        p = np.concatenate([P0, tgt, weights, [w_tip, w_eff, req.margin], d_prev, [req.w_rate]])
        stiff = req.stiffness is not None
        if stiff:
            p = np.concatenate([p, [req.stiffness]])

        nlp, xs, rows, cert, schur = self._variant(certified, stiff)
        b = req.bounds
        lbx, ubx = xs.bounds(d=self.variable_bounds(b))
        lbg, ubg = rows.bounds(profiles=self.profile_bounds(b))
        if req.stage == "B" and req.target is not None:
            k = rows["tip"].start
            lbg[k:k + 2] = ubg[k:k + 2] = 0.0
            if use_angle:
                lbg[k + 2] = ubg[k + 2] = 0.0
        if self.gauge:  # α's mean is pinned at 0 (fix_gauge): a unique optimum, not a flat valley
            d0 = self.fix_gauge(d0)
            i = xs["d"].start + self.dmap["alpha"].start
            lbx[i] = ubx[i] = 0.0
        x0 = np.concatenate([np.asarray(x0_theta, float)[1:], d0] + ([np.zeros(self.n)] if stiff else []))
        if cert is not None and cert.m:
            x0 = np.concatenate([x0, cert.start(schur, x0[:self.n + self.nd], p[:self._parts["p"].numel()])])
        sol = nlp(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        converged, status = outcome(nlp)
        x = np.asarray(sol["x"], float).ravel()
        zr, d = x[: self.n], x[self.n:self.n + self.nd]
        theta0 = P0[sv.layout.slices["theta0"]][0]
        tip = np.asarray(self.f_tip(zr, d, P0), float).ravel()
        return self.point(d, base, np.concatenate([[theta0], zr]), tip, converged=converged,
                          status=status, stage=req.stage + ("+certificate" if certified else ""))


@dataclass
class DesignRequest:
    """What one design-NLP solve asks for.

    target : (x, y) or (x, y, angle) or None (no pose target, e.g. stiffness only)
    stage : "A" (nearest pose: least squares) or "B" (least effort with the target pinned)
    margin : stability margin μ (λ_min(H_r, M) ≥ μ)
    bounds : h_max, p_max, alpha_max, magnetization_max (|β(s)| bound, rad)
    d_prev, w_rate : previous design and weight of the rate term w_rate·|d − d_prev|²
    stiffness : target tip stiffness dp/dv1 (units of B0/ℓ³), or None
    """

    target: Optional[Tuple[float, ...]]
    stage: str
    margin: float
    bounds: Dict[str, float]
    d_prev: Optional[np.ndarray] = None
    w_rate: float = 0.0
    stiffness: Optional[float] = None


def refuse_idle(scene: Scene, vary: Sequence[str], options: SolverOptions, alpha_terms: int,
                clearance: float = 0.0) -> None:
    """ValueError naming each variable of ``vary`` that would have no physical effect on ``scene``'s
    actuator (:meth:`DesignNLP.idle_variables`), and what to do instead; ``scene`` is prepared for
    ``vary`` (:func:`~actuator_design.inverse.design_map.prepare_scene`)."""
    nlp = get_design_nlp(scene, vary, options, alpha_terms, clearance)
    idle = nlp.idle_variables(nlp.solver.parameter_vector(scene))
    if idle:
        zero = not any(abs(q.get(scene)) > 0 for q, _ in lens.field_groups())
        raise ValueError(f"--vary {','.join(idle)}: no effect on this actuator (its energy does not depend on "
                         f"{'it' if len(idle) == 1 else 'them'} at the scene's values"
                         + ("; the scene's field is 0: vary h as well, or give the field's magnitude "
                            "(--set h=VALUE or the scene's field))" if zero else ")"))


def get_design_nlp(scene: Scene, vary: Sequence[str], options: SolverOptions, alpha_terms: int,
                   clearance: float = 0.0) -> DesignNLP:
    """A cached :class:`DesignNLP` (built once per structure, variables and series length)."""
    obstacles = (tuple(scene.obstacles), float(scene.contact_gap), float(clearance)) if scene.obstacles else ()
    key = (structure_key(build_terms(scene)), obstacles, tuple(sorted(vary)), options.transcription, options.elements,
           options.degree, options.clamp_levels, options.tip_levels, options.split_at, options.tol, options.max_iter,
           alpha_terms if any(v in PROFILE_VARIABLES for v in vary) else 0)
    if key not in _CACHE:
        _CACHE[key] = DesignNLP(scene, vary, options, alpha_terms, clearance if scene.obstacles else 0.0)
    return _CACHE[key]
