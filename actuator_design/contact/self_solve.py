"""Self-contact reached from rest (issue 20 item 3): the loads ramped from zero with the
self-contact rows of the pairs near each step (:mod:`actuator_design.contact.self_contact`), then
the contact solve's split rounds at full load (:mod:`actuator_design.contact.equilibrium`).
"""
from __future__ import annotations

import time
from dataclasses import replace
from typing import Optional, Tuple

import numpy as np

from actuator_design.contact.contact_nlp import contact_nlp
from actuator_design.contact.equilibrium import solve_contact, solve_once
from actuator_design.contact.self_contact import (candidate_pairs, neighbour_arc, self_contact_mesh,
                                                  self_penetration, spacing_note)
from actuator_design.continuation.from_rest import load_fraction, path_from_rest
from actuator_design.equilibrium.acceptance import graded_options
from actuator_design.equilibrium.solver import get_solver

__all__ = ["solve_self_contact", "free_lead_in", "RAMP_DTHETA", "LEAD_STATIONS", "LEAD_MARGIN", "LEAD_FIRST"]


#: the ramp from rest: first, largest and smallest load-fraction steps
RAMP_FIRST, RAMP_MAX, RAMP_MIN = 0.125, 0.25, 1.0 / 1024
#: a ramp step that moves a nodal angle more than this (rad) is halved
RAMP_DTHETA = 0.6
#: stations of the contact-free lead-in (:func:`free_lead_in`): load fractions k/LEAD_STATIONS
LEAD_STATIONS = 64
#: ... which stop before the rod comes within (2 + LEAD_MARGIN)·gap of itself, or (1 + LEAD_MARGIN)·gap
#: of an obstacle, at its constrained points: the ramp with the contact rows starts from a state
#: that keeps every row, on the last station before the first touch
LEAD_MARGIN = 0.25
#: the ramp's first step after a lead-in, in stations: the next station came near
LEAD_FIRST = 1


def solve_self_contact(scene, options, initial=None, start: Optional[str] = None):
    """The equilibrium of ``scene`` with self-contact (and its obstacles, if any), reached from rest.

    While the rod stays clear of itself and of the obstacles the loads are ramped by the fast
    contact-free path from rest (:func:`free_lead_in`); from there (first by one of its stations,
    :data:`LEAD_FIRST`: the next one came near; from rest by :data:`RAMP_FIRST`) they are ramped
    on the graded mesh with the self-contact rows of the pairs near each step's start; a step that
    fails, moves a nodal angle more than :data:`RAMP_DTHETA` or leaves the rod inside itself is
    halved, down to :data:`RAMP_MIN` (then the result says where the ramp stopped). At full load
    the contact solve's split rounds (:func:`~actuator_design.contact.equilibrium.solve_contact`)
    put element boundaries at both points of each contact. With ``initial`` (an equilibrium of a
    nearby scene) the ramp is skipped (``start`` names it in the message).
    """
    if initial is not None:
        return solve_contact(scene, options, initial, self_contact=True, start=start)
    t0 = time.perf_counter()
    options = self_contact_mesh(scene, options)
    opts = graded_options(scene, options) if options.adapt else options
    opts = replace(opts, split_at=())
    t, theta = free_lead_in(scene, opts)
    state, dt, steps = None, (RAMP_FIRST if theta is None else LEAD_FIRST / LEAD_STATIONS), 0
    while t < 1.0:
        tn = min(1.0, t + dt)
        r = solve_once(scene, opts, t0, initial=state, fraction=tn, self_contact=True, theta_start=theta)
        if not r.success and theta is not None:  # the start violates a newly chosen pair: IPOPT's
            r = solve_once(scene, opts, t0, initial=state, fraction=tn, self_contact=True, cold=True,  # barrier
                           theta_start=theta)
        steps += 1
        # the ramp keeps the rod on its side of itself (centre lines a gap apart); the contact
        # points' element boundaries, and with them the accuracy, come at full load
        ok = r.success and self_penetration(r, scene.contact_gap, tol=scene.contact_gap) is None
        change = float(np.max(np.abs(r.theta - theta))) if theta is not None else 0.0
        if ok and change <= RAMP_DTHETA:
            # the next step aims at 0.7 of the largest change (at most double, RAMP_MAX)
            grow = 2.0 if change <= 0.35 * RAMP_DTHETA else 0.7 * RAMP_DTHETA / change
            state, theta, t, dt = r, np.asarray(r.theta, float), tn, min(grow * dt, RAMP_MAX)
            continue
        dt *= 0.5
        if dt < RAMP_MIN:  # reported: the last state reached (an equilibrium at that fraction), not
            if state is None and theta is not None:  # the rejected trial beyond it; the lead-in's end
                state = solve_once(scene, opts, t0, fraction=t, self_contact=True, theta_start=theta)
            out = state if state is not None else r
            out.success, out.status = False, "not_converged"
            out.message += (f"; the load ramp from rest with self-contact stopped at {100 * t:.4g} % of the "
                            f"loads (a snap, or a contact the ramp cannot follow)"
                            + (f": the shape is the last state reached, at {100 * t:.10g} % of every load"
                               if state is not None else ""))
            note = spacing_note(scene, out.options)
            out.message += f"; {note}" if note is not None else ""
            inside = self_penetration(out, scene.contact_gap)
            if inside is not None:  # the ramp's states may come within one gap of themselves
                a, b, depth = inside
                out.message += (f"; that shape enters its own thickness (s = {a:.4g} and s = {b:.4g} come "
                                f"{2.0 * scene.contact_gap - depth:.3g} apart, less than 2 x gap = "
                                f"{2.0 * scene.contact_gap:.3g} rod lengths): it is no physical state")
            return out
    out = solve_contact(scene, options, state, self_contact=True, first=state,
                        start=f"rest, the loads ramped in {steps} steps with self-contact")
    note = spacing_note(scene, out.options)
    if note is not None:
        out.message += f"; {note}"
    return out


