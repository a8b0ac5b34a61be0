"""Where a solved shape comes nearest an obstacle or itself: the points the split rounds of
:func:`~actuator_design.contact.equilibrium.solve_contact` put element boundaries at.

Both are roots of a first derivative of a distance along the shape, found by Newton's method with
the exact second derivative on one smooth piece of the shape at a time: θ' kinks at element
boundaries (a contact's point force), where Newton's method across the kink converges only
linearly, so the pieces end at the mesh's nodes.
"""
from __future__ import annotations

from typing import Tuple

import numpy as np

from actuator_design.contact.obstacles import distance_jet

__all__ = ["nearest_point", "nearest_pair", "GRID", "LOCAL", "ROOT_STEP", "CURVATURE_FLOOR", "ROOT_ITERATIONS"]

#: points of the grid :func:`nearest_point` brackets the least distance on (one vectorised evaluation)
GRID = 65
#: half-width (arc length) of the bracket :func:`nearest_point` tries first about the contact point
LOCAL = 4e-3
#: the searches stop after a Newton step this small (arc length; the error is then ~ its square),
#: or where bisections narrowed the bracket to it
ROOT_STEP = 1e-10
#: :func:`nearest_pair`'s Hessian is shifted to at least this curvature (φ's is ~1 across the
#: turns' common normal): a flatter valley is followed by steps up to the box's faces
CURVATURE_FLOOR = 1e-3
#: a safeguard on the steps of either search (each step at least halves a bracket or decreases a
#: distance; bisection alone reaches ROOT_STEP from a grid bracket in ~25)
ROOT_ITERATIONS = 100


