"""Independent reference for contact tests: a penalty formulation on a discrete rod (nothing of the
package's transcription, contact rows or split rounds).

The rod is N straight segments of length 1/N with angles θ_1..θ_N (the clamp at the origin, its
tangent at angle ``theta0``); the energy is

    E = Σ (θ_i − θ_{i−1})² / (2 Δs)  (θ_0 = theta0 over half a segment at the clamp)
        − h_r Σ Δs m̂(θ_i) · ĥ(r_i^mid)              (hard-magnetic, THEORY §9; β = 0)
        + k Σ_points [max(0, R + gap − |r − c|)]²     (the rod's surface against a peg)
        + k Σ_pairs  [max(0, 2 gap − |r_a − r_b|)]²   (the rod against itself, points far apart
                                                       along it: |s_a − s_b| ≥ 2π gap)

at the nodes and the segment midpoints, minimised by IPOPT with exact derivatives (CasADi), from a
given shape, the penalty ``k`` raised until the penetration ~ force / k is below round-off of
interest. As k → ∞ its minimisers tend to the frictionless contact equilibrium, and as N → ∞ to the
rod's; both limits are taken (linear extrapolation in 1/k, Richardson in Δs²).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np


def _points(th, n, theta0):
    """Node positions (n+1 of them, the clamp first) and segment midpoints of angles ``th``."""
    ds = 1.0 / n
    cx, cy = ca.cos(th), ca.sin(th)
    x = ca.vertcat(0.0, ca.cumsum(ds * cx))
    y = ca.vertcat(0.0, ca.cumsum(ds * cy))
    mx, my = x[:-1] + 0.5 * ds * cx, y[:-1] + 0.5 * ds * cy
    return x, y, mx, my


def penalty_equilibrium(n: int, h_r: float, field, peg, gap: float, start, k: float,
                        theta0: float = 0.0, pair_reach: float = 0.05):
    """The penalty minimiser of the discrete rod.

    Parameters
    ----------
    n : int
        Segments.
    h_r : float
        Hard-magnetic group (the magnetisation along the rod, β = 0).
    field : callable (x, y) -> (hx, hy)
        The unit field ĥ, written with CasADi-compatible operations.
    peg : tuple (cx, cy, R)
        A disc the rod's surface stays out of (units of ℓ).
    gap : float
        The rod's half-thickness.
    start : callable s -> θ(s)
        The start shape (its angle at the midpoints of the segments is taken).
    k : float or sequence of float
        Penalty stiffness, raised in the order given (each solve from the last).

    Returns
    -------
    dict: ``theta`` (segment angles), ``tip`` (x, y, angle of the last segment), ``energy`` (without
    the penalty terms), ``peg_force`` (the penalty's total force on the peg, (Fx, Fy), B0/ℓ²),
    ``penetration`` (the deepest, units of ℓ), ``status``.
    """
    ds = 1.0 / n
    s_mid = (np.arange(n) + 0.5) * ds
    th = ca.SX.sym("th", n)
    kk = ca.SX.sym("k")
    x, y, mx, my = _points(th, n, theta0)
    bend = (th[0] - theta0) ** 2 / ds + ca.sumsqr(th[1:] - th[:-1]) / (2 * ds)
    hx, hy = field(mx, my)
    magnetic = -h_r * ds * ca.sum1(ca.cos(th) * hx + ca.sin(th) * hy)
    # every point with its arc length: nodes (the clamp excluded: it cannot move) and midpoints
    px = ca.vertcat(x[1:], mx)
    py = ca.vertcat(y[1:], my)
    ps = np.concatenate([np.arange(1, n + 1) * ds, s_mid])
    cx, cy, radius = peg
    into_peg = ca.fmax(0.0, radius + gap - ca.sqrt((px - cx) ** 2 + (py - cy) ** 2))
    # self pairs: far apart along the rod, and near each other in the start (within pair_reach)
    th0 = np.asarray([start(s) for s in s_mid], float)
    fx = ca.Function("xy", [th], [px, py])
    X0, Y0 = (np.asarray(v, float).ravel() for v in fx(th0))
    dist = np.hypot(X0[:, None] - X0[None, :], Y0[:, None] - Y0[None, :])
    far = np.abs(ps[:, None] - ps[None, :]) >= 2 * math.pi * gap
    ia, ib = np.nonzero(np.triu(far & (dist < 2 * gap + pair_reach), 1))
    pen_self = ca.fmax(0.0, 2 * gap - ca.sqrt((px[ia] - px[ib]) ** 2 + (py[ia] - py[ib]) ** 2)) if ia.size else ca.SX(0)
    energy = bend + magnetic
    f = energy + kk * (ca.sumsqr(into_peg) + ca.sumsqr(pen_self))
    nlp = ca.nlpsol("penalty", "ipopt", {"x": th, "p": kk, "f": f},
                    {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-12,
                     "ipopt.max_iter": 3000})
    ks = np.atleast_1d(np.asarray(k, float))
    z, status = th0, ""
    for kv in ks:
        sol = nlp(x0=z, p=kv)
        z = np.asarray(sol["x"], float).ravel()
        status = str(nlp.stats()["return_status"])
    aux = ca.Function("aux", [th], [x[-1], y[-1], energy, into_peg, pen_self, px, py])
    xt, yt, e, ip, ps_, PX, PY = (np.asarray(v, float).ravel() for v in aux(z))
    # the penalty's force on the peg: 2 k δ along the outward normal at each point, summed
    PX, PY = PX, PY
    nx, ny = PX - cx, PY - cy
    nr = np.hypot(nx, ny)
    push = 2 * ks[-1] * ip
    peg_force = (-float(np.sum(push * nx / nr)), -float(np.sum(push * ny / nr)))
    return {"theta": z, "tip": (float(xt[0]), float(yt[0]), float(z[-1])), "energy": float(e[0]),
            "peg_force": peg_force, "penetration": float(max(np.max(ip, initial=0.0), np.max(ps_, initial=0.0))),
            "self_pairs": int(ia.size), "status": status}
