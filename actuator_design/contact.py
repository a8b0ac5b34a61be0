"""Contact equilibria: the energy minimised subject to d(r(s)) ≥ gap against every obstacle.

The obstacles of a scene (:mod:`actuator_design.obstacles`) are unilateral, frictionless
constraints imposed at the transcription's quadrature points and at the tip, where the positions
r(s) are the NLP's own expressions of θ. IPOPT solves

    min Ê(θ)  s.t.  θ(0) = θ0,   d_k(r(s_j)) − gap ≥ 0   for every obstacle k and point j,

from the rest state (the straight rod, which must be free of the obstacles) with the loads applied.
What a contact equilibrium reports, beyond an ordinary one:

* the contact set: the points whose multiplier μ_j > 0 (the force μ_j ∇d_k on the rod, units of
  B0/ℓ², and per unit length μ_j/w_j at a quadrature point of weight w_j), and the weakly active
  ones (d = gap to the tolerance and μ_j = 0: strict complementarity fails there);
* stability: the inertia of the Lagrangian's reduced Hessian ∇²(Ê − Σ μ_j d_j) on the tangent space
  of the strongly active constraints (against the L² mass, as without contact, THEORY §7);
* accuracy: the moment balance of :mod:`actuator_design.balance` with the contact forces as point
  loads (the Euler–Lagrange residual including contact).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, List, Optional

import casadi as ca
import numpy as np
import scipy.linalg as sla

from .clearance import PENETRATION_TOL, constrained_points, entering
from .options import MAX_SPLITS
from .reduced.linalg import classify_spectrum

__all__ = ["solve_contact", "ContactVerdict"]

#: a multiplier above this (relative to max(1, |clamp force|)) is a contact; below it, with the
#: constraint at the gap, the contact is weak (strict complementarity fails)
ACTIVE = 1e-5
_CACHE: Dict[tuple, "ContactNLP"] = {}


@dataclass
class ContactVerdict:
    eigenvalues: np.ndarray
    morse_index: int
    stable: bool
    marginal: bool = False


class ContactNLP:
    """The contact-constrained NLP of one solver and one set of obstacles (built once)."""

    def __init__(self, solver, obstacles, gap: float):
        tr, lay = solver.transcription, solver.layout
        z = ca.SX.sym("z", tr.nodes.size)
        P = ca.SX.sym("P", lay.size)
        E = solver.f_energy(z, P)
        # one row per distinct point, none at the clamp (fixed): :mod:`.clearance`
        X, Y, self.s_points, self.w_points = constrained_points(tr, z)
        self.obstacles, self.gap = tuple(obstacles), float(gap)
        rows = [ob.distance(X, Y) - gap for ob in obstacles]
        self.n_points = X.numel()
        g = ca.vertcat(z[0] - P[lay.slices["theta0"]], *rows)
        self.f_xy = ca.Function("contact_points", [z], [X, Y])
        self.f_dist = ca.Function("contact_rows", [z], [ca.vertcat(*rows)])
        self._problem = {"x": z, "p": P, "f": E, "g": g}
        self._solvers: Dict[bool, ca.Function] = {}
        # the Lagrangian's gradient and Hessian (upper triangle) and the rows' Jacobian, as IPOPT
        # builds them: L = Ê + λᵀ g with λ_j = −μ_j ≤ 0 on the contact rows
        self.f_grad = self.f_hess = self.f_jac_g = None

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
            solver = self._solvers[warm] = ca.nlpsol("contact", "ipopt", self._problem, opts)
            if self.f_grad is None:
                self.f_grad = solver.get_function("nlp_grad")
                self.f_hess = solver.get_function("nlp_hess_l")
                self.f_jac_g = solver.get_function("nlp_jac_g")
        return self._solvers[warm]

    def lagrangian(self, z, P, lam_g):
        """(∇_z L, ∇²_z L, ∂rows/∂z) at a solution (the clamp row's multiplier included: linear)."""
        if self.f_grad is None:  # no solve yet (a rest state inside an obstacle): IPOPT builds them
            self.nlpsol(False)
        grad = np.asarray(self.f_grad(z, P, 1.0, lam_g)[2], float).ravel()
        triu = np.asarray(ca.densify(self.f_hess(z, P, 1.0, lam_g)), float)
        H = triu + triu.T - np.diag(np.diag(triu))
        jac = np.asarray(ca.densify(self.f_jac_g(z, P)[1]), float)[1:]
        return grad, H, jac


def contact_nlp(solver, scene) -> ContactNLP:
    key = (id(solver), scene.obstacles, scene.contact_gap)
    if key not in _CACHE:
        _CACHE[key] = ContactNLP(solver, scene.obstacles, scene.contact_gap)
    return _CACHE[key]


def _rest_state_problem(scene, nlp: ContactNLP, z0: np.ndarray) -> Optional[str]:
    for ob in scene.obstacles:  # a tube narrower than the rod holds no state at all
        if ob.kind == "lumen" and not ob.radius > scene.contact_gap:
            return (f"the {ob.describe()} is not wider than the rod: its radius must exceed the rod's "
                    f"half-thickness {scene.contact_gap:.4g} l")
    d = np.asarray(nlp.f_dist(z0), float).ravel()
    if np.all(d >= -1e-12):  # touching at rest (a rod lying on a floor) is free
        return None
    k, j = divmod(int(np.argmin(d)), nlp.n_points)
    return (f"the rod at rest (straight at the clamp angle) enters the {scene.obstacles[k].describe()} "
            f"at s = {nlp.s_points[j]:.4g}: contact equilibria are sought from a free rest state")


def solve_contact(scene, options, initial=None):
    """A contact equilibrium of ``scene`` (its obstacles non-empty), or a failed result saying why.

    From the straight rod (the rest state) with the loads applied, or from ``initial`` (an
    ``EquilibriumResult`` of a nearby scene, e.g. the previous state of a loading path: its shape
    interpolated onto the mesh, its contact points the first element boundaries).

    A point force inside an element kinks θ', which one polynomial cannot follow: every interior
    contact point becomes an element boundary (``SolverOptions.split_at``) at the point of the
    solved shape nearest its obstacle (so does a point where the shape enters an obstacle between
    the constrained points: a contact rolling off the tip onto the body, where the rod is nearly
    tangent to the obstacle), and the solve is repeated until those points stay put
    (at most :data:`MAX_SPLIT_ROUNDS` rounds; the residual check judges the last). The rounds are
    a fixed-point iteration s ← F(s) that converges linearly (the boundary pulls the contact point
    a fraction of the way); from the second round on (the first round's contact points standing in
    for its boundaries) the secant step on F(s) − s (:func:`_secant`) takes it there in fewer
    rounds, each a new mesh and a new NLP.

    Returns
    -------
    EquilibriumResult
        ``contact`` holds the contact set (module doc); accepted by the checks of
        :mod:`actuator_design.acceptance` like any equilibrium.
    """
    from dataclasses import replace

    from .acceptance import accept, graded_options

    t0 = time.perf_counter()
    opts = graded_options(scene, options) if options.adapt else options
    splits, rounds = tuple(opts.split_at), 0
    if initial is not None and initial.contact is not None:
        splits = tuple(initial.contact.get("split_at", splits))
    previous, result = None, None  # (splits, F(splits)) of the round before; its state
    checked = None  # (state, where it enters an obstacle or None): the dense check, made once
    while True:
        result = _solve_once(scene, replace(opts, split_at=splits), t0, initial, refine=result)
        rounds += 1
        interior = [p for p in result.contact["points"] if not p["weak"] and 0.0 < p["s"] < 1.0]
        if not result.success or rounds >= MAX_SPLIT_ROUNDS:
            break
        new = _merged(sorted(_nearest_point(scene, result, p) for p in interior))
        if len(new) > MAX_SPLITS:
            break
        if not interior or (len(new) == len(splits)
                            and np.max(np.abs(np.subtract(new, splits)), initial=0.0) <= SPLIT_TOL):
            # the contact points stay put; a shape entering an obstacle between the constrained
            # points (a contact rolling off the tip onto the body) gets a boundary there too
            inside = entering(scene.obstacles, scene.contact_gap, result)
            checked = (result, inside)
            if inside is None or not 0.0 < inside[1] < 1.0 or len(new) >= MAX_SPLITS:
                break
            rolled = {"obstacle": inside[0], "s": inside[1]}
            new = _merged(sorted(list(new) + [_nearest_point(scene, result, rolled)]))
        step = _secant(previous, splits, new)
        # the first round has no boundaries yet: its contact points (constrained points) stand in
        # for them, so that the secant step already starts from the second round
        previous = (splits if splits else _merged(sorted(p["s"] for p in interior if "multiplier" in p)), new)
        splits = step
    result.contact["split_at"] = list(result.options.split_at)
    if options.accuracy is not None:
        result.message += "; the accuracy option is not applied to contact equilibria (the residual check is)"
    inside = _penetration(scene, result, checked[1] if checked is not None and checked[0] is result else False)
    if inside is not None and result.success:
        result.success, result.status = False, "inaccurate"
        result.message += f"; {inside}: give more elements (solver.elements)"
    return accept(result)


#: IPOPT's status when its steps fell below round-off (not a failure in itself: :func:`_solve_once`)
STALLED = "Search_Direction_Becomes_Too_Small"
#: rounds of solve → move the element boundaries to the contact points → solve
MAX_SPLIT_ROUNDS = 8
#: a boundary this close (arc length) to its contact point stays: the kink it leaves is below the
#: residual check's resolution (a force F off by δs leaves a residual ~F δs)
SPLIT_TOL = 1e-8
#: contact points closer than this (rod lengths of arc) are one point: one element boundary
MERGE = 1e-6


def _secant(previous, splits: tuple, new: tuple) -> tuple:
    """The next element boundaries: the secant root of G(s) = F(s) − s through this round and the
    one before (each point on its own), where both rounds had the same points and the step lands
    within 10 |G| of F(s); F(s) itself otherwise."""
    if previous is None or not (len(previous[0]) == len(previous[1]) == len(splits) == len(new)):
        return new
    s0, f0 = (np.asarray(v, float) for v in previous)
    s1, f1 = np.asarray(splits, float), np.asarray(new, float)
    g0, g1 = f0 - s0, f1 - s1
    dg = g1 - g0
    if np.any(np.abs(dg) <= 1e-14) or np.any(s1 == s0):
        return new
    step = s1 - g1 * (s1 - s0) / dg
    if np.any(np.abs(step - f1) > 10 * np.abs(g1)) or np.any(step <= 0.0) or np.any(step >= 1.0):
        return new
    return _merged(sorted(step))


def _merged(points) -> tuple:
    """Sorted arc lengths with those closer than :data:`MERGE` merged into their mean."""
    groups = []
    for s in points:
        if groups and s - groups[-1][-1] <= MERGE:
            groups[-1].append(s)
        else:
            groups.append([s])
    return tuple(round(float(np.mean(g)), 12) for g in groups)


def _nearest_point(scene, result, point: dict) -> float:
    """The arc length of the shape's point nearest the obstacle of a contact ``point``, near it."""
    from scipy.optimize import minimize_scalar

    ob = scene.obstacles[point["obstacle"]]
    half = 0.5 / max(1, result.options.elements)
    lo, hi = max(1e-9, point["s"] - half), min(1.0 - 1e-9, point["s"] + half)
    dist = lambda s: float(np.asarray(ob.distance(*(result.evaluate(np.array([s]))[k] for k in ("x", "y"))))[0])
    return float(minimize_scalar(dist, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12}).x)