def nearest_point(scene, result, point: dict, local: bool = True) -> float:
    """The arc length of the shape's point nearest the obstacle of a contact ``point``, within half
    an element of it: the root of the distance's slope f(s) = ∇d(r(s))·t(s) next to the least
    distance on a grid (a sign change, from approaching to leaving), else (the least distance at an
    end of the interval, a kink) the bounded minimum of the distance near that grid point.

    With ``local`` (a contact point: its distance is the gap, the least in its window) the root is
    bracketed first within :data:`LOCAL` of it (where the round before put an element boundary at
    its nearest point, the new one is that close): the local minimum of the distance there; else
    (and where that bracket holds no sign change, or for a point where the shape enters an obstacle,
    whose deepest point in the window is wanted) on the grid (one evaluation of the shape); the
    bracket is narrowed to one
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

    # a contact at the element boundary the round before put at its nearest point is within ~1e-3
    # of the new one: where the slope changes sign across a bracket that close, the grid is spared
    # (the point itself too: a node, where θ' kinks, so the bracket's halves are smooth pieces)
    near = np.array([max(lo, point["s"] - LOCAL), min(max(lo, point["s"]), hi), min(hi, point["s"] + LOCAL)])
    f = slope(near)[0] if local else np.zeros(3)
    if f[0] < 0.0 < f[2]:
        k = 1 if f[1] >= 0.0 else 2
        a, b, fa, fb = near[k - 1], near[k], f[k - 1], f[k]
    else:
        grid = np.linspace(lo, hi, GRID)
        e = result.evaluate(grid)
        i = int(np.argmin(np.asarray(ob.distance(e["x"], e["y"]), float)))
        ia, ib = max(i - 1, 0), min(i + 1, GRID - 1)
        a, b = grid[ia], grid[ib]
        f = slope(grid[ia:ib + 1])[0]
        fa = fb = None
        if f[0] < 0.0 < f[-1]:
            k = 1 + int(np.argmax(f[1:] >= 0.0))  # the first point past the crossing
            a, b, fa, fb = grid[ia + k - 1], grid[ia + k], f[k - 1], f[k]
    if fa is not None:
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


def nearest_pair(result, s_a: float, s_b: float, half: float) -> Tuple[float, float]:
    """The pair of arc lengths nearest each other on ``result``'s shape near (``s_a``, ``s_b``),
    each within ``half`` of its start (the tip stays the tip): where a self-contact's two element
    boundaries go; sorted.

    The local minimum of φ(a, b) = |r(a) − r(b)|²/2 from the start, by Newton's method projected
    on a box (bounds with the gradient pushing out held), with the exact gradient
    (d·t_a, −d·t_b) and Hessian [[1 + θ'_a d·n_a, −t_a·t_b], [−t_a·t_b, 1 − θ'_b d·n_b]]
    (d = r(a) − r(b), t the tangents, n the normals) and a backtracking line search. The box is one
    piece between the mesh's nodes in each variable; at a face that is a node, with the gradient
    pointing across it, the search goes on in the next piece. Between two nearly parallel turns
    φ has a valley flat to ~1e-6: the gradient's exact form (not differences of φ) fixes the
    minimum along it."""
    nodes = np.asarray(result.s, float)
    lo = np.array([max(1e-9, s_a - half), max(1e-9, s_b - half)])
    hi = np.array([min(1.0, s_a + half), min(1.0, s_b + half)])

    def jet(v: np.ndarray):
        e = result.evaluate(v)
        d = np.array([e["x"][0] - e["x"][1], e["y"][0] - e["y"][1]])
        c, s = np.cos(e["theta"]), np.sin(e["theta"])
        along = c[0] * c[1] + s[0] * s[1]
        H = np.array([[1.0 + e["dtheta"][0] * (d[1] * c[0] - d[0] * s[0]), -along],
                      [-along, 1.0 - e["dtheta"][1] * (d[1] * c[1] - d[0] * s[1])]])
        return 0.5 * float(d @ d), np.array([d[0] * c[0] + d[1] * s[0], -(d[0] * c[1] + d[1] * s[1])]), H

    def piece(x: float, i: int, descend: float) -> Tuple[float, float]:
        """The node interval holding ``x`` (on a node: the one ``descend`` points into), within
        the window of variable ``i``."""
        k = int(np.searchsorted(nodes, x, side="right")) - 1
        if k >= 0 and nodes[k] == x and descend < 0.0:
            k -= 1
        k = min(max(k, 0), nodes.size - 2)
        return max(nodes[k], lo[i]), min(nodes[k + 1], hi[i])

    v = np.clip([float(s_a), float(s_b)], lo, hi)
    phi, g, H = jet(v)
    box = np.array([piece(v[i], i, -g[i]) for i in range(2)])
    for _ in range(ROOT_ITERATIONS):
        for i in range(2):  # on a face that is a node, the gradient pointing across: the next piece
            if ((v[i] <= box[i, 0] and g[i] > 0.0 and box[i, 0] > lo[i])
                    or (v[i] >= box[i, 1] and g[i] < 0.0 and box[i, 1] < hi[i])):
                box[i] = piece(v[i], i, -g[i])
        held = ((v <= box[:, 0]) & (g > 0.0)) | ((v >= box[:, 1]) & (g < 0.0))  # at the window's ends
        if np.all(held):
            break
        p = _newton_step(H, g, ~held)
        out = ~held & (((v <= box[:, 0]) & (p < 0.0)) | ((v >= box[:, 1]) & (p > 0.0)))
        if np.any(out):  # Newton's step leaves the box where the gradient does not: held there too
            p = _newton_step(H, g, ~held & ~out) if np.any(~held & ~out) else np.where(held, 0.0, -g)
        # the step cut where it first meets a face of the box, then backtracking along it
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(p > 0.0, (box[:, 1] - v) / p, np.where(p < 0.0, (box[:, 0] - v) / p, np.inf))
        first = int(np.argmin(room))
        t, moved, cut = min(1.0, float(room[first])), 0.0, room[first] <= 1.0
        if cut and t < ROOT_STEP:  # a face within round-off of the start (a grid point one ulp off
            v = v.copy()           # a node): onto it, and on from there
            v[first] = box[first, 1] if p[first] > 0.0 else box[first, 0]
            phi, g, H = jet(v)
            continue
        while t >= ROOT_STEP:
            trial = np.clip(v + t * p, box[:, 0], box[:, 1])
            if cut:  # exactly on the face it meets (a node: the next piece's end)
                trial[first] = box[first, 1] if p[first] > 0.0 else box[first, 0]
            phi_t, g_t, H_t = jet(trial)
            if phi_t <= phi + 1e-4 * float(g @ (trial - v)):
                moved = float(np.max(np.abs(trial - v)))
                v, phi, g, H = trial, phi_t, g_t, H_t
                break
            t, cut = 0.5 * t, False
        if moved <= ROOT_STEP and not cut:
            break
    a, b = (float(x) for x in v)
    return (a, b) if a <= b else (b, a)


def _newton_step(H: np.ndarray, g: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Newton's step in the ``free`` variables (the others held), its Hessian shifted to at least
    :data:`CURVATURE_FLOOR`: at a saddle (two turns sliding along each other, φ falling along its
    valley) a long step down the valley, which the box cuts."""
    p = np.zeros(g.size)
    Hf = H[np.ix_(free, free)]
    least = float(np.linalg.eigvalsh(Hf)[0])
    if least < CURVATURE_FLOOR:
        Hf = Hf + (CURVATURE_FLOOR - least) * np.eye(Hf.shape[0])
    p[free] = -np.linalg.solve(Hf, g[free])
    return p
