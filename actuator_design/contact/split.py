"""Element boundaries at contact points: the split rounds of :func:`actuator_design.contact.equilibrium.solve_contact`.

A point force inside an element kinks θ', which one polynomial cannot follow: each contact point
becomes an element boundary, at the point of the solved shape nearest its obstacle (or, for a
self-contact, at the two points of the shape nearest each other), and the solve is repeated until
the boundaries stay put. The rounds are a fixed-point iteration s ← F(s) that converges linearly
(a boundary pulls the contact point a fraction of the way); :func:`accelerated` takes it there in
fewer rounds.
"""
from __future__ import annotations

import numpy as np

from actuator_design.contact.obstacles import distance_jet

__all__ = ["accelerated", "extended", "merged", "nearest_point", "MAX_SPLIT_ROUNDS", "SPLIT_TOL", "MERGE", "DEPTH"]

#: rounds of solve → move the element boundaries to the contact points → solve (a safeguard: the
#: rounds stop when the points stay put; obstacles take 1–5, the self-contact coil 10 at tip moment
#: 8.5 and 27 at 8.6, where its turns' contact wanders along their nearly parallel stretch first)
MAX_SPLIT_ROUNDS = 30
#: a boundary this close (arc length) to its contact point stays: the kink it leaves is below the
#: residual check's resolution (a force F off by δs leaves a residual ~F δs). Measured: a looser
#: rule (F δs below 1e-3 of the residual limit, δs ≤ 1e-6) saved the lumen a round but moved a
#: coil's tip angle by 2.6e-7 and a pegged rod's compliance by 1.4e-3 of itself
SPLIT_TOL = 1e-8
#: contact points closer than this (rod lengths of arc) are one point: one element boundary
MERGE = 1e-6
#: rounds of differences Anderson's mixing uses (:func:`accelerated`)
DEPTH = 3
#: points of the grid :func:`nearest_point` brackets the least distance on (one vectorised evaluation)
GRID = 65
#: :func:`nearest_point` stops after a Newton step this small (arc length; its error is then ~ its
#: square), or where bisections narrowed the bracket to it
ROOT_STEP = 1e-10
#: a safeguard: Newton steps and bisections of :func:`nearest_point` (bisection alone reaches
#: ROOT_STEP from a grid bracket in ~25)
ROOT_ITERATIONS = 100


def accelerated(history) -> tuple:
    """The next element boundaries from the rounds so far with the same points, ``history`` of
    (s, F(s)): Anderson's mixing over the last :data:`DEPTH` differences (one difference: the
    secant root of G(s) = F(s) − s), which couples the points (the two ends of a self-contact slide
    together); F(s) itself for the first round, or where the step leaves (0, 1) or lands farther
    than 10 max|G| from F(s) (an extrapolation from nearly equal G)."""
    s1, f1 = (np.asarray(v, float) for v in history[-1])
    if len(history) < 2:
        return merged(sorted(f1))
    depth = min(DEPTH, s1.size)  # no more differences than points: one point, the secant
    S = np.array([np.asarray(h[0], float) for h in history[-(depth + 1):]])
    G = np.array([np.asarray(h[1], float) for h in history[-(depth + 1):]]) - S
    dS, dG = np.diff(S, axis=0).T, np.diff(G, axis=0).T
    g1 = G[-1]
    if not np.all(np.isfinite(dG)) or np.max(np.abs(dG), initial=0.0) <= 1e-14:
        return merged(sorted(f1))
    gamma = np.linalg.lstsq(dG, g1, rcond=1e-10)[0]
    step = s1 + g1 - (dS + dG) @ gamma
    if (np.any(step <= 0.0) or np.any(step >= 1.0)
            or np.max(np.abs(step - f1)) > 10 * np.max(np.abs(g1))):
        return merged(sorted(f1))
    return merged(sorted(step))


def extended(history, here) -> list:
    """The rounds :func:`accelerated` mixes once ``here`` = (s, F(s)) is done: ``history`` continued
    while every round has as many points in its start as in its answer, and as the rounds before
    (a contact appearing or leaving starts a new history), else ``here`` alone."""
    s, f = here
    if history and len(history[-1][0]) == len(history[-1][1]) == len(s) == len(f):
        return history + [here]
    return [here]


