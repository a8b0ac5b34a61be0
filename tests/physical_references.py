"""Independent references for strong fields and large loads (issue 10): closed forms and scipy BVPs.

* :func:`layer_tip` — the strong-field clamp layer in closed form (THEORY §6, the pendulum first
  integral ½ψ'² = h² sin²ψ, ψ = θ − φ → 0 away from the clamp): tan(ψ/2) = tan(−φ/2) e^{−√2 h s};
  the semi-infinite layer misses the free-end condition by ~e^{−√2 h}; tip by adaptive quadrature.
* :func:`bvp_from_rest` — scipy ``solve_bvp`` (collocation, tolerance 1e-10) continued from rest.
"""
import math

import numpy as np
from scipy.integrate import quad, solve_bvp


def layer_tip(h, phi):
    """Tip (x, y) of the strong-field clamp layer in closed form (module docstring)."""
    def theta(s):
        return phi + 2.0 * math.atan(math.tan(-0.5 * phi) * math.exp(-math.sqrt(2.0) * h * s))
    w = 1.0 / (math.sqrt(2.0) * h)
    pts = [min(1.0, c * w) for c in (1, 3, 10, 30)]
    kw = dict(points=pts, epsabs=1e-14, epsrel=1e-13, limit=200)
    return (quad(lambda s: math.cos(theta(s)), 0, 1, **kw)[0],
            quad(lambda s: math.sin(theta(s)), 0, 1, **kw)[0])


def _rhs(h, phi, p):
    return lambda s, Y: np.vstack([Y[1], h * h * np.sin(2 * (Y[0] - phi)) - p * np.cos(Y[0]),
                                   np.cos(Y[0]), np.sin(Y[0])])


def _jac(h, phi, p):
    def jac(s, Y):
        J = np.zeros((4, 4, s.size))
        J[0, 1] = 1.0
        J[1, 0] = 2 * h * h * np.cos(2 * (Y[0] - phi)) + p * np.sin(Y[0])
        J[2, 0] = -np.sin(Y[0])
        J[3, 0] = np.cos(Y[0])
        return J
    return jac


def _bc(a, b):
    return np.array([a[0], b[1], a[2], a[3]])


_BC_JAC = (np.array([[1.0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
           np.array([[0.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]))


def bvp_from_rest(h, phi, p, steps=30):
    """Tip (x, y) of θ'' = h² sin 2(θ − φ) − p cos θ, θ(0) = 0, θ'(1) = 0 (Y = θ, θ', x, y),
    continued from rest with field and load ramped together: (λh, λp), λ from 1e-3 to 1
    (analytic Jacobians; the last solve at tolerance 1e-10)."""
    s = np.linspace(0, 1, 201)
    Y = np.zeros((4, s.size))
    Y[2] = s
    lams = np.geomspace(1e-3, 1.0, steps)
    for lam in lams:
        sol = solve_bvp(_rhs(lam * h, phi, lam * p), _bc, s, Y, fun_jac=_jac(lam * h, phi, lam * p),
                        bc_jac=lambda a, b: _BC_JAC, tol=1e-10 if lam == lams[-1] else 1e-5,
                        max_nodes=200000)
        assert sol.success, sol.message
        s, Y = sol.x, sol.y
    return Y[2, -1], Y[3, -1]
