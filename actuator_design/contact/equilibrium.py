"""Contact equilibria: the energy minimised subject to d(r(s)) ≥ gap against every obstacle.

The obstacles of a scene (:mod:`actuator_design.contact.obstacles`) are unilateral, frictionless
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
* accuracy: the moment balance of :mod:`actuator_design.equilibrium.balance` with the contact forces as point
  loads (the Euler–Lagrange residual including contact).
"""
from __future__ import annotations

import time
import weakref
from dataclasses import replace
from typing import Optional

import numpy as np

from actuator_design.contact.clearance import PENETRATION_TOL, entering
from actuator_design.contact.contact_nlp import ContactNLP, contact_nlp
from actuator_design.contact.nearest import nearest_pair, nearest_point
from actuator_design.contact.newton import (kept_clear, newton_on_contact_set, nothing_pressed, pressing_rows,
                                            strict_minimum)
from actuator_design.contact.report import (ACTIVE, ContactVerdict, contact_report, one_per_contact,
                                            penetration_text, point_loads, verdict)
from actuator_design.contact.self_contact import (GROW_ROUNDS, SELF_MAX_NODES, boundary_pairs, candidate_pairs,
                                                  grown_pairs, self_contact_mesh, self_penetration, tangential_force)
from actuator_design.contact.split import MAX_SPLIT_ROUNDS, MERGE, SPLIT_TOL, accelerated, extended, merged
from actuator_design.continuation.from_rest import load_fraction
from actuator_design.equilibrium.acceptance import accept, graded_options, moment_scale, residual_limit
from actuator_design.equilibrium.dense_shape import Balance
from actuator_design.equilibrium.options import MAX_SPLITS
from actuator_design.equilibrium.single import make_result
from actuator_design.equilibrium.solver import STALLED, RawSolution, get_solver

__all__ = ["mesh_limited", "solve_contact", "solve_once", "contact_nlp", "ContactVerdict"]


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


