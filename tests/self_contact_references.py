"""Independent reference for self-contact tests: a coiled strip (bending stiffness b(s), tip moment
M) whose turns press on each other, by shooting with the contact conditions written out (scipy's
DOP853 and a root finder; nothing of the package's transcription).

Along the rod m = b θ', m' = −t × n, r' = t, with n(s) the sum of the contact forces beyond s. A
self-contact is a pair of points (a, b) a distance 2·gap apart along their common normal: the force
F ν on b and −F ν on a, ν = (r_b − r_a)/(2 gap) the normal of the rod at a and at b (frictionless;
at a tip only at the point on the body). Each pair's forces are equal, opposite and along the line
joining them, so m(0) = M and the pairs add nothing to the tip's moment balance.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root


def coil_reference(stiffness, M: float, gap: float, pairs, guess_s, guess_f, walls=(), guess_walls=()):
    """Shooting for a strip with the given self-contact pairs (and wall contacts).

    Parameters
    ----------
    stiffness : callable s -> b(s)
    M : float
        Tip moment (counter-clockwise; the strip coils to its left).
    gap : float
        Half-thickness: a contact pair is 2·gap apart, and the centre line a gap from a wall.
    pairs : sequence of (bool,)
        Per contact, whether its inner end is the tip (``True``: unknowns s_a only) or an interior
        point (``False``: s_a and s_b).
    guess_s : sequence of float
        Arc lengths of the contact points, in the order (s_a, [s_b]) per pair.
    guess_f : sequence of float
        Force magnitudes per pair.
    walls : sequence of ((px, py), normal_angle)
        Walls the rod presses on at one interior point each: a force F ν along the wall's normal ν
        at s_w, where the centre line is a gap from the wall and tangent to it; the clamp moment
        m(0) is then an unknown too (m(1) = M).
    guess_walls : sequence of (s_w, F_w)

    Returns
    -------
    dict with ``s`` (the contact arc lengths, as in ``guess_s``), ``force`` (per pair), ``walls``
    ((s_w, F_w) per wall), ``tip`` (x, y, θ at s = 1), ``moment_at_tip`` and the residual of the
    conditions.
    """
    n_s, n_f = len(guess_s), len(guess_f)
    nus = [np.array([math.cos(a), math.sin(a)]) for _, a in walls]

    def unpack(v):
        s, f, out, k = v[:n_s], v[n_s:n_s + n_f], [], 0
        for tip in pairs:
            out.append((s[k], 1.0 if tip else s[k + 1], f[len(out)]))
            k += 1 if tip else 2
        w = v[n_s + n_f:n_s + n_f + 2 * len(walls)]
        return out, [(w[2 * j], w[2 * j + 1]) for j in range(len(walls))], (v[-1] if walls else M)

    def shoot(v):
        contacts, at_walls, m0 = unpack(v)
        # events in order of arc length: at a, the pair's normal ν is fixed (the rod's left normal);
        # between a and b the internal force carries F ν (the force on b; −F ν at a cancels it below a);
        # a wall's force F_w ν_w acts on everything before s_w
        marks = sorted([(a, "a", q) for q, (a, b, f) in enumerate(contacts)]
                       + [(b, "b", q) for q, (a, b, f) in enumerate(contacts) if b < 1.0]
                       + [(sw, "w", j) for j, (sw, fw) in enumerate(at_walls)])
        n = sum((fw * nus[j] for j, (_, fw) in enumerate(at_walls)), np.zeros(2))
        normals, state = {}, np.array([0.0, m0, 0.0, 0.0])
        s0, at = 0.0, {}

        def rhs(s, u):
            th, m = u[0], u[1]
            t = (math.cos(th), math.sin(th))
            return [m / stiffness(s), -(t[0] * n[1] - t[1] * n[0]), t[0], t[1]]

        for s1, kind, q in marks + [(1.0, "end", None)]:
            if s1 > s0:
                sol = solve_ivp(rhs, (s0, s1), state, method="DOP853", rtol=1e-13, atol=1e-13)
                state = sol.y[:, -1]
            s0 = s1
            at[(kind, q)] = state.copy()
            if kind == "a":
                th = state[0]
                normals[q] = np.array([-math.sin(th), math.cos(th)])
                n = n + contacts[q][2] * normals[q]
            elif kind == "b":
                n = n - contacts[q][2] * normals[q]
            elif kind == "w":
                n = n - at_walls[q][1] * nus[q]
        return contacts, normals, at

    def residual(v):
        contacts, normals, at = shoot(v)
        out = []
        for q, (a, b, f) in enumerate(contacts):
            ra = at[("a", q)][2:]
            ub = at[("end", None)] if b == 1.0 else at[("b", q)]
            out += list(ub[2:] - ra - 2.0 * gap * normals[q])
            if b < 1.0:  # an interior point: the rod at b is tangent to the rod at a
                out.append(math.cos(ub[0]) * normals[q][0] + math.sin(ub[0]) * normals[q][1])
        for j, ((px, py), _) in enumerate(walls):
            u = at[("w", j)]
            out += [(u[2] - px) * nus[j][0] + (u[3] - py) * nus[j][1] - gap,
                    math.cos(u[0]) * nus[j][0] + math.sin(u[0]) * nus[j][1]]
        if walls:
            out.append(at[("end", None)][1] - M)
        return out

    guess = list(guess_s) + list(guess_f) + [v for w in guess_walls for v in w] + ([M] if walls else [])
    sol = root(residual, guess, method="hybr", options={"xtol": 1e-14})
    contacts, _, at = shoot(sol.x)
    end = at[("end", None)]
    w = sol.x[n_s + n_f:n_s + n_f + 2 * len(walls)]
    return {"s": list(sol.x[:n_s]), "force": list(sol.x[n_s:n_s + n_f]),
            "walls": [(w[2 * j], w[2 * j + 1]) for j in range(len(walls))], "tip": (end[2], end[3], end[0]),
            "moment_at_tip": end[1], "residual": float(np.max(np.abs(residual(sol.x))))}


def free_coil_touch(stiffness_rate: float, gap: float, lo: float, hi: float) -> float:
    """The tip moment at which the free coil b(s) = exp(−k s) (no contact: θ(s) = M (e^{k s} − 1)/k)
    first comes within 2·gap of itself, between points at least 2π·gap apart along it: Brent's
    method on the least distance of the curve, integrated by DOP853 and minimised over both points."""
    from scipy.optimize import brentq, minimize
    from scipy.spatial import cKDTree

    k = stiffness_rate
    s = np.linspace(0.0, 1.0, 4001)

    def least(M):
        sol = solve_ivp(lambda u, r: [math.cos(M * (math.exp(k * u) - 1) / k), math.sin(M * (math.exp(k * u) - 1) / k)],
                        (0.0, 1.0), [0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
        pts = sol.sol(s).T
        pairs = cKDTree(pts).query_pairs(0.2, output_type="ndarray")
        pairs = pairs[np.abs(s[pairs[:, 0]] - s[pairs[:, 1]]) >= 2 * math.pi * gap]
        d = np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T)
        i, j = pairs[int(np.argmin(d))]

        def d2(v):
            a, b = sol.sol(v[0]), sol.sol(v[1])
            return float(np.sum((a - b) ** 2))
        h = 2.0 / (s.size - 1)
        out = minimize(d2, [s[i], s[j]], method="L-BFGS-B", options={"ftol": 1e-16, "gtol": 1e-15},
                       bounds=[(max(0.0, s[i] - h), min(1.0, s[i] + h)), (max(0.0, s[j] - h), min(1.0, s[j] + h))])
        return math.sqrt(out.fun) - 2 * gap

    return brentq(least, lo, hi, xtol=1e-13)


def tip_on_body_reference(h_r: float, beta, phi: float, gap: float, side: float, guess, shape):
    """A uniform hard-magnetic strip (THEORY §9: energy ∫ ½θ'² − h_r cos(θ + β(s) − φ)) whose tip
    presses on its own body at one point s_a, by scipy's ``solve_bvp`` (its clamp layer, ~e^{−√h_r s},
    defeats single shooting): a force F ν on the tip and −F ν on the body at s_a, ν =
    side·(−sin θ_a, cos θ_a) the body's normal there (frictionless), the tip 2·gap from the body along
    it. Along the rod m = θ', m' = −t × n + h_r sin(θ + β − φ), r' = t, with n = F ν beyond s_a and 0
    before it; θ(0) = 0, m(1) = 0 (a free end). The two stretches [0, s_a] and [s_a, 1] are each mapped
    onto τ ∈ [0, 1]; s_a, F and θ_a = θ(s_a) are the problem's unknown parameters.

    Parameters
    ----------
    beta : callable s -> β(s) (rad), vectorised
    side : +1 or −1
        Which side of the body the tip lies on (the body's left normal: +1).
    guess : (s_a, F)
    shape : callable s -> (θ, θ', x, y), vectorised: the starting guess of the state.

    Returns
    -------
    dict with ``s_a``, ``force``, ``clamp_moment`` (m(0)), ``tip`` (x, y, θ at s = 1), ``status`` and
    ``rms`` (solve_bvp's largest relative residual).
    """
    from scipy.integrate import solve_bvp

    def part(s, u, n, length):
        th, m = u[0], u[1]
        return length * np.vstack([m, -(np.cos(th) * n[1] - np.sin(th) * n[0]) + h_r * np.sin(th + beta(s) - phi),
                                   np.cos(th), np.sin(th)])

    def rhs(tau, u, p):
        s_a, force, th_a = p
        nu = side * np.array([-np.sin(th_a), np.cos(th_a)])
        return np.vstack([part(s_a * tau, u[:4], np.zeros(2), s_a),
                          part(s_a + (1.0 - s_a) * tau, u[4:], force * nu, 1.0 - s_a)])

    def bc(ua, ub, p):
        s_a, force, th_a = p
        nu = side * np.array([-np.sin(th_a), np.cos(th_a)])
        return np.concatenate([[ua[0], ua[2], ua[3]], ua[4:] - ub[:4], [ub[5]],
                               ub[6:8] - ub[2:4] - 2.0 * gap * nu, [ub[0] - th_a]])

    s_a, force = guess
    tau = np.linspace(0.0, 1.0, 801)
    u0 = np.vstack([np.vstack(shape(s_a * tau)), np.vstack(shape(s_a + (1.0 - s_a) * tau))])
    th_a = float(shape(np.array([s_a]))[0][0])
    sol = solve_bvp(rhs, bc, tau, u0, p=[s_a, force, th_a], tol=1e-10, max_nodes=200000)
    end = sol.sol(1.0)[4:]
    return {"s_a": float(sol.p[0]), "force": float(sol.p[1]), "clamp_moment": float(sol.sol(0.0)[1]),
            "tip": (float(end[2]), float(end[3]), float(end[0])), "status": int(sol.status),
            "rms": float(np.max(sol.rms_residuals))}
