"""Stage 4 of :func:`~actuator_design.inverse.design.design`, **verify**, independently of the design NLP's own state: a
fresh forward solve, and a quasi-static loading path from zero field that must reach the design
without a snap and end stable (a magnitude ramp at the designed angle or, where that lands on
another branch, a ramp at another angle followed by a rotation of the field).

The ramp is one of the applied field's magnitude H, from 0 to the design's H_d: at the fraction
t = H/H_d every field group is at its design value times t^field_power (the lens's
``Parameter.field_power``, THEORY §5, §9): h = t·h_d and, with a hard-magnetic term, h_r = t·h_r,d
(both linear in H; h² ∝ H²). A rotation keeps the magnitude, so h and h_r stay at their design
values."""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Dict, List, Optional

import numpy as np

from actuator_design.contact.clearance import entering
from actuator_design.continuation.loading import follow_path  # the quasi-static path follower
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.inverse.settings import Choice, DesignProblem, Verification, normalise_phi, phi_period
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics.hard_magnetic import HardMagnetic

__all__ = ["verify", "stiffness_by_differences"]


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
    start = replace(choice.scene, h=0.0)
    hard = _hard_magnetic_group(choice.scene)  # h_r,d when the scene has the hard-magnetic term
    if hard is not None:
        start = replace(start, h_r=0.0)
    if design_p:
        start = start.with_values(p=0.0)
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

    ramp = _ramp(pt.h, pt.phi, pt.p, steps, design_p, hard)
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
            schedule = _ramp_then_rotate(pt.h, phi_a, pt.phi, pt.p, steps, design_p, hard)
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


def _hard_magnetic_group(scene: Scene) -> Optional[float]:
    """The scene's h_r when it has the hard-magnetic term (THEORY §9), else None."""
    return float(scene.h_r) if HardMagnetic.present(scene) else None


def _field_groups(h: float, h_r: Optional[float], t: float) -> Dict[str, float]:
    """The field groups at the fraction t = H/H_d of the design field: h·t and h_r·t (both ∝ H)."""
    return {"h": h * t, **({"h_r": h_r * t} if h_r is not None else {})}


def _ramp(h: float, phi: float, p: float, steps: int, design_p: bool,
          h_r: Optional[float] = None) -> List[Dict[str, float]]:
    """``steps`` points from zero field (and load) to (h[, h_r], φ[, p]) at the fixed angle φ."""
    return [{**_field_groups(h, h_r, t), "phi": phi, **({"p": p * t} if design_p else {})}
            for t in np.linspace(0, 1, steps)]


def _ramp_then_rotate(h, phi_a, phi, p, steps, design_p, h_r=None) -> List[Dict[str, float]]:
    """A ramp at φ_a, then a rotation of the field from φ_a to φ at full magnitude."""
    turn = [{**_field_groups(h, h_r, 1.0), "phi": phi_a + (phi - phi_a) * t, **({"p": p} if design_p else {})}
            for t in np.linspace(0, 1, steps)[1:]]
    return _ramp(h, phi_a, p, steps, design_p, h_r) + turn


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