def solve_contact(scene, options, initial=None, self_contact: bool = False, start: Optional[str] = None,
                  first=None):
    """A contact equilibrium of ``scene`` (its obstacles, and with ``self_contact`` the rod against
    itself), or a failed result saying why.

    From the straight rod (the rest state) with the loads applied, or from ``initial`` (an
    ``EquilibriumResult`` of a nearby scene, e.g. the previous state of a loading path: its shape
    interpolated onto the mesh, its contact points the first element boundaries; a self-contact
    state keeps self-contact on; ``start`` names it in the message).

    A point force inside an element kinks θ', which one polynomial cannot follow: every interior
    contact point becomes an element boundary (``SolverOptions.split_at``) at the point of the
    solved shape nearest its obstacle (at both points of a self-contact), and so does a point where
    the shape enters an obstacle (or itself) between the constrained points: a contact rolling off
    the tip onto the body, where the rod is nearly tangent to the obstacle. The solve is repeated
    until those points stay put (at most :data:`~actuator_design.contact.split.MAX_SPLIT_ROUNDS` rounds; the
    residual check judges the last), from the second round on with Anderson's mixing
    (:func:`~actuator_design.contact.split.accelerated`), each round a new mesh and a new NLP.
    ``first``: a contact solve of ``scene`` itself (all loads) on the mesh of the first round, from
    ``initial`` (the last step of a ramp from rest to full load): it is the first round (solving
    it again would give it once more).

    Returns
    -------
    EquilibriumResult
        ``contact`` holds the contact set (:mod:`actuator_design.contact.report`); accepted by the checks of
        :mod:`actuator_design.equilibrium.acceptance` like any equilibrium.
    """
    t0 = time.perf_counter()
    self_contact = self_contact or bool(initial is not None and (initial.contact or {}).get("self_contact"))
    options = self_contact_mesh(scene, options) if self_contact else options
    opts = graded_options(scene, options) if options.adapt else options
    splits, rounds = tuple(opts.split_at), 0
    if initial is not None and initial.contact is not None:
        splits = tuple(initial.contact.get("split_at", splits))
    history, result = [], None  # (splits, F(splits)) of the rounds with the same points; the state
    checked = None  # (state, where it enters an obstacle, where itself): the dense checks, made once
    while True:
        if rounds == 0 and first is not None and first.options == replace(opts, split_at=splits):
            result = first  # its message and contact report name the start of the whole solve
            result.message = result.message.replace(f"(contact, from {first.contact['start']})",
                                                    f"(contact, from {start})")
            result.contact["start"] = start
        else:
            result = solve_once(scene, replace(opts, split_at=splits), t0, initial, refine=result,
                                self_contact=self_contact, start=start, planes=True)
        rounds += 1
        strong = [p for p in result.contact["points"] if not p["weak"]]
        interior = [p for p in strong if 0.0 < p["s"] < 1.0]
        if not result.success or rounds >= MAX_SPLIT_ROUNDS:
            break
        new = merged(sorted(_boundaries(scene, result, strong)))
        if len(new) > MAX_SPLITS:
            break
        if not interior or (len(new) == len(splits)
                            and np.max(np.abs(np.subtract(new, splits)), initial=0.0) <= SPLIT_TOL):
            # the contact points stay put; a shape entering an obstacle (or itself) between the
            # constrained points (a contact rolling off the tip onto the body) gets boundaries there
            checked = (result,) + _dense_checks(scene, result, self_contact)
            extra = _entry_boundaries(scene, result, *checked[1:])
            if not extra or len(new) >= MAX_SPLITS:
                break
            new = merged(sorted(list(new) + extra))
        # the first round has no boundaries yet: its contact points (constrained points) stand in
        # for them, so that the acceleration already starts from the second round
        here = (splits if splits else merged(sorted(p["s"] for p in interior)), new)
        history = extended(history, here)
        splits = accelerated(history)
    result.contact["split_at"] = list(result.options.split_at)
    result.contact["boundary_rounds"] = rounds
    if options.accuracy is not None:
        result.message += "; the accuracy option is not applied to contact equilibria (the residual check is)"
    if checked is None or checked[0] is not result:
        checked = (result,) + _dense_checks(scene, result, self_contact)
    inside = penetration_text(scene, *checked[1:])
    result.contact["entering"] = inside
    if inside is not None and result.success:
        result.success, result.status = False, "inaccurate"
        if rounds >= MAX_SPLIT_ROUNDS:
            result.message += (f"; {inside}: the contact points were still moving after {rounds} boundary "
                               "rounds (the element boundaries chase a contact that slides, e.g. a tip along "
                               "the rod's body)")
        else:
            result.message += f"; {inside}: give more elements (solver.elements)"
    if self_contact and result.success:
        _check_frictionless(result)
    return accept(result)


def mesh_limited(result) -> bool:
    """Whether a contact result misses only the residual check, which a finer mesh meets
    (:func:`~actuator_design.equilibrium.acceptance.refined`): it converged, its shape enters no
    obstacle and not itself, its boundary rounds settled, and no self-contact carries a tangential
    force; not a result cut short by its rounds (a contact that slides) or one the mesh cannot hold."""
    c = result.contact or {}
    if not (result.success or result.status == "inaccurate") or c.get("entering") is not None:
        return False
    if c.get("boundary_rounds", 0) >= MAX_SPLIT_ROUNDS:
        return False
    opts = result.options
    if c.get("self_contact") and opts.degree * (2 * opts.elements + opts.extra_elements) > SELF_MAX_NODES:
        return False  # a self-contact NLP's Hessian is dense: its mesh stays within the node cap
    return c.get("tangential_force", 0.0) <= residual_limit(result.options) * moment_scale(result)


def _check_frictionless(result) -> None:
    """A self-contact whose rows push off the turns' common normal (its points not yet the nearest
    points of the two turns when the split rounds stopped) carries a tangential force; above the
    residual check's limit (relative to the moment scale) the result is inaccurate, in place."""
    worst = tangential_force(result)
    if worst is None:
        return
    f, a, b = worst
    limit = residual_limit(result.options) * moment_scale(result)
    result.contact["tangential_force"] = f
    if f > limit:
        result.success, result.status = False, "inaccurate"
        result.message += (f"; the self-contact at s = {a:.4g} against s = {b:.4g} is not yet at the nearest "
                           f"points of the two turns: a tangential force {f:.2e} > {limit:.1e} (B0/l^2) that a "
                           "frictionless contact cannot carry; try another mesh (solver.elements)")


