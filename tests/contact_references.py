"""Independent references for contact tests: shooting with the contact conditions written out
(scipy's DOP853 and root finders; nothing of the package's transcription)."""
import math

import numpy as np
from scipy.optimize import brentq

from actuator_design.reference.shooting import ShootingParams, solve_shooting


def floor_reference(p: float, depth: float):
    """The elastica with a downward tip load p whose tip rests on a floor at y = −depth: the floor's
    reaction R (by bisection on the tip height) and the shooting solution with net tip force −p + R."""
    def tip_y(R):
        sol = solve_shooting(ShootingParams(fy=-p + R), gamma_guess=0.0)
        assert sol.converged
        return sol.tip_y + depth

    R = brentq(tip_y, 0.0, p, xtol=1e-14)
    return R, solve_shooting(ShootingParams(fy=-p + R), gamma_guess=0.0)


def peg_reference(f, centre, radius, guess):
    """The elastica with tip force f touching a peg at one interior point, by shooting on
    (θ'(0), s_c, R, ψ): the internal force is f + R ν on [0, s_c] (ν = (cos ψ, sin ψ)) and f beyond;
    the contact point lies on the peg, ν is the peg's normal there, the rod is tangent to the peg,
    and the free end has no moment. Its own right-hand side: θ'' = n_x sin θ − n_y cos θ."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    def rhs(n):
        return lambda s, u: [u[1], n[0] * math.sin(u[0]) - n[1] * math.cos(u[0]), math.cos(u[0]), math.sin(u[0])]

    def shoot(v):
        gamma, sc, R, psi = v
        nu = np.array([math.cos(psi), math.sin(psi)])
        a = solve_ivp(rhs(f + R * nu), (0, sc), [0, gamma, 0, 0], method="DOP853", rtol=1e-13, atol=1e-13)
        b = solve_ivp(rhs(f), (sc, 1), a.y[:, -1], method="DOP853", rtol=1e-13, atol=1e-13)
        return a, b, nu

    def ends(v):
        a, b, nu = shoot(v)
        rc = a.y[2:, -1] - centre
        t = np.array([math.cos(a.y[0, -1]), math.sin(a.y[0, -1])])
        return [np.linalg.norm(rc) - radius, rc @ t, nu[0] * rc[1] - nu[1] * rc[0], b.y[1, -1]]

    out = root(ends, guess, method="hybr", options={"xtol": 1e-13})
    assert max(abs(e) for e in ends(out.x)) <= 1e-10, out.message
    a, b, nu = shoot(out.x)
    assert nu @ (a.y[2:, -1] - centre) > 0  # the peg pushes the rod away from its centre
    return out.x, b.y[:, -1], nu


def peg_and_tip_wall_reference(centre, radius, wall_point, wall_normal, guess):
    """The unloaded elastica pressed at one interior point against a disc (``centre``, ``radius``:
    the rod's surface on a curved wall) and at its tip against a straight wall (the line through
    ``wall_point`` with unit ``wall_normal`` pointing to the free side), by shooting on
    (θ'(0), s_c, R1, ψ, R2): internal force R2 n_w + R1 ν on [0, s_c], R2 n_w beyond; conditions:
    the contact point on the disc with the rod tangent to it and ν its normal, the tip on the wall,
    no moment at the tip."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    centre, wall_point, n_w = (np.asarray(v, float) for v in (centre, wall_point, wall_normal))

    def rhs(n):
        return lambda s, u: [u[1], n[0] * math.sin(u[0]) - n[1] * math.cos(u[0]), math.cos(u[0]), math.sin(u[0])]

    def shoot(v):
        gamma, sc, R1, psi, R2 = v
        nu = np.array([math.cos(psi), math.sin(psi)])
        a = solve_ivp(rhs(R2 * n_w + R1 * nu), (0, sc), [0, gamma, 0, 0], method="DOP853", rtol=1e-13, atol=1e-13)
        b = solve_ivp(rhs(R2 * n_w), (sc, 1), a.y[:, -1], method="DOP853", rtol=1e-13, atol=1e-13)
        return a, b, nu

    def ends(v):
        a, b, nu = shoot(v)
        rc = a.y[2:, -1] - centre
        t = np.array([math.cos(a.y[0, -1]), math.sin(a.y[0, -1])])
        return [np.linalg.norm(rc) - radius, rc @ t, nu[0] * rc[1] - nu[1] * rc[0], b.y[1, -1],
                (b.y[2:, -1] - wall_point) @ n_w]

    out = root(ends, guess, method="hybr", options={"xtol": 1e-13})
    assert max(abs(e) for e in ends(out.x)) <= 1e-10, out.message
    a, b, nu = shoot(out.x)
    assert nu @ (a.y[2:, -1] - centre) > 0 and out.x[4] > 0  # both walls push
    return out.x, b.y[:, -1], nu


def free_shape(f, n: int = 2001):
    """The contact-free elastica with tip force f (θ(0) = 0, no tip moment), by shooting on θ'(0)
    with DOP853: arc lengths and positions (x, y) at ``n`` points."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    rhs = lambda s, u: [u[1], f[0] * math.sin(u[0]) - f[1] * math.cos(u[0]), math.cos(u[0]), math.sin(u[0])]
    s = np.linspace(0.0, 1.0, n)
    tip_moment = lambda g: solve_ivp(rhs, (0, 1), [0, g, 0, 0], method="DOP853", rtol=1e-13, atol=1e-13).y[1, -1]
    g = brentq(tip_moment, -abs(f[1]) - abs(f[0]) - 1.0, abs(f[1]) + abs(f[0]) + 1.0, xtol=1e-15)
    sol = solve_ivp(rhs, (0, 1), [0, g, 0, 0], method="DOP853", rtol=1e-13, atol=1e-13, t_eval=s)
    return s, sol.y[2], sol.y[3]


def touch_load(direction, centre, radius, lo: float, hi: float) -> float:
    """The tip-force magnitude t (force t·direction, the rod free of contact) at which the centre
    line first touches a disc: the root in (lo, hi) of the least distance to ``centre`` less
    ``radius``, sampled at 2001 points (a touch at the tip, where the samples end, is exact)."""
    from scipy.optimize import brentq

    def gap(t):
        _, x, y = free_shape(t * np.asarray(direction, float))
        return float(np.min(np.hypot(x - centre[0], y - centre[1]))) - radius

    return brentq(gap, lo, hi, xtol=1e-14)


def tip_on_peg(psi: float, centre, radius, guess):
    """The elastica with a vertical tip load p whose tip rests on a disc at the polar angle ψ about
    its ``centre`` (frictionless: the reaction R along (cos ψ, sin ψ)), by shooting on
    (θ'(0), R, p): no moment at the tip and the tip at centre + radius·(cos ψ, sin ψ)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    nu = np.array([math.cos(psi), math.sin(psi)])

    def ends(v):
        gamma, R, p = v
        f = np.array([0.0, p]) + R * nu
        rhs = lambda s, u: [u[1], f[0] * math.sin(u[0]) - f[1] * math.cos(u[0]), math.cos(u[0]), math.sin(u[0])]
        end = solve_ivp(rhs, (0, 1), [0, gamma, 0, 0], method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
        return [end[1], end[2] - centre[0] - radius * nu[0], end[3] - centre[1] - radius * nu[1]]

    out = root(ends, guess, method="hybr", options={"xtol": 1e-14})
    assert max(abs(e) for e in ends(out.x)) <= 1e-10, out.message
    return out.x


def tip_slip_load(centre, radius, psi_guess: float, guess, width: float = 0.01) -> float:
    """The load p at which a tip pressed down on a disc slides off it: the extreme of p over the
    tip-on-disc branch (:func:`tip_on_peg`), the branch's fold, searched within ``width`` (rad) of
    ``psi_guess`` from the branch point ``guess`` = (θ'(0), R, p) there."""
    from scipy.optimize import minimize_scalar

    state = {"v": tip_on_peg(psi_guess, centre, radius, guess)}

    def p_of(psi):
        state["v"] = tip_on_peg(psi, centre, radius, state["v"])
        return state["v"][2]

    res = minimize_scalar(p_of, bounds=(psi_guess - width, psi_guess + width), method="bounded",
                          options={"xatol": 1e-12})
    return float(res.fun)
