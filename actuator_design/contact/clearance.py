"""Where obstacles constrain the rod: its distinct quadrature points and its tip, and the clearance
rows d_k(r(s_j)) − gap ≥ 0 at them (issue 20).

One home for the points both the contact NLP (:mod:`actuator_design.contact.equilibrium`, where the rows may
become active and carry the contact forces) and the design NLPs (:mod:`actuator_design.inverse.nlp`,
:mod:`actuator_design.robust.design_robust`, where a design keeps its rod clear of every obstacle) impose the
obstacles at. The positions are the transcription's own expressions of θ, so the rows have exact
derivatives.
"""
from __future__ import annotations

from typing import Optional, Sequence, Tuple

import casadi as ca
import numpy as np

__all__ = ["constrained_points", "constrained_angles", "clearance_rows", "entering", "least_clearance", "clearance_check", "clearances",
           "entered_at_rest", "PENETRATION_TOL"]


def constrained_points(tr, z) -> Tuple[ca.SX, ca.SX, np.ndarray, np.ndarray]:
    """The points obstacles are imposed at, for θ at all nodes ``z`` (CasADi, shape (nodes,)).

    One point per distinct quadrature point (LGL's element ends are points of two elements, its
    last one is the tip) and the tip; none at the clamp (it is fixed).

    Returns
    -------
    X, Y : SX, shape (m,)
        Positions, units of ℓ.
    s_points : ndarray, shape (m,)
        Arc lengths, units of ℓ, increasing (the last is the tip, s = 1).
    w_points : ndarray, shape (m,)
        Quadrature weight of each point (summed over its copies; 0 at the tip).
    """
    thq, _ = tr.point_values(z)
    xq, yq = tr.point_positions(thq)
    xt, yt = tr.tip_position(thq)
    first, s_points, w_points = _distinct_points(tr)
    return ca.vertcat(xq, xt)[first], ca.vertcat(yq, yt)[first], s_points, w_points


def constrained_angles(tr, z) -> ca.SX:
    """θ at the points of :func:`constrained_points` (rad, shape (m,)), for θ at all nodes ``z``."""
    thq, _ = tr.point_values(z)
    return ca.vertcat(thq, z[z.numel() - 1])[_distinct_points(tr)[0]]


def _distinct_points(tr) -> Tuple[list, np.ndarray, np.ndarray]:
    """(indices into the quadrature points and the tip of the distinct points after the clamp, their
    arc lengths, their summed quadrature weights)."""
    sq, wq = np.asarray(tr.quadrature_points, float), np.asarray(tr.quadrature_weights, float)
    s_all = np.concatenate([sq, [1.0]])
    w_all = np.concatenate([wq, [0.0]])
    keys = np.round(s_all, 13)
    first = [int(np.flatnonzero(keys == k)[0]) for k in np.unique(keys) if k > 0.0]
    return first, s_all[first], np.array([w_all[keys == keys[i]].sum() for i in first])


def clearance_rows(tr, z, obstacles: Sequence, gap: float) -> ca.SX:
    """d_k(r(s_j)) − gap for every obstacle k and constrained point j (obstacle-major), shape
    (len(obstacles)·m,); ≥ 0 where the rod keeps clear of (or just touches) every obstacle."""
    X, Y, _, _ = constrained_points(tr, z)
    return ca.vertcat(*[ob.distance(X, Y) - gap for ob in obstacles]) if obstacles else ca.SX(0, 1)


#: how far (rod lengths) a dense shape may come inside an obstacle's gap and still count as clear:
#: between the constrained points the shape is the transcription's interpolant, not constrained
PENETRATION_TOL = 1e-6


#: samples of :func:`entering`'s coarse pass along the rod (spacing 1/(COARSE − 1) of its length)
COARSE = 129


