"""An independent reference for the rod's equilibrium with distributed terms: scipy's solve_bvp on
the Euler–Lagrange equation written out (THEORY §4), with a Winkler bed's resultant as a state."""
import numpy as np
from scipy.integrate import solve_bvp

S = np.linspace(0.0, 1.0, 201)


def rod_bvp(torque, k=0.0, guess_theta=None):
    """(tip x, y, angle) of θ'' = torque(s, θ) + N cos θ, N' = −k y, N(1) = 0 (the bed's resultant
    beyond s), θ(0) = θ'(1) = 0, x(0) = y(0) = 0.

    Parameters
    ----------
    torque : callable (s, θ) -> ndarray
        The other terms' torque per unit length, e.g. h² sin 2(θ − φ) − fy cos θ.
    k : float
        Bed stiffness (B0/ℓ⁴).
    guess_theta : callable s -> θ, optional
        Starting shape (default straight).
    """
    def rhs(s, u):
        th, dth, x, y, n = u
        return np.vstack([dth, torque(s, th) + n * np.cos(th), np.cos(th), np.sin(th), -k * y])

    def bc(a, b):
        return np.array([a[0], b[1], a[2], a[3], b[4]])

    guess = np.zeros((5, S.size))
    guess[2] = S
    if guess_theta is not None:
        guess[0] = guess_theta(S)
    sol = solve_bvp(rhs, bc, S, guess, tol=1e-10, max_nodes=200000)
    assert sol.success, sol.message
    return sol.y[2, -1], sol.y[3, -1], sol.y[0, -1]
