"""Checks of :mod:`bench_design` that follow a design by the independent reference: the box's
corners reached by continuation from the design state, and the schedule replayed from rest.

Both march the shooting reference (``actuator_design.reference.shooting``, scipy's DOP853, its own
right-hand side) in small parameter steps: each step starts Newton from a secant predictor of
θ'(0) and, of the roots near it, takes the one whose tip is nearest the last accepted tip (at
strong fields the roots lie close in θ'(0), growth ~e^h); a step whose tip moves by more than
:data:`TIP_JUMP` has left the branch and is halved (down to :data:`MIN_STEP`). Where shooting
loses the branch, the same march is made by Newton on a 32 × 12 LGL mesh instead (a convergence
check of the transcription), and the check says so.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable, List, Optional, Tuple

import numpy as np

from actuator_design.robust.tolerances import perturb
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reference.jacobi import jacobi_morse_index
from actuator_design.reference.shooting import ShootingParams, shoot, solve_shooting
from actuator_design.equilibrium.solver import get_solver

#: Half-width of the θ'(0) window searched for roots around the predictor, relative to max(1, |γ|);
#: on the refined mesh, 4× it bounds the change of θ in one step.
MAX_JUMP = 0.05
#: Largest tip move in one accepted step (rod lengths): a larger one is a jump to another branch.
TIP_JUMP = 0.05
#: Smallest step (fraction of a leg) before the march gives up.
MIN_STEP = 1.0 / 4096
REFINED = SolverOptions(elements=32, degree=12)
#: The stated discretisation error is an estimate (the change of the tip on a finer mesh), not a
#: bound: a state is checked to ESTIMATE_FACTOR times it (at least 1e-6).
ESTIMATE_FACTOR = 2.0


def _profile(p):
    return 0.0 if p is None else p  # a Profile is a vectorised callable of s


def shooting_params(scene) -> ShootingParams:
    """The reference's parameters of a (dimensionless) scene."""
    return ShootingParams(h=scene.h, phi=scene.phi, fx=0.0 if scene.tip_force is None else scene.tip_force[0],
                          fy=scene.p, m=scene.tip_moment or 0.0, theta0=scene.theta0,
                          alpha=_profile(scene.fibres), b=_profile(scene.stiffness), h_r=scene.h_r,
                          beta=_profile(scene.magnetization))


def _tip_gap(q, tip) -> float:
    return math.inf if tip is None else math.hypot(q.tip[0] - tip[0], q.tip[1] - tip[1])


def _nearest_root(params, pred: float, gamma: float, tip):
    """The root of the free-end residual near θ'(0) = ``pred`` whose tip is nearest ``tip`` (the
    last accepted state): at strong fields the roots lie close in θ'(0) (growth ~e^h), and Newton
    from the predictor can land on a neighbour with a wholly different shape."""
    q = solve_shooting(params, pred)
    if q.converged and _tip_gap(q, tip) <= TIP_JUMP:
        return q
    half = MAX_JUMP * max(1.0, abs(gamma))
    grid = pred + np.linspace(-half, half, 21)
    r = [shoot(g, params).residual for g in grid]
    roots = [solve_shooting(params, bracket=(grid[k], grid[k + 1])) for k in range(grid.size - 1)
             if r[k] * r[k + 1] <= 0]
    roots = [x for x in roots if x.converged] + ([q] if q.converged else [])
    return min(roots, key=lambda x: _tip_gap(x, tip), default=None)


def _march_shooting(scene_at: Callable[[float], object], gamma: float, tip, steps: int,
                    slope: float = 0.0):
    """Shooting continuation over t ∈ [0, 1] from θ'(0) = ``gamma`` and its tip (x, y), with
    dγ/dt ≈ ``slope``: each step takes the root near the secant predictor nearest the last tip,
    accepted when the tip moves by at most :data:`TIP_JUMP` (else the step is halved). Returns
    (solution at t = 1 or None, reason, slope)."""
    t, dt, sol = 0.0, 1.0 / steps, None
    while t < 1.0 - 1e-15:
        dt = min(dt, 1.0 - t)
        pred = gamma + slope * dt
        q = _nearest_root(shooting_params(scene_at(t + dt)), pred, gamma, tip)
        if q is not None and _tip_gap(q, tip) <= TIP_JUMP:
            slope = (q.gamma - gamma) / dt
            t, gamma, sol, tip = t + dt, q.gamma, q, q.tip
            dt = min(2 * dt, 1.0 / steps)
            continue
        dt /= 2
        if dt < MIN_STEP:
            return None, f"shooting lost the branch at {100 * t:.3g} % of the way", slope
    return sol, "", slope


def _march_refined(scene_at: Callable[[float], object], z: np.ndarray, steps: int):
    """The same march by Newton on the refined mesh from θ ``z`` at its nodes:
    ((θ at t = 1, tip (x, y), Morse index) or None, reason)."""
    sv = get_solver(scene_at(0.0), REFINED)
    t, dt = 0.0, 1.0 / steps
    while t < 1.0 - 1e-15:
        dt = min(dt, 1.0 - t)
        raw = sv.solve_newton(z, sv.parameter_vector(scene_at(t + dt)))
        if raw.converged and np.max(np.abs(raw.z - z)) <= 4 * MAX_JUMP * max(1.0, np.max(np.abs(z))):
            t, z = t + dt, raw.z
            dt = min(2 * dt, 1.0 / steps)
            continue
        dt /= 2
        if dt < MIN_STEP:
            return None, f"the refined mesh lost the branch at {100 * t:.3g} % of the way"
    P = sv.parameter_vector(scene_at(1.0))
    _, x, y = sv.f_tip(z, P)
    return (z, (float(x), float(y)), int(sv.stability(z, P).morse_index)), ""