def entering(obstacles: Sequence, gap: float, state, n: int = 2001,
             tol: float = PENETRATION_TOL) -> Optional[Tuple[int, float, float]]:
    """Where a solved ``state`` (an :class:`~actuator_design.equilibrium.result.EquilibriumResult`) comes closer
    to an obstacle than ``gap`` by more than ``tol``, sampled at ``n`` points along it.

    A coarse pass first: a point of the rod between two coarse samples h apart lies within h/2 of
    one of them (|r'| = 1) and a signed distance changes by at most that, so only the stretches
    where a coarse sample comes within h/2 − tol of the gap are sampled at the ``n`` points: the
    same entry as sampling all of them (its depth up to round-off: positions at a subset of the
    points are integrated by another Gauss rule).

    Returns
    -------
    (k, s, depth) or None
        The obstacle's index, the arc length (units of ℓ) and how deep (units of ℓ) the deepest
        entry is; None when the state keeps clear of every obstacle.
    """
    fine = np.linspace(0.0, 1.0, n)
    if n > COARSE:
        coarse = np.linspace(0.0, 1.0, COARSE)
        c = state.evaluate(coarse)
        near = np.zeros(COARSE - 1, bool)
        for ob in obstacles:
            dist = np.asarray(ob.distance(c["x"], c["y"]), float) - gap
            with np.errstate(invalid="ignore"):
                near |= ~(np.minimum(dist[:-1], dist[1:]) - 0.5 / (COARSE - 1) >= -tol)  # NaN: near
        # the fine samples in the near stretches
        keep = near[np.clip(np.searchsorted(coarse, fine, side="right") - 1, 0, COARSE - 2)]
        if not np.any(keep):
            return None
        fine = fine[keep]
    d = state.evaluate(fine)
    worst = None
    for k, ob in enumerate(obstacles):
        dist = np.asarray(ob.distance(d["x"], d["y"]), float) - gap
        i = int(np.argmin(dist))
        if worst is None or dist[i] < worst[2]:
            worst = (k, float(d["s"][i]), float(dist[i]))
    if worst is None or worst[2] >= -tol:
        return None
    return worst[0], worst[1], -worst[2]


def least_clearance(solver, obstacles: Sequence, gap: float):
    """θ at the nodes of ``solver``'s mesh (rad, shape (nodes,)) → the least d_k(r(s_j)) − gap over
    the obstacles and the points contact is imposed at (units of ℓ; +inf without obstacles)."""
    z = ca.SX.sym("z", solver.transcription.nodes.size)
    rows = ca.Function("clearance", [z], [clearance_rows(solver.transcription, z, tuple(obstacles), gap)])
    return lambda theta: float(np.min(np.asarray(rows(np.asarray(theta, float)), float), initial=np.inf))


def clearance_check(solver, obstacles: Sequence, gap: float, tol: float = PENETRATION_TOL):
    """A predicate on θ at the nodes of ``solver``'s mesh (rad, shape (nodes,)): whether the rod
    keeps clear of every obstacle at the points contact is imposed at (to ``tol`` rod lengths);
    None when there are no obstacles (every state is admissible)."""
    if not obstacles:
        return None
    least = least_clearance(solver, obstacles, gap)
    return lambda theta: least(theta) >= -tol


def clearances(obstacles: Sequence, gap: float, state, n: int = 2001) -> list:
    """How far a solved ``state`` keeps from each obstacle: per obstacle a dict with ``obstacle``
    (index), ``obstacle_text``, ``min_distance`` (the smallest d(r(s)) − gap, units of ℓ; 0 where it
    touches, negative inside) and ``s`` (where, units of ℓ), sampled at ``n`` points along the rod."""
    d = state.evaluate(np.linspace(0.0, 1.0, n))
    out = []
    for k, ob in enumerate(obstacles):
        dist = np.asarray(ob.distance(d["x"], d["y"]), float) - gap
        i = int(np.argmin(dist))
        out.append({"obstacle": k, "obstacle_text": ob.describe(), "min_distance": float(dist[i]),
                    "s": float(d["s"][i])})
    return out


def entered_at_rest(scene, n: int = 401) -> Optional[str]:
    """Where the straight rod at rest (at the clamp angle θ0) enters one of the scene's obstacles
    (closer than the gap), as words, or None when the rest state is free of them all."""
    s = np.linspace(0.0, 1.0, n)
    x, y = s * np.cos(scene.theta0), s * np.sin(scene.theta0)
    for ob in scene.obstacles:
        d = np.asarray(ob.distance(x, y), float) - scene.contact_gap
        if d.min() < -1e-9:
            return f"the straight rod at rest enters the {ob.describe()} at s = {s[int(np.argmin(d))]:.3g}"
    return None
