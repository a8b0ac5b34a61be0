"""The contact NLP of one mesh: the energy minimised subject to the obstacle rows d(r(s_j)) − gap ≥ 0
at the constrained points (:mod:`actuator_design.contact.clearance`) and the self-contact pair rows
(:mod:`actuator_design.contact.self_contact`), built once per solver and set of obstacles and
cached on the solver (:func:`contact_nlp`); its Hessian and Jacobian are assembled from their
parts (:mod:`actuator_design.contact.kkt`). The solves that use it:
:mod:`actuator_design.contact.equilibrium`.
"""
from __future__ import annotations

from typing import Dict

import casadi as ca
import numpy as np

from actuator_design.contact import cache as contact_cache
from actuator_design.contact.clearance import constrained_angles, constrained_points
from actuator_design.contact.kkt import Buffered, HessianCallback, RowDerivatives
from actuator_design.contact.self_contact import SLOTS, neighbour_arc

__all__ = ["ContactNLP", "contact_nlp", "corner_body"]


class ContactNLP:
    """The contact-constrained NLP of one solver and one set of obstacles (built once)."""

    def __init__(self, solver, obstacles, gap: float, slots: int = 0):
        tr, lay = solver.transcription, solver.layout
        z = ca.SX.sym("z", tr.nodes.size)
        P = ca.SX.sym("P", lay.size)
        E = solver.f_energy(z, P)
        # one row per distinct point, none at the clamp (fixed): :mod:`actuator_design.contact.clearance`
        X, Y, self.s_points, self.w_points = constrained_points(tr, z)
        self.obstacles, self.gap, self.slots = tuple(obstacles), float(gap), int(slots)
        rows = [ob.distance(X, Y) - gap for ob in obstacles]
        self.n_points = m = X.numel()
        # self-contact: ``slots`` pairs of points chosen per solve by one-hot selection parameters
        # (:mod:`actuator_design.contact.self_contact`), so that one NLP serves every pair set on this mesh; the clamp
        # (fixed at the origin) is a point the rod may press on too
        self.s_self, self.w_self = np.concatenate([[0.0], self.s_points]), np.concatenate([[0.0], self.w_points])
        Sa, Sb = ca.SX.sym("Sa", self.slots, m + 1), ca.SX.sym("Sb", self.slots, m + 1)
        # a corner pair's plane row (:func:`corner_body`): the body point's one-hot selection B and the
        # side ρ = ±1 of its tangent line the corner keeps to (ρ = 0: a point row)
        B, rho = ca.SX.sym("B", self.slots, m + 1), ca.SX.sym("rho", self.slots)
        T = constrained_angles(tr, z)
        if self.slots:
            dx, dy = ca.mtimes(Sa - Sb, ca.vertcat(0, X)), ca.mtimes(Sa - Sb, ca.vertcat(0, Y))
            th = ca.mtimes(B, ca.vertcat(z[0], T))
            point = (dx ** 2 + dy ** 2 - 4.0 * gap ** 2) / (4.0 * gap)
            plane = rho * (-dx * ca.sin(th) + dy * ca.cos(th)) - 2.0 * gap * rho ** 2
            rows.append((1.0 - rho ** 2) * point + plane)
        self.n_rows = len(self.obstacles) * m + self.slots
        self._kernel, self._n_params, self._theta0 = solver.kernel, lay.size, lay.slices["theta0"].start
        self._row_parts, self._row_derivatives = (z, X, Y, T), None
        # IPOPT's Hessian assembled from its parts (:mod:`actuator_design.contact.kkt`), except for an energy that
        # reads positions (a non-uniform field), whose own Hessian is dense and expensive to build
        # symbolically (a dipole on 12 elements: 0.8 s, ~130 MB): IPOPT then differentiates the
        # whole Lagrangian itself, as before
        self._energy_parts, self._f_energy_hessian = (z, P, E), None
        self._hess_callback = None if solver.discrete.uses_positions else HessianCallback(
            "contact_hess_lag", z.numel(), lay.size + 3 * self.slots * (m + 1) + self.slots, 1 + self.n_rows,
            self.lagrangian_hessian)
        Pall = ca.vertcat(P, ca.vec(Sa), ca.vec(Sb), ca.vec(B), rho)
        g = ca.vertcat(z[0] - P[lay.slices["theta0"]], *rows)
        self.f_xy = ca.Function("contact_points", [z], [X, Y])
        self.f_xyt = ca.Function("contact_points_angles", [z], [X, Y, T])
        self.f_dist = ca.Function("obstacle_rows", [z], [ca.vertcat(*rows[:len(self.obstacles)])])
        self.f_rows = ca.Function("contact_rows", [z, Pall], [ca.vertcat(*rows)])
        self._problem = {"x": z, "p": Pall, "f": E, "g": g}
        self._solvers: Dict[bool, ca.Function] = {}
        # the Lagrangian's gradient (:meth:`_gradient`): L = Ê + λᵀg with λ_j = −μ_j ≤ 0 on the
        # contact rows (its Hessian: :meth:`lagrangian_hessian`, :meth:`kkt`)
        self.f_grad = None

    def nlpsol(self, warm: bool) -> ca.Function:
        """IPOPT on this NLP, built on first use. Bounds are not relaxed: a contact point sits
        exactly at the gap. ``warm`` (a start that is an equilibrium of a nearby scene on this mesh,
        a contact point exactly at the gap) starts with a small barrier and does not push the start off the
        constraints: with IPOPT's defaults (barrier 0.1, slacks pushed 1e-2 inside) the first step
        lifted a tip pressed on a peg's flank off it and the rod slid past the peg, a snap reported
        long before the contact branch's fold. A cold start (the straight rod with the loads applied)
        keeps the defaults: their barrier keeps its first steps from jumping through an obstacle."""
        if warm not in self._solvers:
            opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-12,
                    "ipopt.max_iter": 500, "ipopt.mu_strategy": "adaptive", "ipopt.bound_relax_factor": 0.0}
            if warm:
                opts.update({"ipopt.mu_init": 1e-8, "ipopt.bound_push": 1e-8, "ipopt.bound_frac": 1e-8,
                             "ipopt.slack_bound_push": 1e-8, "ipopt.slack_bound_frac": 1e-8,
                             "ipopt.mu_strategy": "monotone", "ipopt.warm_start_init_point": "yes"})
            if self._hess_callback is not None:
                opts["hess_lag"] = self._hess_callback
            solver = self._solvers[warm] = ca.nlpsol("contact", "ipopt", self._problem, opts)
            built = [solver.get_function(name) for name in ("nlp_grad", "nlp_jac_g")]
            contact_cache.charge(self, built if self._hess_callback is not None
                                 else built + [solver.get_function("nlp_hess_l")])
        return self._solvers[warm]

    def _gradient(self) -> Buffered:
        """∇_z L of L = σÊ + λᵀg (arguments z, P, σ, λ_g), built on first use: Newton's rounds need
        it, and not IPOPT, whose construction (~0.1 s for a lumen) a round that Newton settles spares."""
        if self.f_grad is None:
            z, P, f, g = (self._problem[k] for k in ("x", "p", "f", "g"))
            sigma, lam = ca.SX.sym("sigma"), ca.SX.sym("lam_g", g.numel())
            grad = ca.gradient(sigma * f + ca.dot(lam, g), z)
            self.f_grad = Buffered(ca.Function("lagrangian_gradient", [z, P, sigma, lam], [grad]))
            contact_cache.charge(self, [self.f_grad.source])
        return self.f_grad

    def parameters(self, P: np.ndarray, pairs=(), planes=()) -> np.ndarray:
        """The NLP's parameters: the solver's ``P``, the one-hot selections of ``pairs`` (index
        pairs into the clamp and the constrained points, ``s_self``, at most ``slots``; the unused
        slots select nothing) and, per pair, the side ρ ∈ {−1, 0, 1} of a corner pair's plane row
        (``planes``, :func:`plane_sides`; empty or 0: a point row)."""
        shape = (self.slots, self.n_points + 1)
        Sa, Sb, B, rho = np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros(self.slots)
        for q, (a, b) in enumerate(pairs):
            Sa[q, a] = Sb[q, b] = 1.0
            side = float(planes[q]) if q < len(planes) else 0.0
            body = corner_body(a, b, self.n_points)
            if side and body is not None:
                B[q, body], rho[q] = 1.0, side
        return np.concatenate([np.asarray(P, float), Sa.ravel(order="F"), Sb.ravel(order="F"),
                               B.ravel(order="F"), rho])

    def plane_sides(self, z: np.ndarray, pairs, only=None) -> tuple:
        """Per pair, the side ρ = sign((r_a − r_b)·n(θ_body)) of the body point's tangent line the
        corner lies on in the state ``z`` (θ at the nodes), for the plane rows of a corner pair
        (:func:`corner_body`); 0 for a pair of two body points or of two corners, for a pair not in
        ``only`` (when given), and for a body point within :func:`~actuator_design.contact.self_contact.neighbour_arc`
        of an end of the rod (the tip pressing on the rod beside the clamp slips over the clamp's
        corner; a tangent line there would hold it beyond the rod's end); () when every pair gets a
        point row."""
        X, Y, T = (np.concatenate([[0.0 if k < 2 else float(z[0])], np.asarray(v, float).ravel()])
                   for k, v in enumerate(self.f_xyt(z)))
        arc = neighbour_arc(self.gap)
        out = []
        for a, b in pairs:
            body = corner_body(a, b, self.n_points) if only is None or (a, b) in only else None
            if body is not None and not arc <= self.s_self[body] <= 1.0 - arc:
                body = None  # beside an end the corner's nearest may be that end, past the tangent line
            along = (X[a] - X[b]) * -np.sin(T[body]) + (Y[a] - Y[b]) * np.cos(T[body]) if body is not None else 0.0
            out.append(float(np.sign(along)))
        return tuple(out) if any(out) else ()  # point rows only: the ramp's rows, whose multipliers carry over

    def pair_normals(self, z: np.ndarray, P: np.ndarray) -> dict:
        """Slot → the unit direction (shape (2,)) a corner pair's plane row pushes its a-end along,
        ρ n(θ_body), in the state ``z`` (θ at the nodes) with the NLP's parameters ``P``; point rows
        push along r_a − r_b and are not listed."""
        if not self.slots:
            return {}
        _, B, rho = self._pairs(np.asarray(P, float))
        th = B @ self._rows().JT0 @ np.asarray(z, float)
        return {int(q): rho[q] * np.array([-np.sin(th[q]), np.cos(th[q])]) for q in np.flatnonzero(rho)}

    def bounds(self, pairs=()):
        """(lbg, ubg): the clamp row and the contact rows (≥ 0; an unused pair slot unbounded)."""
        lbg = np.zeros(1 + self.n_rows)
        lbg[1 + self.n_rows - self.slots + len(pairs):] = -np.inf
        return lbg, np.concatenate([[0.0], np.full(self.n_rows, np.inf)])

    def raise_callback_error(self) -> None:
        """Raise what the Hessian callback raised during the last IPOPT solve, if anything."""
        if self._hess_callback is not None:
            self._hess_callback.raise_error()

    def _pairs(self, P: np.ndarray) -> tuple:
        """(Sa − Sb, B, ρ) of the self-contact pair rows from the NLP's parameters: shapes
        (slots, m + 1), (slots, m + 1), (slots,)."""
        k, shape, n = self.slots * (self.n_points + 1), (self.slots, self.n_points + 1), self._n_params
        diff = (P[n:n + k] - P[n + k:n + 2 * k]).reshape(shape, order="F")
        return diff, P[n + 2 * k:n + 3 * k].reshape(shape, order="F"), P[n + 3 * k:]

    def _rows(self) -> RowDerivatives:
        if self._row_derivatives is None:
            self._row_derivatives = RowDerivatives(*self._row_parts, self.obstacles, self.gap, self.slots)
            contact_cache.charge(self, self._row_derivatives.functions())
        return self._row_derivatives

    def lagrangian_hessian(self, z, P, sigma: float, lam_g) -> np.ndarray:
        """σ∇²Ê + ∇²(λᵀg) at ``z`` (all nodes, the clamp's included), dense, shape (n, n): IPOPT's
        ``hess_lag`` (:class:`~actuator_design.contact.kkt.HessianCallback`)."""
        z, P = np.asarray(z, float), np.asarray(P, float)
        lam = np.asarray(lam_g, float)[1:]
        H = self._rows().rows_hessian_jacobian(z, self._pairs(P), lam, jacobian=False)[0]
        if self._f_energy_hessian is None:
            z_sym, P_sym, E = self._energy_parts
            self._f_energy_hessian = Buffered(ca.Function("energy_hessian", [z_sym, P_sym],
                                                          [ca.hessian(E, z_sym)[0]]))
            contact_cache.charge(self, [self._f_energy_hessian.source])
        return H + sigma * self._f_energy_hessian(z, P[:self._n_params])[0]

    def lagrangian(self, z, P, lam_g):
        """(∇_z L, ∇²_z L, ∂rows/∂z) at a solution, as :meth:`kkt` gives them (∇²_z L without the
        energy's row and column 0: :mod:`actuator_design.contact.kkt`)."""
        return self.kkt(z, P, lam_g)[:3]

    def kkt(self, z, P, lam_g):
        """(∇_z L, ∇²_z L, ∂rows/∂z, g): :meth:`lagrangian` and the rows' values (the clamp row first)."""
        grad = self._gradient()(z, P, 1.0, lam_g)[0].ravel().copy()
        # the Hessian and the Jacobian from their parts (:mod:`actuator_design.contact.kkt`): IPOPT's own took ~1 ms
        # a call for a curved lumen
        P = np.asarray(P, float).ravel()
        H, jac, rows = self._rows().rows_hessian_jacobian(np.asarray(z, float), self._pairs(P),
                                                          np.asarray(lam_g, float)[1:])
        self._kernel.set_params(P[:self._n_params])
        self._kernel.evaluate(np.asarray(z, float)[1:])
        H[1:, 1:] += self._kernel.hessian_dense()
        return grad, H, jac, np.concatenate([[z[0] - P[self._theta0]], rows])