def _boundaries(scene, result, strong) -> list:
    """Element boundaries in (0, 1) at the contact points of ``strong`` (a self-contact's pair once)."""
    half = 0.5 / max(1, result.options.elements)
    out = []
    for p in strong:
        if p.get("self"):
            if p["s"] < p["partner_s"]:
                out += [v for v in nearest_pair(result, p["s"], p["partner_s"], half) if MERGE < v < 1.0]
        elif 0.0 < p["s"] < 1.0:
            out.append(nearest_point(scene, result, p))
    return out


def _dense_checks(scene, result, self_contact: bool) -> tuple:
    """(where the dense shape enters an obstacle, where it enters itself): each None when it does not."""
    inside = entering(scene.obstacles, scene.contact_gap, result) if scene.obstacles else None
    return inside, (self_penetration(result, scene.contact_gap) if self_contact else None)


def _entry_boundaries(scene, result, inside, self_inside) -> list:
    out = []
    if inside is not None and 0.0 < inside[1] < 1.0:
        out.append(nearest_point(scene, result, {"obstacle": inside[0], "s": inside[1]}, local=False))
    if self_inside is not None:
        half = 0.5 / max(1, result.options.elements)
        out += [v for v in nearest_pair(result, self_inside[0], self_inside[1], half) if MERGE < v < 1.0]
    return out


