"""Self-contact reached from rest (issue 20 item 3): the loads ramped from zero with the
self-contact rows of the pairs near each step (:mod:`actuator_design.contact.self_contact`), then
the contact solve's split rounds at full load (:mod:`actuator_design.contact.equilibrium`).
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from actuator_design.contact.equilibrium import solve_contact, solve_once
from actuator_design.contact.self_contact import self_penetration
from actuator_design.equilibrium.acceptance import graded_options

__all__ = ["solve_self_contact", "RAMP_DTHETA"]


#: the ramp from rest: first, largest and smallest load-fraction steps
RAMP_FIRST, RAMP_MAX, RAMP_MIN = 0.125, 0.25, 1.0 / 1024
#: a ramp step that moves a nodal angle more than this (rad) is halved
RAMP_DTHETA = 0.6


def solve_self_contact(scene, options, initial=None):
    """The equilibrium of ``scene`` with self-contact (and its obstacles, if any), reached from rest.

    The loads (every field and load slot, :func:`~actuator_design.continuation.from_rest.load_fraction`) are
    ramped from zero on the graded mesh with the self-contact rows of the pairs near each step's
    start; a step that fails, moves a nodal angle more than :data:`RAMP_DTHETA` or leaves the rod
    inside itself is halved, down to :data:`RAMP_MIN` (then the result says where the ramp
    stopped). At full load the contact solve's split rounds (:func:`~actuator_design.contact.equilibrium.solve_contact`)
    put element boundaries at both points of each contact. With ``initial`` (an equilibrium of a
    nearby scene) the ramp is skipped.
    """
    if initial is not None:
        return solve_contact(scene, options, initial, self_contact=True)
    t0 = time.perf_counter()
    opts = graded_options(scene, options) if options.adapt else options
    opts = replace(opts, split_at=())
    state, t, dt, steps = None, 0.0, RAMP_FIRST, 0
    while t < 1.0:
        tn = min(1.0, t + dt)
        r = solve_once(scene, opts, t0, initial=state, fraction=tn, self_contact=True)
        if not r.success and state is not None:  # the start violates a newly chosen pair: IPOPT's
            r = solve_once(scene, opts, t0, initial=state, fraction=tn, self_contact=True, cold=True)  # barrier
        steps += 1
        # the ramp keeps the rod on its side of itself (centre lines a gap apart); the contact
        # points' element boundaries, and with them the accuracy, come at full load
        ok = r.success and self_penetration(r, scene.contact_gap, tol=scene.contact_gap) is None
        change = float(np.max(np.abs(r.theta - state.theta))) if state is not None else 0.0
        if ok and change <= RAMP_DTHETA:
            # the next step aims at 0.7 of the largest change (at most double, RAMP_MAX)
            grow = 2.0 if change <= 0.35 * RAMP_DTHETA else 0.7 * RAMP_DTHETA / change
            state, t, dt = r, tn, min(grow * dt, RAMP_MAX)
            continue
        dt *= 0.5
        if dt < RAMP_MIN:  # reported: the last state reached (an equilibrium at that fraction), not
            out = state if state is not None else r  # the rejected trial beyond it
            out.success, out.status = False, "not_converged"
            out.message += (f"; the load ramp from rest with self-contact stopped at {100 * t:.4g} % of the "
                            f"loads (a snap, or a contact the ramp cannot follow)"
                            + (f": the shape is the last state reached, at {100 * t:.10g} % of every load"
                               if state is not None else ""))
            return out
    return solve_contact(scene, options, state, self_contact=True,
                         start=f"rest, the loads ramped in {steps} steps with self-contact")