def _on_refined(scene, s, theta) -> np.ndarray:
    return np.interp(get_solver(scene, REFINED).transcription.nodes, s, theta)


def follow(scene_at, s, theta, gamma, tip, steps=4) -> Tuple[Optional[Tuple[float, float]],
                                                              Optional[int], str, str]:
    """(tip (x, y), Morse index, method, reason) at t = 1 of the scene family ``scene_at``
    followed from the state (s, θ, γ = θ'(0), its tip (x, y)) at t = 0; tip None when both methods
    lose it."""
    sol, why, _ = _march_shooting(scene_at, gamma, tip, steps)
    if sol is not None:
        morse = None if scene_at(1.0).h_r > 0 else jacobi_morse_index(sol, sol.params).index
        return (float(sol.tip[0]), float(sol.tip[1])), morse, "shooting", ""
    got, why2 = _march_refined(scene_at, _on_refined(scene_at(0.0), s, theta), steps)
    if got is None:
        return None, None, "refined mesh", f"{why}; {why2}"
    return got[1], got[2], "refined mesh", ""


def corner_checks(res) -> List[str]:
    """Every box corner the design reports, reached by the reference from the design state along
    the straight segment to it: its tip must be the reported one to the stated discretisation
    error (times :data:`ESTIMATE_FACTOR`, at least 1e-6), and its Morse index 0. Returns the
    failed checks (text)."""
    rob = res.robustness.robustness
    tol, stated = rob.tolerances, max(1e-6, rob.discretisation_error)
    state, base = res.path.final, res.design_scene
    gamma = float(state._clamp_curvature())
    out = []
    for c in rob.corners:
        off = c["offset"]
        scene_at = lambda t, off=off: perturb(base, tol, {k: t * v for k, v in off.items()})
        tip, morse, how, why = follow(scene_at, state.s, state.theta, gamma,
                                      (res.achieved["x"], res.achieved["y"]))
        label = ", ".join(f"{k} {v:+g}" for k, v in off.items())
        if tip is None:
            out.append(f"corner ({label}): {why}")
            continue
        d = math.hypot(tip[0] - c["tip"]["x"], tip[1] - c["tip"]["y"])
        if d > ESTIMATE_FACTOR * stated:
            out.append(f"corner ({label}): {how} tip differs by {d:.3g} (stated {stated:.3g})")
        if morse not in (None, 0):
            out.append(f"corner ({label}): Morse index {morse} ({how})")
    return out


def schedule_check(res) -> List[str]:
    """The reported schedule replayed from rest (the straight rod at zero field) by the reference,
    leg by leg (straight lines between its points in (h, φ[, p]), with h_r and h_pos in proportion
    to h as the one field drives them): it must end at the reported tip to the stated
    discretisation error (times :data:`ESTIMATE_FACTOR`, at least 1e-6). Returns the failed checks
    (text)."""
    pts, base = res.schedule, res.design_scene
    stated = max(1e-6, res.robustness.robustness.discretisation_error) if res.robustness is not None else 1e-6
    keys = [k for k in ("h", "phi", "p") if k in pts[0]]

    def at(values):  # the field is one field: h_r and h_pos grow with h (h, h_r, h_pos ∝ H, THEORY §9)
        sc = base.with_values(**values)
        k = values["h"] / base.h if "h" in values and base.h > 0 else 1.0
        return replace(sc, h_r=base.h_r * k, h_pos=base.h_pos * k)

    legs = [lambda t, a=a, b=b: at({k: (1 - t) * a[k] + t * b[k] for k in keys})
            for a, b in zip(pts[:-1], pts[1:])]
    tip, how = _replay_shooting(legs, (math.cos(base.theta0), math.sin(base.theta0)))
    if tip is None:  # shooting lost the branch: the whole replay again on the refined mesh
        z = _on_refined(base, np.array([0.0, 1.0]), np.full(2, base.theta0))
        for leg in legs:
            got, why = _march_refined(leg, z, 1)
            if got is None:
                return [f"schedule: the replay from rest was lost ({how}; {why})"]
            z, tip = got[0], got[1]
        how = "refined-mesh"
    d = math.hypot(tip[0] - res.achieved["x"], tip[1] - res.achieved["y"])
    if d <= ESTIMATE_FACTOR * stated:
        return []
    return [f"schedule: the {how} replay from rest ends {d:.3g} from the reported tip (stated {stated:.3g})"]


def _replay_shooting(legs, tip):
    """(tip at the end of the last leg, "shooting") or (None, reason), from the straight rod
    (θ'(0) = 0, ``tip``) at the first leg's start."""
    gamma, slope = 0.0, 0.0
    for leg in legs:
        sol, why, slope = _march_shooting(leg, gamma, tip, 1, slope)
        if sol is None:
            return None, why
        gamma, tip = sol.gamma, (float(sol.tip[0]), float(sol.tip[1]))
    return tip, "shooting"