def contact_nlp(solver, scene, self_contact: bool = False) -> ContactNLP:
    """The contact NLP of ``solver``'s mesh for the scene's obstacles (and self-contact), kept on the
    solver: it lives as long as the solver stays in :func:`~actuator_design.equilibrium.solver.get_solver`'s cache and the
    memory budget of :mod:`actuator_design.contact.cache` keeps it."""
    slots = SLOTS if self_contact else 0
    cache = solver.__dict__.setdefault("_contact_nlps", {})
    key = (scene.obstacles, scene.contact_gap, slots)
    if key not in cache:
        cache[key] = ContactNLP(solver, scene.obstacles, scene.contact_gap, slots)
    contact_cache.keep(solver, key, cache[key])
    return cache[key]


def corner_body(a: int, b: int, m: int):
    """The body end of a corner pair (indices into the clamp, 0, and the m constrained points, the
    tip last): the tip against a body point, or the clamp against one. A corner is a point of the rod
    where it has no tangent to slide along; a pair's point row |r_a − r_b| ≥ 2·gap would let the
    corner roll round the body point into the rod's thickness beside it (the tip of a curled strip
    settled in the dip between two constrained points, 2.4e-5 inside, and the element boundaries
    chased it for 30 rounds). Its plane row keeps the corner on its side of the body point's tangent
    line, |(r_corner − r_body)·n_body| ≥ 2·gap, written ρ (r_a − r_b)·n_body ≥ 2·gap with ρ the sign
    of (r_a − r_b)·n_body in the start (:meth:`ContactNLP.plane_sides`), pushing along the body's
    normal (frictionless); where the body point is the corner's nearest (the split rounds put it
    there) the two rows agree to second order. None for a pair of two body points or of two corners."""
    if b == m and a != 0:
        return a
    if a == 0 and b != m:
        return b
    return None
