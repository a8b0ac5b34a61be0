"""Self-contact (issue 20 item 3): a rod that would cross itself, solved with |r(s) − r(t)| ≥ 2·gap.

The rod's centre line keeps twice its half-thickness (``Scene.contact_gap``) from itself between
points that are not neighbours along it: arc lengths |s − t| ≥ :func:`neighbour_arc` apart. Two
points closer in arc than π·gap cannot be 2·gap apart without the rod bending tighter than its own
half-thickness, so those pairs are never constrained.

The constraint is imposed between pairs of the contact NLP's constrained points and the clamp
(:mod:`actuator_design.contact.equilibrium`), chosen from the state the solve starts from
(:func:`candidate_pairs`: where the rod comes within 2·gap + :data:`REACH` of itself, the nearest
pair of each place, at most :data:`SLOTS`; in a split round, the points the boundaries were moved
to). A pair's row

    c(a, b) = (|r_a − r_b|² − (2 gap)²) / (4 gap) ≥ 0

has the unit normal as its gradient at contact, so its multiplier is the contact force (units of
B0/ℓ²), pushing r_a away from r_b and r_b away from r_a. A corner (the tip or the clamp) pressing
on a body point that an element boundary was put at keeps instead to the body point's tangent line
(:func:`~actuator_design.contact.contact_nlp.corner_body`). As with obstacles, a contact point inside
an element becomes an element boundary on *both* sides (:func:`~actuator_design.contact.nearest.nearest_pair`), and the solve is
repeated until the pair stays put, so the point-to-point rows meet the point-to-curve contact;
what tangential force a pair still carries (:func:`tangential_force`) is checked against the
residual limit.

A state reached from rest is what a user builds on: the loads are ramped from zero
(:func:`~actuator_design.contact.self_solve.solve_self_contact`), each step warm-started from the one before with the pairs near it
constrained, so the rod stays on the side of itself it came from.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import List, Optional, Tuple

import numpy as np

from actuator_design.config.limits import mesh_problem
from actuator_design.contact.clearance import constrained_points
from actuator_design.equilibrium.accuracy import MAX_ELEMENTS
from actuator_design.equilibrium.options import MAX_SPLITS
from actuator_design.transcription.lgl import lgl_nodes_weights

__all__ = ["neighbour_arc", "candidate_pairs", "self_penetration", "tangential_force",
           "least_self_clearance", "grown_pairs", "boundary_pairs", "SLOTS", "REACH",
           "GROW_ROUNDS", "SELF_SPACING", "SELF_MAX_NODES", "self_contact_mesh", "spacing_note"]

#: pairs of constrained points a self-contact NLP carries (rows; unused ones are unbounded)
SLOTS = 8
#: pairs closer than 2·gap + REACH (rod lengths) in the start state are constrained
REACH = 0.1
#: samples of :func:`self_penetration`'s coarse pass
COARSE = 201


def neighbour_arc(gap: float) -> float:
    """Arc length (units of ℓ) below which two points of the rod are neighbours, never a contact
    pair: 2π·gap (a hairpin of radius gap brings points π·gap apart in arc to 2·gap)."""
    return 2.0 * math.pi * gap


def candidate_pairs(s: np.ndarray, x: np.ndarray, y: np.ndarray, gap: float, reach: float = REACH,
                    slots: int = SLOTS, spread: int = 0) -> List[Tuple[int, int]]:
    """Index pairs (i < j) of points (arc lengths ``s``, increasing; positions ``x, y``, units of ℓ)
    to constrain: the local minima of the distance over the grid of non-neighbouring pairs closer
    than 2·gap + ``reach``, one per :func:`neighbour_arc` of arc on both sides (one pair per place
    where the rod comes near itself: the rows of nearby pairs are nearly dependent, and as separate
    constraints they split one contact force between them and over-constrain the stability
    verdict), each with the pairs ``spread`` points along either side (a contact sliding within a
    step stays constrained), the closest first, at most ``slots``."""
    pts = np.column_stack([x, y])
    if not np.all(np.isfinite(pts)) or len(pts) < 2:
        return []
    cand = _kdtree(pts).query_pairs(2.0 * gap + reach, output_type="ndarray")
    if cand.size == 0:
        return []
    cand = np.sort(cand[np.abs(s[cand[:, 0]] - s[cand[:, 1]]) >= neighbour_arc(gap)], axis=1)
    n = len(s)
    d = np.hypot(*(pts[cand[:, 0]] - pts[cand[:, 1]]).T)
    # the grid of pairs, bordered: a candidate's distance; a pair of neighbours along the rod is
    # nearer (the distance falls towards them: no minimum at the edge), −inf; out of reach or off
    # the grid, +inf
    grid = np.full((n + 2, n + 2), np.inf)
    grid[1:-1, 1:-1][np.abs(s[:, None] - s[None, :]) < neighbour_arc(gap)] = -np.inf
    grid[cand[:, 0] + 1, cand[:, 1] + 1] = d
    i, j = cand[:, 0] + 1, cand[:, 1] + 1
    minimum = (d <= grid[i - 1, j]) & (d <= grid[i + 1, j]) & (d <= grid[i, j - 1]) & (d <= grid[i, j + 1])
    order = np.flatnonzero(minimum)[np.argsort(d[minimum], kind="stable")]

    def is_candidate(q):
        return 0 <= q[0] < n and 0 <= q[1] < n and np.isfinite(grid[q[0] + 1, q[1] + 1])

    chosen: List[Tuple[int, int]] = []
    centres: List[Tuple[int, int]] = []
    window = neighbour_arc(gap)
    for i, j in (tuple(int(v) for v in cand[k]) for k in order):
        # along a valley of the distance (two turns side by side) every node pair is a minimum:
        # one per stretch of ``window`` of arc on both sides
        if any(abs(s[i] - s[a]) < window and abs(s[j] - s[b]) < window for a, b in centres):
            continue
        centres.append((i, j))
        for q in [(i, j)] + [(i + k, j) for k in range(-spread, spread + 1) if k] \
                + [(i, j + k) for k in range(-spread, spread + 1) if k]:
            if is_candidate(q) and q not in chosen:
                chosen.append(q)
    return chosen[:slots]


#: the widest spacing of the constrained points a self-contact solve allows, in units of the gap: a
#: pair row holds two points 2·gap apart, and between two body points h apart another point of the
#: rod (its tip) can sink 2·gap − √(4 gap² − h²/4) into the body — all the way through at h = 4·gap
#: (a strip 0.006 thick on 4 elements, points 0.037 apart, did); at 3·gap 0.68·gap, within the one
#: gap the ramp from rest allows (:mod:`actuator_design.contact.self_solve`)
SELF_SPACING = 3.0


def self_contact_mesh(scene, options):
    """``options`` with enough LGL elements that the constrained points of its mesh are at most
    :data:`SELF_SPACING` × ``scene.contact_gap`` apart (the widest LGL gap of an element of length
    1/E, the longest: grading and contact boundaries only shorten elements), at most
    :data:`~actuator_design.equilibrium.accuracy.MAX_ELEMENTS`, :data:`SELF_MAX_NODES` and what the memory budget allows
    (:func:`~actuator_design.config.limits.mesh_problem`; a thinner strip than that is solved on the
    finest mesh allowed, and its dense check says if it enters itself); ``options`` itself for the
    midpoint rule, with ``adapt`` off (the mesh is the user's), or when it is fine enough."""
    if options.transcription != "lgl" or not options.adapt or not scene.contact_gap > 0:
        return options
    widest = _widest_lgl_gap(int(options.degree))
    need = min(MAX_ELEMENTS, SELF_MAX_NODES // int(options.degree),
               int(math.ceil(widest / (SELF_SPACING * scene.contact_gap))))
    # within the memory budget, with room for the grading and the contact points' boundaries
    extra = int(options.clamp_levels) + int(options.tip_levels) + MAX_SPLITS + GRADING_ROOM
    while need > options.elements and mesh_problem("lgl", need + extra, int(options.degree)) is not None:
        need = max(int(options.elements), need * 9 // 10)
    return options if need <= options.elements else replace(options, elements=need)


def _widest_lgl_gap(degree: int) -> float:
    """The widest gap between the LGL nodes of an element of unit length (the longest elements of a
    mesh of E are 1/E long: grading and contact boundaries only shorten elements)."""
    return float(np.max(np.diff(lgl_nodes_weights(degree)[0]))) / 2.0


#: grading levels :func:`~actuator_design.equilibrium.acceptance.graded_options` may still add
GRADING_ROOM = 8
#: most nodes a self-contact mesh is given (its IPOPT Hessian is dense, and each boundary round
#: builds a new NLP: a curled strip on 200 elements of degree 10 took over 1500 s and 3.8 GB, on 50
#: elements 131 s); a thinner strip than this resolves is solved on it and told
#: (:func:`spacing_note`)
SELF_MAX_NODES = 300


def spacing_note(scene, options) -> Optional[str]:
    """What to know when the constrained points of ``options``' mesh lie farther apart than
    :data:`SELF_SPACING` half-thicknesses (the rod is thinner than the finest self-contact mesh
    allowed), or None."""
    if options.transcription != "lgl" or not scene.contact_gap > 0:
        return None
    widest = _widest_lgl_gap(int(options.degree)) / int(options.elements)
    if widest <= SELF_SPACING * scene.contact_gap:
        return None
    return (f"the points where self-contact is imposed lie up to {widest:.3g} apart, more than "
            f"{SELF_SPACING:g} half-thicknesses ({SELF_SPACING * scene.contact_gap:.3g}): between them the rod "
            "may pass through itself (a rod this thin needs more elements than a self-contact solve takes)")


#: times a self-contact solve is repeated with the pairs it passed through added (:func:`grown_pairs`)
GROW_ROUNDS = 3


def grown_pairs(nlp, gap: float, z: np.ndarray, pairs) -> Optional[tuple]:
    """``pairs`` with those of the solved constrained points ``z`` that came closer than 2·gap
    without a row (the solve moved the rod through itself where its start was clear: the start's
    pairs are only those near each other there, :func:`candidate_pairs`), or None
    when there are none or no free slot."""
    X, Y = (np.concatenate([[0.0], np.asarray(v, float).ravel()]) for v in nlp.f_xy(z))
    inside = [q for q in candidate_pairs(nlp.s_self, X, Y, gap, reach=0.0, slots=nlp.slots)
              if q not in pairs and np.hypot(X[q[0]] - X[q[1]], Y[q[0]] - Y[q[1]]) < 2.0 * gap * (1.0 - 1e-6)]
    room = nlp.slots - len(pairs)
    if not inside or room <= 0:
        return None
    return tuple(pairs) + tuple(inside[:room])


def boundary_pairs(s_self: np.ndarray, splits, state) -> list:
    """Index pairs (into ``s_self``: the clamp, then the constrained points) of the element
    boundaries put at ``state``'s self-contacts (each end at the boundary, the clamp or the tip
    nearest it): a split round constrains exactly the points it moved the boundaries to. The
    nearest node pair of the start may be a neighbouring node (LGL nodes crowd at an element's
    ends), and a force there lands up to ~1e-3 off its contact."""
    if state is None or not (state.contact or {}).get("self_contact"):
        return []
    ends = np.concatenate([[0.0, 1.0], np.asarray(splits, float)])
    out = []
    for p in state.contact["points"]:
        if not p.get("self") or p["weak"] or p["s"] > p["partner_s"]:
            continue
        q = []
        for s in (p["s"], p["partner_s"]):
            b = ends[int(np.argmin(np.abs(ends - s)))]
            i = int(np.argmin(np.abs(s_self - b)))
            if abs(b - s) > 1e-2 or abs(s_self[i] - b) > 1e-9:
                break
            q.append(i)
        if len(q) == 2 and q[0] != q[1] and tuple(sorted(q)) not in out:
            out.append(tuple(sorted(q)))
    return out


def self_penetration(state, gap: float, n: int = 2001, tol: float = 1e-6) -> Optional[Tuple[float, float, float]]:
    """Where a solved ``state`` comes closer to itself than 2·gap (by more than ``tol``) between
    non-neighbouring points, sampled at ``n`` points: (s, t, depth) of the deepest such pair (arc
    lengths s < t and the depth, units of ℓ), or None.

    A coarse pass first (:data:`COARSE` points, spacing h) settles most shapes: every point of the
    rod is within h/2 of a sample, so two samples farther apart than 2·gap − tol + h leave their
    stretches farther apart than 2·gap − tol."""
    coarse = state.evaluate(np.linspace(0.0, 1.0, COARSE))
    pts = np.column_stack([coarse["x"], coarse["y"]])
    if np.all(np.isfinite(pts)):
        h = 1.0 / (COARSE - 1)
        cand = _kdtree(pts).query_pairs(2.0 * gap - tol + h, output_type="ndarray")
        if cand.size == 0 or not np.any(np.abs(coarse["s"][cand[:, 0]] - coarse["s"][cand[:, 1]])
                                        >= neighbour_arc(gap) - h):
            return None
    d = state.evaluate(np.linspace(0.0, 1.0, n))
    pts = np.column_stack([d["x"], d["y"]])
    if not np.all(np.isfinite(pts)):
        return None
    cand = _kdtree(pts).query_pairs(2.0 * gap - tol, output_type="ndarray")
    if cand.size == 0:
        return None
    cand = cand[np.abs(d["s"][cand[:, 0]] - d["s"][cand[:, 1]]) >= neighbour_arc(gap)]
    if cand.size == 0:
        return None
    dist = np.hypot(*(pts[cand[:, 0]] - pts[cand[:, 1]]).T)
    i, j = sorted(cand[int(np.argmin(dist))])
    return float(d["s"][i]), float(d["s"][j]), float(2.0 * gap - dist.min())


def tangential_force(result) -> Optional[Tuple[float, float, float]]:
    """The largest tangential (friction-like) force of ``result``'s self-contacts (units of B0/ℓ²)
    and where (s_a, s_b), or None without self-contacts.

    A pair's point row pushes along the line d̂ between its two points, which is the normal of both
    turns only where they are the nearest points of the two (frictionless contact); off it, the
    force has a tangential part |F| max(|d̂·t|) over its interior ends (the tip and the clamp are
    corners) that the moment balance cannot see, as it balances the force it is given. A corner
    pair's plane row (:func:`~actuator_design.contact.contact_nlp.corner_body`) pushes along the
    body's normal, and the same |F| |d̂·t| measures the couple F (r_corner − r_body)·t its row
    puts on the body point, over |r_corner − r_body|: zero where the body point is the corner's
    nearest."""
    pts = [p for p in (result.contact or {}).get("points", [])
           if p.get("self") and not p["weak"] and p["s"] < p["partner_s"]]
    worst = None
    for p in pts:
        e = result.evaluate(np.array([p["s"], p["partner_s"]]))
        d = np.array([e["x"][1] - e["x"][0], e["y"][1] - e["y"][0]])
        d /= max(float(np.hypot(*d)), 1e-300)
        # the force is normal to the rod at an interior end; the tip and the clamp are corners
        ends = [k for k, s in enumerate((p["s"], p["partner_s"])) if 0.0 < s < 1.0]
        tau = max((abs(d @ [np.cos(e["theta"][k]), np.sin(e["theta"][k])]) for k in ends), default=0.0)
        f = abs(p["multiplier"]) * tau
        if worst is None or f > worst[0]:
            worst = (f, p["s"], p["partner_s"])
    return worst


def least_self_clearance(solver, gap: float):
    """θ at the nodes of ``solver``'s mesh (rad, shape (nodes,)) → the least |r(s) − r(t)| − 2·gap
    over the non-neighbouring pairs of its constrained points and the clamp (units of ℓ; +inf when
    no pair is far enough apart along the rod): the event function of a branch's first self-touch."""
    import casadi as ca

    z = ca.SX.sym("z", solver.transcription.nodes.size)
    X, Y, s_points, _ = constrained_points(solver.transcription, z)
    f_xy = ca.Function("points", [z], [X, Y])
    s = np.concatenate([[0.0], s_points])
    far = np.triu(np.abs(s[:, None] - s[None, :]) >= neighbour_arc(gap), 1)

    def least(theta) -> float:
        x, y = (np.concatenate([[0.0], np.asarray(v, float).ravel()]) for v in f_xy(np.asarray(theta, float)))
        d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])[far]
        return float(np.min(d, initial=np.inf)) - 2.0 * gap
    return least


def _kdtree(points: np.ndarray):
    """scipy's k-d tree of ``points``, shape (n, 2); imported on first use, since most scenes never
    come near themselves and scipy.spatial would otherwise be loaded with every continuation."""
    from scipy.spatial import cKDTree

    return cKDTree(points)
