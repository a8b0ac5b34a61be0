"""Stage 4 of :func:`~actuator_design.inverse.design.design`, **verify**, independently of the design NLP's own state: a
fresh forward solve, and a quasi-static loading path from zero field that must reach the design
without a snap and end stable (a magnitude ramp at the designed angle or, where that lands on
another branch, a ramp at another angle followed by a rotation of the field).

The ramp is one of the applied field's magnitude H, from 0 to the design's H_d: at the fraction
t = H/H_d every field group is at its design value times t^field_power (the lens's
``Parameter.field_power``, THEORY §5, §9): h = t·h_d and, with remanence, h_r = t·h_r,d (both linear
in H; h² ∝ H²). A schedule row names h and the remanent groups (:func:`ramped_groups`: a rod with
remanence alone has no h to ramp); every other group the field drives (h_pos of a non-uniform
field) follows h by the lens's rule, the path's base being the design scene. (A rod with h = 0 has
no magnitude for h_pos to follow: it stays at its design value, as it did before.) A rotation keeps
the magnitude, so every group stays at its design value."""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Dict, List, Mapping, Sequence, Tuple

import numpy as np

from actuator_design.contact.clearance import entering
from actuator_design.continuation.loading import follow_path  # the quasi-static path follower
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.inverse.settings import Choice, DesignProblem, Verification, normalise_phi, phi_period
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import term_class

__all__ = ["verify", "stiffness_by_differences", "ramped_groups", "schedule_rows"]


def verify(problem: DesignProblem, choice: Choice) -> Verification:
    """Fresh forward solve and a snap-free loading path from zero field; never the NLP's own state.

    Schedules tried: the magnitude ramp at the designed angle; if it lands on another branch, a
    ramp at φ_d ∓ Δ (Δ = 90°, 45°, 135°) followed by a rotation of the field to φ_d, rotating first
    in the direction that winds the rod from where the plain ramp left it towards the design (a
    rotating field can wind the rod onto branches a ramp never reaches).

    Parameters
    ----------
    problem : DesignProblem
    choice : Choice
        The design: ``choice.scene`` is its forward scene, ``choice.point`` its NLP state (used
        only for the tip the path must reach, to 1e-6).

    Returns
    -------
    Verification
        ``path`` is None when no schedule reaches the design; ``schedule`` is the one followed.
    """
    pt, options = choice.point, problem.options
    design_p = "p" in choice.candidate.vary
    forward = solve(choice.scene, options)  # a fresh forward NLP from the straight rod
    # the path's base is the design scene: every value a row does not name stays at the design's,
    # and the groups that follow h by the lens's rule (h_pos) start at zero field with it
    start = choice.scene
    groups = ramped_groups(choice.scene)
    steps = problem.settings.ramp_steps
    obstacles, gap = tuple(start.obstacles), float(start.contact_gap)
    touched: List[str] = []

    def reaches(path) -> bool:
        final = path.final
        return (final is not None and final.success and path.snap_free and final.stable
                and max(abs(final.tip["x"] - pt.tip[0]), abs(final.tip["y"] - pt.tip[1]),
                        abs(final.tip["angle"] - pt.tip[2])) <= 1e-6)

    def attempt(schedule):
        # with obstacles the rod is first followed without them: a path through states clear of
        # them is the contact path (no constraint is active on it), found without a contact solve
        # per step. The first schedule whose free path touches an obstacle on the way is followed
        # again through contact (touch-down, lift-off); only that one: a rod sliding along a wall
        # costs contact solves on new meshes at every step (issue 20)
        path = follow_path(replace(start, obstacles=()), options, schedule, max_step=0.25, max_dtheta=0.5)
        ok = reaches(path)
        if ok and obstacles:
            hit = next(((k, st) for st in path.states if st.success
                        for k in [entering(obstacles, gap, st)] if k is not None), None)
            if hit is not None:
                (k, s_hit, _), st = hit
                touched.append(f"the rod touches the {obstacles[k].describe()} at s = {s_hit:.3g} on the way")
                ok = False
                if len(touched) == 1:
                    path = follow_path(start, options, schedule, max_step=0.25, max_dtheta=0.5)
                    ok = reaches(path)
        return ok, path

    ramp = _ramp(groups, pt.phi, pt.p, steps, design_p)
    if not isinstance(choice.scene.field, UniformField):  # a field without an angle to set or turn
        ok, path = attempt([{k: v for k, v in step.items() if k != "phi"} for step in ramp])
        label = "magnitude ramp" + _contact_note(path)
        return (Verification(forward, path, label, ramp) if ok else  # (phi = 0 in the table)
                Verification(forward, None, "no snap-free magnitude ramp from zero field reaches the design", []))
    ok, path = attempt(ramp)
    if ok:
        return Verification(forward, path, "magnitude ramp at the designed angle" + _contact_note(path), ramp)
    reached = path.final.tip["angle"] if path.final is not None and path.final.success else 0.0
    wind = 1.0 if pt.tip[2] >= reached else -1.0  # rotate the field the way the rod must turn
    for sign in (wind, -wind):
        for delta_deg in (90, 45, 135):
            phi_a = pt.phi - sign * math.radians(delta_deg)
            schedule = _ramp_then_rotate(groups, phi_a, pt.phi, pt.p, steps, design_p)
            ok, path = attempt(schedule)
            if ok:
                phi_label = round(math.degrees(normalise_phi(phi_a, phi_period(choice.scene)))) + 0  # no "-0"
                return Verification(forward, path, f"ramp at {phi_label:.0f} deg, then "
                                    f"rotate the field {'counter-' if sign > 0 else ''}clockwise by {delta_deg} "
                                    f"deg to the designed angle" + _contact_note(path), schedule)
    if touched:
        return Verification(forward, None, "no snap-free path from zero field that keeps clear of the obstacles "
                            f"reaches the design ({touched[0]}; followed through contact, that path did not "
                            "reach it either)", [])
    return Verification(forward, None, "no snap-free path from zero field reaches the design", [])


