"""What a contact equilibrium reports (:mod:`actuator_design.contact.equilibrium`): the contact set and its
forces, and the stability verdict on the tangent space of the active constraints.

The rows of a contact NLP are obstacle-major (obstacle k's row at constrained point j is
k·m + j, m points) followed by the self-contact pairs (:mod:`actuator_design.contact.self_contact`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np
import scipy.linalg as sla

from actuator_design.reduced.stability import classify_spectrum

__all__ = ["ContactVerdict", "ACTIVE", "CONTACT_WINDOW", "verdict", "one_per_contact", "contact_report",
           "point_loads", "penetration_text"]

#: a multiplier above this (relative to max(1, the largest multiplier)) is a contact; below it,
#: with the constraint at the gap, the contact is weak (strict complementarity fails)
ACTIVE = 1e-5
#: strong contacts of one obstacle closer than this (arc length, units of ℓ) are one contact: the
#: nodes of a short element beside a contact point (a contact rolling off the tip) both carried
#: a force, one of them ~1e-5 of the other, and as two constraints they kept the rod from rolling
#: on the obstacle (the lowest eigenvalue jumped from 22.8 to 57.9 where the contact left the tip)
CONTACT_WINDOW = 1e-4


@dataclass
class ContactVerdict:
    eigenvalues: np.ndarray
    morse_index: int
    stable: bool
    marginal: bool = False


def one_per_contact(strong: np.ndarray, mu: np.ndarray, s_points: np.ndarray, n_obstacles: int,
                    pairs: Sequence[Tuple[int, int]] = ()) -> np.ndarray:
    """``strong`` with, among strong points of one obstacle within :data:`CONTACT_WINDOW` of each
    other (self-contact pairs: both ends within it), only the one of the largest multiplier kept
    (the others are reported weakly active)."""
    out = strong.copy()
    m = s_points.size
    groups: List[List[int]] = []
    for k in range(n_obstacles):
        idx = [k * m + j for j in range(m) if strong[k * m + j]]
        for i in idx:
            if groups and groups[-1][0] // m == k and s_points[i % m] - s_points[groups[-1][-1] % m] <= CONTACT_WINDOW:
                groups[-1].append(i)
            else:
                groups.append([i])
    base = n_obstacles * m
    s_self = np.concatenate([[0.0], s_points])  # pairs index the clamp, then the points
    pair_groups: List[List[int]] = []
    for q, (a, b) in enumerate(pairs):
        i = base + q
        if not strong[i]:
            continue
        for g in pair_groups:
            a0, b0 = pairs[g[0] - base]
            if abs(s_self[a] - s_self[a0]) <= CONTACT_WINDOW and abs(s_self[b] - s_self[b0]) <= CONTACT_WINDOW:
                g.append(i)
                break
        else:
            pair_groups.append([i])
    for group in groups + pair_groups:
        if len(group) > 1:
            keep = max(group, key=lambda g: mu[g])
            for g in group:
                out[g] = g == keep
    return out


def verdict(H: np.ndarray, A: np.ndarray, m: np.ndarray) -> ContactVerdict:
    """Inertia of H on the null space of the active rows A, against the mass diag(m)."""
    Z = sla.null_space(A) if A.size else np.eye(H.shape[0])
    if Z.shape[1] == 0:
        return ContactVerdict(np.array([np.inf]), 0, True)
    Hz, Mz = Z.T @ H @ Z, Z.T @ (m[:, None] * Z)
    ev = sla.eigh(0.5 * (Hz + Hz.T), 0.5 * (Mz + Mz.T), eigvals_only=True)
    # the package's one rule (scaled by the lowest eigenvalue: the largest grows without bound on a
    # short element beside a contact near the tip, and made a stable state "marginal")
    morse, stable, marginal = classify_spectrum(ev)
    return ContactVerdict(ev[:6], morse, stable, marginal)


def contact_report(scene, nlp, X, Y, mu, strong, weak, pairs: Sequence[Tuple[int, int]] = (),
                   normals: Optional[dict] = None) -> dict:
    """The ``contact`` dict of a result: ``points`` (one per obstacle contact; two per self-contact,
    ``obstacle`` None, ``self`` True and the other end's ``partner_s``), forces on the rod (units of
    B0/ℓ², per length B0/ℓ³; SI too on a physical scene), the total force, and what the solve used.
    ``normals``: pair slot → the direction its row pushes the a-end along (a corner pair's plane
    row, :meth:`~actuator_design.contact.contact_nlp.ContactNLP.pair_normals`); else r_a − r_b."""
    normals = normals or {}
    points: List[dict] = []

    def point(k, s, w, x, y, i, f, **extra):
        end = s in (0.0, 1.0)  # a point force; elsewhere the force of a quadrature weight
        points.append({"obstacle": k, "s": float(s), "x": float(x), "y": float(y),
                       "force": [float(f[0]), float(f[1])], "multiplier": float(mu[i]),
                       "force_per_length": None if end else [float(f[0] / w), float(f[1] / w)],
                       "weak": bool(weak[i]), **extra})

    m = nlp.n_points
    for k, ob in enumerate(scene.obstacles):
        for j in np.flatnonzero(strong[k * m:(k + 1) * m] | weak[k * m:(k + 1) * m]):
            i = k * m + j
            point(k, nlp.s_points[j], nlp.w_points[j], X[j], Y[j], i, mu[i] * ob.normal(X[j], Y[j])[:, 0])
    Xs, Ys = np.concatenate([[0.0], X]), np.concatenate([[0.0], Y])  # the clamp, then the points
    for q, (a, b) in enumerate(pairs):
        i = len(scene.obstacles) * m + q
        if strong[i] or weak[i]:
            d = np.array([Xs[a] - Xs[b], Ys[a] - Ys[b]])
            d = normals.get(q, d / max(float(np.hypot(*d)), 1e-300))
            f = mu[i] * d  # pushes a away from b, b from a
            for j, o, sign in ((a, b, 1.0), (b, a, -1.0)):
                point(None, nlp.s_self[j], nlp.w_self[j], Xs[j], Ys[j], i, sign * f, self=True,
                      partner_s=float(nlp.s_self[o]))
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
            "self_contact": bool(nlp.slots),
            "weakly_active": int(sum(p["weak"] for p in points)),
            "units": {"force": "B0/l^2", "force_per_length": "B0/l^3", "position": "rod length"}}


def point_loads(contact: dict):
    """The contact forces as point loads for :func:`actuator_design.equilibrium.balance.balance`:
    (s, fx, fy, x, y) arrays, or None without contacts."""
    pts = contact["points"]  # weakly active points too: their (tiny) forces are part of the balance
    if not pts:
        return None
    return tuple(np.array(v) for v in zip(*[(p["s"], p["force"][0], p["force"][1], p["x"], p["y"]) for p in pts]))


def penetration_text(scene, inside, self_inside) -> Optional[str]:
    """Whether the dense shape comes closer to an obstacle than the gap, or to itself than twice
    the gap, between the points where contact is imposed (by more than
    :data:`~actuator_design.contact.clearance.PENETRATION_TOL` rod lengths), in words: ``inside`` (obstacle index, s,
    depth) and ``self_inside`` (s, t, depth), each None when it does not (:mod:`actuator_design.contact.equilibrium`'s dense checks)."""
    if inside is not None:
        k, s, depth = inside
        return (f"between the points where contact is imposed the rod enters the "
                f"{scene.obstacles[k].describe()} by {depth:.2g} rod lengths at s = {s:.4g}")
    if self_inside is not None:
        s, t, depth = self_inside
        return (f"between the points where contact is imposed the rod enters itself by {depth:.2g} rod "
                f"lengths (s = {s:.4g} against s = {t:.4g})")
    return None