def solve_once(scene, opts, t0: float, initial=None, refine=None, fraction: float = 1.0,
               self_contact: bool = False, spread: int = 1, cold: bool = False, start: Optional[str] = None,
               theta_start: Optional[np.ndarray] = None, planes: bool = False):
    """One IPOPT solve of the contact NLP on the mesh of ``opts`` (not yet accepted), from the
    straight rod or from ``initial``'s shape at the mesh's nodes; a later round of the element
    boundaries from ``refine`` (the round before: its start is the one reported). ``fraction``
    scales every load and field (a ramp from rest); ``self_contact`` adds the rows of the pairs of
    points near each other in the start (:func:`~actuator_design.contact.self_contact.candidate_pairs`, with ``spread``);
    ``cold``: IPOPT's default barrier from any start (a start that violates a newly chosen pair);
    ``theta_start``: θ at the mesh's nodes (rad) of a free equilibrium of a nearby scene, a warm start
    like ``initial``; ``planes``: a corner pair (the tip or the clamp against a body point) whose
    body point is an element boundary put at the corner's nearest point (by the round before, or
    by ``initial``'s contact solve: a step of a path) keeps the corner on its side of the body
    point's tangent line instead of a point's distance
    (:func:`~actuator_design.contact.contact_nlp.corner_body`; :func:`solve_contact`'s rounds)."""
    solver = get_solver(scene, opts)
    nlp = contact_nlp(solver, scene, self_contact)
    P = solver.parameter_vector(scene)
    if fraction != 1.0:
        P = load_fraction(solver, P, fraction)
    z0 = np.full(solver.transcription.nodes.size, scene.theta0)
    warm = refine if refine is not None else initial
    if warm is not None:
        z0 = np.asarray(warm.evaluate(np.asarray(solver.transcription.nodes, float))["theta"], float)
        z0[0] = scene.theta0
    elif theta_start is not None:
        z0 = np.array(theta_start, float)
        z0[0] = scene.theta0
    given = initial is not None or theta_start is not None
    problem = _rest_state_problem(scene, nlp, z0) if warm is None and theta_start is None else None
    start = (start or "the previous state") if given else "the straight rod with the loads applied"
    if refine is not None:
        start = refine.contact["start"]
    if problem is not None:  # a rod that cannot lie straight in its lumen starts along its centre line
        shaped = _lumen_start(scene, np.asarray(solver.transcription.nodes, float))
        if shaped is not None and _rest_state_problem(scene, nlp, shaped) is None:
            z0, problem, start = shaped, None, "the rod laid along the lumen's centre line, the loads applied"
    pairs, kept = (), []
    if nlp.slots:
        X0, Y0 = (np.concatenate([[0.0], np.asarray(v, float).ravel()]) for v in nlp.f_xy(z0))
        pairs = candidate_pairs(nlp.s_self, X0, Y0, scene.contact_gap, slots=nlp.slots, spread=spread)
        kept = boundary_pairs(nlp.s_self, opts.split_at, refine if refine is not None else initial)
        pairs = tuple((kept + [q for q in pairs if q not in kept])[:nlp.slots])
    # a corner pair's plane row where the body point is an element boundary put at the corner's
    # nearest point in the round before (a pair chosen afresh may have the corner beyond the body's end)
    signs = nlp.plane_sides(z0, pairs, only=kept) if planes and kept else ()
    Pall = nlp.parameters(P, pairs, signs)
    lbg, ubg = nlp.bounds(pairs)
    used = np.isfinite(lbg[1:])
    mass = np.asarray(solver.transcription.mass, float)
    newton = minimum = None
    if problem is not None:  # no rest state to start from: nothing is solved
        z, lam, status, iterations = z0, np.zeros(1 + nlp.n_rows), "obstacle_at_rest", 0
        message = problem
    else:
        # a state of the previous scene on its own mesh is feasible: warm; a later round's start
        # (the round before, interpolated onto new element boundaries) may enter an obstacle at a
        # new point, and a small barrier from there jumped the rod past the peg: cold
        warm_start = not cold and ((given and refine is None) or (self_contact and warm is not None))
        lam0 = getattr(initial, "_contact_multipliers", None) if warm_start else None
        same = lam0 is not None and lam0[0]() is nlp and lam0[1] == pairs and lam0[3] == signs  # the same rows
        # a split round's pairs start with the round before's self-contacts, now element boundaries
        at_boundaries = tuple(1 + len(scene.obstacles) * nlp.n_points + q for q in range(len(kept)))
        before = lam0[2] if same else None
        if before is None and refine is None and not cold and self_contact and (
                (lam0 is not None and lam0[0]() is nlp and nothing_pressed(lam0[2]))
                or (lam0 is None and theta_start is not None and initial is None)):
            # a ramp step from a state pressing nowhere (or the lead-in's contact-free state), its
            # pairs chosen afresh: none guessed to press
            before = np.zeros(1 + nlp.n_rows)
        rows = pressing_rows(nlp, before, None if cold else refine, opts.split_at, at_boundaries)
        newton = None if rows is None else newton_on_contact_set(nlp, z0, Pall, lbg, rows, mass, opts.tol)
        if newton is not None and kept_clear(nlp, z0, Pall, newton):
            minimum = strict_minimum(nlp, newton, mass)
        if minimum is None:
            newton = None  # a jump past an obstacle, or a saddle (past a fold): IPOPT decides
        if newton is not None:  # the contact set of the step or round before still holds
            z, lam, iterations, derivatives = newton
            status = "Solve_Succeeded"
            message = f"Newton on the contact set of the {'round' if refine is not None else 'state'} before (contact, from {start})"
        else:
            iterations, ipopt = 0, nlp.nlpsol(warm_start)
            for attempt in range(GROW_ROUNDS + 1):
                if same:  # its contact forces as the start
                    sol = ipopt(x0=z0, p=Pall, lbg=lbg, ubg=ubg, lam_g0=lam0[2])
                else:
                    sol = ipopt(x0=z0, p=Pall, lbg=lbg, ubg=ubg)
                nlp.raise_callback_error()
                iterations += int(ipopt.stats().get("iter_count", 0))
                z, lam = (np.asarray(sol[k], float).ravel() for k in ("x", "lam_g"))
                grow = nlp.slots and refine is not None and attempt < GROW_ROUNDS
                grown = grown_pairs(nlp, scene.contact_gap, z, pairs) if grow else None
                if grown is None:
                    break
                # a split round (the same loads, the boundaries moved) passed the rod through itself
                # where no pair held it: those pairs are constrained too, and it is solved again from
                # the same start (a ramp step that does so is halved instead: :mod:`actuator_design.contact.self_contact`)
                pairs, same = grown, False
                signs = nlp.plane_sides(z0, pairs, only=kept) if planes and kept else ()
                Pall = nlp.parameters(P, pairs, signs)
                lbg, ubg = nlp.bounds(pairs)
                used = np.isfinite(lbg[1:])
            status = str(ipopt.stats().get("return_status"))
            message = f"IPOPT: {status} (contact, from {start})"
    converged = problem is None and status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    mu = np.where(used, np.maximum(-lam[1:], 0.0), 0.0)
    finite = bool(np.all(np.isfinite(z)) and np.all(np.isfinite(lam)))
    if finite:
        grad, H, jac = derivatives if newton is not None else nlp.lagrangian(z, Pall, lam)
        finite = bool(np.all(np.isfinite(grad)) and np.all(np.isfinite(H)))
    d = np.asarray(nlp.f_rows(z, Pall), float).ravel() if finite else np.full(nlp.n_rows, np.nan)
    d[~used] = np.inf
    pressing = mu > ACTIVE * max(1.0, float(np.max(mu, initial=0.0)))
    if (status == STALLED and finite and np.min(d, initial=0.0) >= -PENETRATION_TOL
            and np.max(d[pressing], initial=0.0) <= PENETRATION_TOL):
        # IPOPT stopped at round-off (an element only ~1e-3 long beside a contact point near the
        # tip makes the system stiff): a feasible point whose forces all act at the gap
        # (complementary) is judged by the residual check, as any
        converged = True
        message += " at a feasible point: judged by the residual check"
    strong = pressing
    kept = one_per_contact(strong, mu, nlp.s_points, len(scene.obstacles), pairs) if finite else strong
    weak = ((~strong) & (d <= 1e-8)) | (strong & ~kept)  # a merged-away point: weakly active
    strong = kept
    if finite:
        stationarity = float(np.max(np.abs(grad.ravel()[1:] / mass[1:])))
        if newton is not None and np.array_equal(np.flatnonzero(strong), minimum[1]):
            stability = minimum[0]  # Newton's acceptance judged these very rows already
        else:
            stability = verdict(H[1:, 1:], jac[strong][:, 1:], mass[1:])
    else:  # IPOPT left no usable point: no verdict
        converged, stationarity = False, float("inf")
        stability = ContactVerdict(np.array([np.nan]), -1, False)
    raw = RawSolution(z=z, converged=converged,
                      status="converged" if converged else ("obstacle_at_rest" if problem else "not_converged"),
                      iterations=iterations, stationarity=stationarity, message=message)
    result = make_result(scene, opts, solver, P, raw, stability, False, [], time.perf_counter() - t0)
    result.stats["method"] = ("none" if problem is not None else
                              "newton on the contact set" if newton is not None else "ipopt")
    X, Y = (np.asarray(v, float).ravel() for v in nlp.f_xy(z))
    result.contact = contact_report(scene, nlp, X, Y, mu, strong, weak, pairs, nlp.pair_normals(z, Pall))
    result.contact["start"] = start
    # a warm start's multipliers (the next state of a path), with the (cached) NLP they belong to
    result._contact_multipliers = WarmMultipliers((weakref.ref(nlp), pairs, lam, signs))
    result._balance = Balance(solver, P, result._dense, scene, z, point_loads=point_loads(result.contact))
    return result


class WarmMultipliers(tuple):
    """(weak reference to the NLP, pairs, multipliers, signs) of a contact result: the warm start of
    the next state of a path in this process. Copies share it; a pickle (a result a worker sends
    back) holds None instead, as the NLP lives in the process that solved it."""

    def __reduce__(self):
        return _nothing, ()

    def __copy__(self):
        return self

    def __deepcopy__(self, memo):
        return self


def _nothing():
    return None


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
