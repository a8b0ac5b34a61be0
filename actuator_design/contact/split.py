"""Element boundaries at contact points: the split rounds of :func:`actuator_design.contact.equilibrium.solve_contact`.

A point force inside an element kinks θ', which one polynomial cannot follow: each contact point
becomes an element boundary, at the point of the solved shape nearest its obstacle (or, for a
self-contact, at the two points of the shape nearest each other: :mod:`.nearest`), and the solve is repeated until
the boundaries stay put. The rounds are a fixed-point iteration s ← F(s) that converges linearly
(a boundary pulls the contact point a fraction of the way); :func:`accelerated` takes it there in
fewer rounds.
"""
from __future__ import annotations

import numpy as np

__all__ = ["accelerated", "extended", "merged", "MAX_SPLIT_ROUNDS", "SPLIT_TOL", "MERGE", "DEPTH"]

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