def _contact_note(path) -> str:
    """What a verified path through contact met on the way ("" without contact events)."""
    events = getattr(path, "contact_events", None) or []
    if not events:
        return ""
    seen = ", ".join(dict.fromkeys(f"{e['kind']} on the {e['obstacle_text']}" if e["kind"] == "touch-down"
                                   else f"{e['kind']} from the {e['obstacle_text']}" for e in events))
    return f" (through contact on the way: {seen}; the design itself keeps clear of every obstacle)"


def ramped_groups(scene: Scene) -> Dict[str, Tuple[float, int]]:
    """The field groups a schedule row names, name -> (design value, power f: ∝ H^f): the magnitude
    h and every remanent-magnetisation group of a term the scene has (h_r, THEORY §9; the lens's
    ``Parameter.remanent_field``). Other groups the field drives follow h along the path."""
    out = {"h": (float(scene.h), 1)}
    for par, f in lens.field_groups(magnitude=False):
        if par.remanent_field and (par.term is None or term_class(par.term).present(scene)):
            out[par.name] = (par.get(scene), f)
    return out


def _field_groups(groups: Dict[str, Tuple[float, int]], t: float) -> Dict[str, float]:
    """The named groups at the fraction t = H/H_d of the design field: g_d·t^f each."""
    return {name: value * t ** f for name, (value, f) in groups.items()}


def _ramp(groups, phi: float, p: float, steps: int, design_p: bool) -> List[Dict[str, float]]:
    """``steps`` points from zero field (and load) to the design's groups, φ[, p] at the fixed angle φ."""
    return [{**_field_groups(groups, t), "phi": phi, **({"p": p * t} if design_p else {})}
            for t in np.linspace(0, 1, steps)]


def _ramp_then_rotate(groups, phi_a, phi, p, steps, design_p) -> List[Dict[str, float]]:
    """A ramp at φ_a, then a rotation of the field from φ_a to φ at full magnitude."""
    turn = [{**_field_groups(groups, 1.0), "phi": phi_a + (phi - phi_a) * t, **({"p": p} if design_p else {})}
            for t in np.linspace(0, 1, steps)[1:]]
    return _ramp(groups, phi_a, p, steps, design_p) + turn


def schedule_rows(schedule: Sequence[Mapping[str, float]], phi_shift: float = 0.0) -> List[Dict[str, float]]:
    """A verified schedule as output rows: h, φ (+ ``phi_shift``), then the other values each row
    names (remanent groups, p), as floats."""
    return [{"h": float(q["h"]), "phi": float(q["phi"]) + phi_shift,
             **{k: float(v) for k, v in q.items() if k not in ("h", "phi")}} for q in schedule]


def stiffness_by_differences(scene: Scene, options: SolverOptions, state, dp: float = 1e-5) -> float:
    """dp/dv1 (B0/ℓ³) by central differences of two independent forward solves warm-started on
    ``state`` so they stay on its branch; truncation error O(dp²).

    ``state`` is an :class:`~actuator_design.equilibrium.result.EquilibriumResult` (the solves then choose and
    check their mesh as ``solve`` does) or θ at the nodes of the mesh of ``options`` (one warm
    solve each on that mesh). NaN when a solve does not converge.
    """
    ys = []
    for sgn in (+1.0, -1.0):
        r = solve(scene.with_values(p=scene.p + sgn * dp), replace(options, ensure_stable=False), initial=state)
        if not r.success:
            return float("nan")
        ys.append(r.tip["y"])
    return float(2 * dp / (ys[0] - ys[1])) if ys[0] != ys[1] else float("inf")