def _solve_once(scene, opts, t0: float, initial=None, refine=None):
    """One IPOPT solve of the contact NLP on the mesh of ``opts`` (not yet accepted), from the
    straight rod or from ``initial``'s shape at the mesh's nodes; a later round of the element
    boundaries from ``refine`` (the round before: its start is the one reported)."""
    from .balance import balance
    from .equilibrium import _make_result
    from .solver import RawSolution, get_solver

    solver = get_solver(scene, opts)
    nlp = contact_nlp(solver, scene)
    P = solver.parameter_vector(scene)
    z0 = np.full(solver.transcription.nodes.size, scene.theta0)
    warm = refine if refine is not None else initial
    if warm is not None:
        z0 = np.asarray(warm.evaluate(np.asarray(solver.transcription.nodes, float))["theta"], float)
        z0[0] = scene.theta0
    problem = _rest_state_problem(scene, nlp, z0) if warm is None else None
    start = "the previous state" if initial is not None else "the straight rod with the loads applied"
    if refine is not None:
        start = refine.contact["start"]
    if problem is not None:  # a rod that cannot lie straight in its lumen starts along its centre line
        shaped = _lumen_start(scene, np.asarray(solver.transcription.nodes, float))
        if shaped is not None and _rest_state_problem(scene, nlp, shaped) is None:
            z0, problem, start = shaped, None, "the rod laid along the lumen's centre line, the loads applied"
    n_rows = len(scene.obstacles) * nlp.n_points
    lbg = np.zeros(1 + n_rows)
    ubg = np.concatenate([[0.0], np.full(n_rows, np.inf)])
    if problem is not None:  # no rest state to start from: nothing is solved
        z, lam, status, iterations = z0, np.zeros(1 + n_rows), "obstacle_at_rest", 0
        message = problem
    else:
        # a state of the previous scene on its own mesh is feasible: warm; a later round's start
        # (the round before, interpolated onto new element boundaries) may enter an obstacle at a
        # new point, and a small barrier from there jumped the rod past the peg: cold
        warm_start = initial is not None and refine is None
        ipopt = nlp.nlpsol(warm_start)
        lam0 = getattr(initial, "_contact_multipliers", None) if warm_start else None
        if lam0 is not None and lam0[0] == id(nlp) and lam0[1].size == 1 + n_rows:  # the same NLP: its
            sol = ipopt(x0=z0, p=P, lbg=lbg, ubg=ubg, lam_g0=lam0[1])  # contact forces as the start
        else:
            sol = ipopt(x0=z0, p=P, lbg=lbg, ubg=ubg)
        st = ipopt.stats()
        z, lam = (np.asarray(sol[k], float).ravel() for k in ("x", "lam_g"))
        status = str(st.get("return_status"))
        iterations = int(st.get("iter_count", 0))
        message = f"IPOPT: {status} (contact, from {start})"
    converged = problem is None and status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    mu = np.maximum(-lam[1:], 0.0)
    mass = np.asarray(solver.transcription.mass, float)
    finite = bool(np.all(np.isfinite(z)) and np.all(np.isfinite(lam)))
    if finite:
        grad, H, jac = nlp.lagrangian(z, P, lam)
        finite = bool(np.all(np.isfinite(grad)) and np.all(np.isfinite(H)))
    d = np.asarray(nlp.f_dist(z), float).ravel() if finite else np.full(n_rows, np.nan)
    pressing = mu > ACTIVE * max(1.0, float(np.max(mu, initial=0.0)))
    if (status == STALLED and finite and np.min(d, initial=0.0) >= -PENETRATION_TOL
            and np.max(d[pressing], initial=0.0) <= PENETRATION_TOL):
        # IPOPT stopped at round-off (an element only ~1e-3 long beside a contact point near the
        # tip makes the system stiff): a feasible point whose forces all act at the gap
        # (complementary) is judged by the residual check, as any
        converged = True
        message += " at a feasible point: judged by the residual check"
    strong = pressing
    merged = _one_per_contact(strong, mu, nlp.s_points, len(scene.obstacles)) if finite else strong
    weak = ((~strong) & (d <= 1e-8)) | (strong & ~merged)  # a merged-away point: weakly active
    strong = merged
    if finite:
        stationarity = float(np.max(np.abs(grad.ravel()[1:] / mass[1:])))
        verdict = _verdict(H[1:, 1:], jac[strong][:, 1:], mass[1:])
    else:  # IPOPT left no usable point: no verdict
        converged, stationarity = False, float("inf")
        verdict = ContactVerdict(np.array([np.nan]), -1, False)
    raw = RawSolution(z=z, converged=converged,
                      status="converged" if converged else ("obstacle_at_rest" if problem else "not_converged"),
                      iterations=iterations, stationarity=stationarity, message=message)
    result = _make_result(scene, opts, solver, P, raw, verdict, False, [], time.perf_counter() - t0)
    result.contact = _contact_report(scene, nlp, z, mu, strong, weak)
    result.contact["start"] = start
    # a warm start's multipliers (the next state of a path), with the (cached) NLP they belong to
    result._contact_multipliers = (id(nlp), lam)
    loads = _point_loads(result.contact)
    dense = result._dense
    result._balance = lambda: balance(solver, P, dense, scene, z, point_loads=loads)
    return result