def free_lead_in(scene, opts) -> Tuple[float, Optional[np.ndarray]]:
    """How far the loads of ``scene`` go from rest before its rod comes near itself or an obstacle:
    the last of the stations k/:data:`LEAD_STATIONS` of the contact-free path from rest
    (:func:`~actuator_design.continuation.from_rest.path_from_rest`, Newton steps on the mesh of
    ``opts``) before the first whose rod comes within (2 + :data:`LEAD_MARGIN`)·gap of itself or
    (1 + LEAD_MARGIN)·gap of an obstacle at its constrained points, and θ there at the nodes (rad);
    (0, None) when that is rest. Up to there the contact rows hold nothing, and the ramp with them
    would follow the same states, an IPOPT solve each; from there its steps choose the pairs that
    come near, as from any state of the ramp. It also stops before a snap or a branch point of the
    path: a contact-free snap could carry the rod through itself, and the ramp meets them with the
    contact rows."""
    gap = scene.contact_gap
    solver = get_solver(scene, opts)
    nlp = contact_nlp(solver, scene, self_contact=True)
    P = solver.parameter_vector(scene)
    lams = np.arange(1, LEAD_STATIONS + 1) / LEAD_STATIONS
    path = path_from_rest(solver, P, stations=[(lam, load_fraction(solver, P, lam)) for lam in lams])
    last = (0.0, None)
    # the pairs of points far enough apart along the rod to be a contact (the clamp first): where
    # none comes within reach, candidate_pairs finds none either, and is not asked
    far = np.triu(np.abs(nlp.s_self[:, None] - nlp.s_self[None, :]) >= neighbour_arc(gap), 1)
    reach = (2.0 + LEAD_MARGIN) * gap
    for lam, visit in zip(lams, path.visits):
        z = np.asarray(visit.z, float)
        X, Y = (np.concatenate([[0.0], np.asarray(v, float).ravel()]) for v in nlp.f_xy(z))
        near = (not np.min(np.hypot(X[:, None] - X[None, :], Y[:, None] - Y[None, :])[far], initial=np.inf) > reach
                and candidate_pairs(nlp.s_self, X, Y, gap, reach=LEAD_MARGIN * gap, slots=1)) or (
            scene.obstacles and np.min(np.asarray(nlp.f_dist(z), float)) < LEAD_MARGIN * gap)
        if near or not visit.newton or visit.snaps or visit.branch_points or lam == 1.0:
            break
        last = (float(lam), z)
    return last