def merged(points) -> tuple:
    """Sorted arc lengths with those closer than :data:`MERGE` merged into their mean."""
    groups = []
    for s in points:
        if groups and s - groups[-1][-1] <= MERGE:
            groups[-1].append(s)
        else:
            groups.append([s])
    return tuple(round(float(np.mean(g)), 12) for g in groups)


def nearest_point(scene, result, point: dict) -> float:
    """The arc length of the shape's point nearest the obstacle of a contact ``point``, within half
    an element of it: the root of the distance's slope f(s) = ∇d(r(s))·t(s) next to the least
    distance on a grid (a sign change, from approaching to leaving), else (the least distance at an
    end of the interval, a kink) the bounded minimum of the distance near that grid point.

    The root is bracketed on the grid (one evaluation of the shape), the bracket narrowed to one
    piece between the mesh's nodes, and the root found there by Newton's method
    with f'(s) = tᵀ∇²d t + θ' ∇d·n (n the rod's normal), kept inside the bracket (a step that
    leaves it bisects it instead): from the bracket's secant point, two evaluations of one point
    usually; it stops after a Newton step below :data:`ROOT_STEP`, whose error is then ~ that step
    squared."""
    ob = scene.obstacles[point["obstacle"]]
    half = 0.5 / max(1, result.options.elements)
    lo, hi = max(1e-9, point["s"] - half), min(1.0 - 1e-9, point["s"] + half)

    def slope(s: np.ndarray):
        """f and f' at the arc lengths ``s``."""
        v = result.evaluate(s)
        g, h = distance_jet(ob, v["x"], v["y"])
        c, n = np.cos(v["theta"]), np.sin(v["theta"])
        return (g[0] * c + g[1] * n,
                h[0] * c * c + 2.0 * h[1] * c * n + h[2] * n * n + v["dtheta"] * (g[1] * c - g[0] * n))

    grid = np.linspace(lo, hi, GRID)
    e = result.evaluate(grid)
    i = int(np.argmin(np.asarray(ob.distance(e["x"], e["y"]), float)))
    ia, ib = max(i - 1, 0), min(i + 1, GRID - 1)
    a, b = grid[ia], grid[ib]
    f = slope(grid[ia:ib + 1])[0]
    if f[0] < 0.0 < f[-1]:
        k = 1 + int(np.argmax(f[1:] >= 0.0))  # the first point past the crossing
        a, b, fa, fb = grid[ia + k - 1], grid[ia + k], f[k - 1], f[k]
        # θ' kinks at element boundaries (a contact's point force): the nodes inside the bracket
        # narrow it to a piece where f is smooth and Newton converges quadratically
        nodes = np.asarray(result.s, float)
        nodes = nodes[(nodes > a) & (nodes < b)]
        if nodes.size:
            s, fs = np.concatenate([[a], nodes, [b]]), np.concatenate([[fa], slope(nodes)[0], [fb]])
            k = 1 + int(np.argmax(fs[1:] >= 0.0))
            a, b, fa, fb = s[k - 1], s[k], fs[k - 1], fs[k]
        if fb == 0.0:
            return float(b)
        s = a - fa * (b - a) / (fb - fa)
        for _ in range(ROOT_ITERATIONS):
            (v,), (dv,) = slope(np.array([s]))
            if v == 0.0:
                break
            if v < 0.0:
                a, fa = s, v
            else:
                b, fb = s, v
            step = -v / dv if dv > 0.0 else np.nan
            if a < s + step < b:
                s += step
                if abs(step) <= ROOT_STEP:
                    break
            else:
                s = 0.5 * (a + b)
                if b - a <= ROOT_STEP:
                    break
        return float(s)
    from scipy.optimize import minimize_scalar  # here: scipy.optimize takes ~0.3 s to import

    dist = lambda s: float(np.asarray(ob.distance(*(result.evaluate(np.array([s]))[k] for k in ("x", "y"))))[0])
    return float(minimize_scalar(dist, bounds=(a, b), method="bounded", options={"xatol": 1e-12}).x)