def _lumen_start(scene, s: np.ndarray) -> Optional[np.ndarray]:
    """θ at arc lengths ``s`` of the rod laid along the centre line of the first lumen holding the
    clamp (the centre line's turning from the clamp's nearest point on, added to the clamp angle),
    or None without such a lumen."""
    for ob in scene.obstacles:
        if ob.kind != "lumen" or not float(ob.distance(np.array([0.0]), np.array([0.0]))[0]) > scene.contact_gap:
            continue
        line = ob.centreline(n=4000, extend=2.0)
        u = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))]) - 2.0  # 0 at the start
        u0 = u[int(np.argmin(np.hypot(line[:, 0], line[:, 1])))]
        heading = ob.tangent_angle(u0 + s)
        return scene.theta0 + heading - heading[0]
    return None


def _penetration(scene, result, inside=False) -> Optional[str]:
    """Whether the dense shape comes closer to an obstacle than the gap between the points where
    contact is imposed (by more than :data:`~.clearance.PENETRATION_TOL` rod lengths), in words;
    ``inside``: :func:`~.clearance.entering` of ``result`` when already made (False: not yet)."""
    if inside is False:
        inside = entering(scene.obstacles, scene.contact_gap, result)
    if inside is None:
        return None
    k, s, depth = inside
    return (f"between the points where contact is imposed the rod enters the "
            f"{scene.obstacles[k].describe()} by {depth:.2g} rod lengths at s = {s:.4g}")


#: strong contacts of one obstacle closer than this (arc length, units of ℓ) are one contact: the
#: nodes of a short element beside a contact point (a contact rolling off the tip) both carried
#: a force, one of them ~1e-5 of the other, and as two constraints they kept the rod from rolling
#: on the obstacle (the lowest eigenvalue jumped from 22.8 to 57.9 where the contact left the tip)
CONTACT_WINDOW = 1e-4


def _one_per_contact(strong: np.ndarray, mu: np.ndarray, s_points: np.ndarray, n_obstacles: int) -> np.ndarray:
    """``strong`` with, among strong points of one obstacle within :data:`CONTACT_WINDOW` of each
    other, only the one of the largest multiplier kept (the others are reported weakly active)."""
    out = strong.copy()
    m = s_points.size
    for k in range(n_obstacles):
        idx = [k * m + j for j in range(m) if strong[k * m + j]]
        group: list = []
        for i in idx + [None]:
            if i is not None and group and s_points[i % m] - s_points[group[-1] % m] <= CONTACT_WINDOW:
                group.append(i)
                continue
            if len(group) > 1:
                keep = max(group, key=lambda g: mu[g])
                for g in group:
                    out[g] = g == keep
            group = [] if i is None else [i]
    return out


def _verdict(H: np.ndarray, A: np.ndarray, m: np.ndarray) -> ContactVerdict:
    """Inertia of H on the null space of the active rows A, against the mass diag(m) (module doc)."""
    Z = sla.null_space(A) if A.size else np.eye(H.shape[0])
    if Z.shape[1] == 0:
        return ContactVerdict(np.array([np.inf]), 0, True)
    Hz, Mz = Z.T @ H @ Z, Z.T @ (m[:, None] * Z)
    ev = sla.eigh(0.5 * (Hz + Hz.T), 0.5 * (Mz + Mz.T), eigvals_only=True)
    # the package's one rule (scaled by the lowest eigenvalue: the largest grows without bound on a
    # short element beside a contact near the tip, and made a stable state "marginal")
    morse, stable, marginal = classify_spectrum(ev, 1e-9)
    return ContactVerdict(ev[:6], morse, stable, marginal)


def _contact_report(scene, nlp: ContactNLP, z, mu, strong, weak) -> dict:
    X, Y = (np.asarray(v, float).ravel() for v in nlp.f_xy(z))
    points: List[dict] = []
    for k, ob in enumerate(scene.obstacles):
        sl = slice(k * nlp.n_points, (k + 1) * nlp.n_points)
        for j in np.flatnonzero(strong[sl] | weak[sl]):
            i = k * nlp.n_points + j
            nrm = ob.normal(X[j], Y[j])[:, 0]
            f = mu[i] * nrm
            w = nlp.w_points[j]
            tip = nlp.s_points[j] == 1.0  # a point force; elsewhere the force of a quadrature weight
            points.append({"obstacle": k, "s": float(nlp.s_points[j]), "x": float(X[j]), "y": float(Y[j]),
                           "force": [float(f[0]), float(f[1])], "multiplier": float(mu[i]),
                           "force_per_length": None if tip else [float(f[0] / w), float(f[1] / w)],
                           "weak": bool(weak[i])})
    total = np.sum([p["force"] for p in points], axis=0) if points else np.zeros(2)
    sc = scene.scales
    if sc is not None:  # in the scene's SI units too
        for p in points:
            p["force_N"] = [v * sc.force for v in p["force"]]
            p["force_per_length_N_per_m"] = (None if p["force_per_length"] is None else
                                             [v * sc.force / sc.length for v in p["force_per_length"]])
            p["position_m"] = [p["x"] * sc.length, p["y"] * sc.length]
    return {"points": points, "total_force": [float(total[0]), float(total[1])],
            **({"total_force_N": [float(total[0] * sc.force), float(total[1] * sc.force)]} if sc else {}),
            "obstacles": [ob.describe() for ob in scene.obstacles], "gap": scene.contact_gap,
            "weakly_active": int(sum(p["weak"] for p in points)),
            "units": {"force": "B0/l^2", "force_per_length": "B0/l^3", "position": "rod length"}}


def _point_loads(contact: dict):
    pts = contact["points"]  # weakly active points too: their (tiny) forces are part of the balance
    if not pts:
        return None
    return tuple(np.array(v) for v in zip(*[(p["s"], p["force"][0], p["force"][1], p["x"], p["y"]) for p in pts]))
