"""Independent shooting reference for a rod in a non-uniform field given by any field function.

One of the project's *independent references*: numpy and scipy only, no CasADi and nothing of
:mod:`actuator_design`; the field is a callable (typically magpylib's ``getH`` on the user's magnets
and coils, evaluated here at every step of the integrator, its gradient by central differences).

Model (THEORY §3–§5, §9; dimensionless: lengths in ℓ, energies in B0/ℓ, b ≡ 1, a dead load at the tip
only): with
ĥ(r) the field in units of H0, a = (cos(θ+α), sin(θ+α)), m̂ = (cos(θ+β), sin(θ+β)),

    e(θ, r) = −h² (a·ĥ)² − h_pos² |ĥ|² − h_r (m̂·ĥ),

the stationarity of ∫ ½θ'² + e ds under r' = (cos θ, sin θ) (multiplier n(s), the internal force) is

    θ'' = ∂e/∂θ + n_x sin θ − n_y cos θ,   n' = ∂e/∂r,   r' = (cos θ, sin θ),
    θ(0) = θ0, r(0) = 0;   θ'(1) = 0, n(1) = (f_x, f_y) (the tip load; 0 without),

(for a uniform field and n ≡ (0, p) this is THEORY §5's θ'' − h² sin 2(θ − φ) + p cos θ = 0). Shooting
on (θ'(0), n(0)) with DOP853 and Newton's method on the three end conditions.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root

__all__ = ["FieldRod", "FieldShot", "shoot_field", "solve_field_shooting"]


@dataclass
class FieldRod:
    """A rod in a field ``field(points (k, 2)) -> ĥ (k, 2)`` (dimensionless, positions in ℓ).

    h, h_pos, h_r : the groups of THEORY §5 and §9; alpha, beta : constant fibre and magnetisation
    angles (rad); theta0 : clamp angle (rad); delta : step of the central differences for ∇ĥ (ℓ);
    end_load : a dead load (f_x, f_y) at the tip (units of B0/ℓ²; f_y = p of THEORY §5): the end
    condition is then n(1) = end_load.
    """

    field: Callable[[np.ndarray], np.ndarray]
    h: float = 0.0
    h_pos: float = 0.0
    h_r: float = 0.0
    alpha: float = 0.0
    beta: float = 0.0
    theta0: float = 0.0
    delta: float = 1e-4
    end_load: tuple = (0.0, 0.0)

    def jet(self, x: float, y: float):
        """ĥ (2,) and ∇ĥ (2, 2), [i, j] = ∂ĥ_i/∂r_j, by 4th-order central differences."""
        d = self.delta
        offs = np.array([[0, 0], [-2 * d, 0], [-d, 0], [d, 0], [2 * d, 0], [0, -2 * d], [0, -d], [0, d], [0, 2 * d]])
        v = np.asarray(self.field(np.array([x, y]) + offs), float)
        J = np.empty((2, 2))
        J[:, 0] = (v[1] - 8 * v[2] + 8 * v[3] - v[4]) / (12 * d)
        J[:, 1] = (v[5] - 8 * v[6] + 8 * v[7] - v[8]) / (12 * d)
        return v[0], J

    def rhs(self, s, u):
        th, k, x, y, nx, ny = u
        h, J = self.jet(x, y)
        a = np.array([math.cos(th + self.alpha), math.sin(th + self.alpha)])
        ap = np.array([-a[1], a[0]])
        m = np.array([math.cos(th + self.beta), math.sin(th + self.beta)])
        mp = np.array([-m[1], m[0]])
        ah = a @ h
        de_dth = -2 * self.h ** 2 * ah * (ap @ h) - self.h_r * (mp @ h)
        de_dr = -2 * self.h ** 2 * ah * (J.T @ a) - 2 * self.h_pos ** 2 * (J.T @ h) - self.h_r * (J.T @ m)
        c, sn = math.cos(th), math.sin(th)
        return [k, de_dth + nx * sn - ny * c, c, sn, de_dr[0], de_dr[1]]


@dataclass
class FieldShot:
    """A shot: the integrated state at s = 1 and the solution object (dense output)."""

    unknowns: np.ndarray  # θ'(0), n_x(0), n_y(0)
    end: np.ndarray  # θ, θ', x, y, n_x, n_y at s = 1
    sol: object
    converged: bool = False

    @property
    def tip(self):
        """(x(1), y(1), θ(1))."""
        return float(self.end[2]), float(self.end[3]), float(self.end[0])

    def state(self, s) -> np.ndarray:
        """θ, θ', x, y, n_x, n_y at ``s``, shape (6, len(s))."""
        return self.sol.sol(np.atleast_1d(np.asarray(s, float)))


def shoot_field(rod: FieldRod, unknowns: Sequence[float], rtol: float = 1e-12) -> FieldShot:
    """Integrate from the clamp with θ'(0), n(0) = ``unknowns``."""
    k0, nx0, ny0 = (float(v) for v in unknowns)
    sol = solve_ivp(rod.rhs, (0.0, 1.0), [rod.theta0, k0, 0.0, 0.0, nx0, ny0], method="DOP853",
                    rtol=rtol, atol=rtol, dense_output=True)
    if not sol.success:
        raise RuntimeError(f"integration failed: {sol.message}")
    return FieldShot(np.array([k0, nx0, ny0]), sol.y[:, -1].copy(), sol)


def solve_field_shooting(rod: FieldRod, guess: Sequence[float], *, tol: float = 1e-10,
                         rtol: float = 1e-12) -> FieldShot:
    """Newton (MINPACK's hybrid method) on θ'(1) = 0, n(1) = 0 from ``guess`` = (θ'(0), n(0)), to
    ``tol`` × max(1, |θ'(0)|, |n(0)|) (the size of the clamp's moment and force).

    Raises
    ------
    RuntimeError
        When the end conditions are not met to ``tol``.
    """
    fx, fy = (float(f) for f in rod.end_load)

    def ends(v):
        e = shoot_field(rod, v, rtol).end
        return [e[1], e[4] - fx, e[5] - fy]

    out = root(ends, np.asarray(guess, float), method="hybr", options={"xtol": 1e-13})
    shot = shoot_field(rod, out.x, rtol)
    resid = max(abs(shot.end[1]), abs(shot.end[4] - fx), abs(shot.end[5] - fy))
    if not resid <= tol * max(1.0, float(np.max(np.abs(out.x)))):
        raise RuntimeError(f"shooting did not converge: end residual {resid:.3g} ({out.message})")
    shot.converged = True
    return shot


def field_from_function(h_of_points: Callable[[np.ndarray], np.ndarray], length: float,
                        h0: float) -> Callable[[np.ndarray], np.ndarray]:
    """ĥ(r) = H(ℓ r)/H0 from a function of points in metres (k, 3) giving H in A/m (k, 3)."""
    def field(pts: np.ndarray) -> np.ndarray:
        p = np.column_stack([np.asarray(pts, float) * length, np.zeros(len(pts))])
        return np.asarray(h_of_points(p), float).reshape(-1, 3)[:, :2] / h0
    return field


def guess_from_shape(rod: FieldRod, s: np.ndarray, theta: np.ndarray, dtheta0: float,
                     x: np.ndarray, y: np.ndarray) -> Optional[np.ndarray]:
    """(θ'(0), n(0)) for a start: n(0) = n(1) − ∫₀¹ ∂e/∂r ds along a given shape (trapezoidal), n(1)
    the tip load."""
    de_dr = np.array([rod.rhs(si, [th, 0.0, xi, yi, 0.0, 0.0])[4:6] for si, th, xi, yi in zip(s, theta, x, y)])
    n0 = np.asarray(rod.end_load, float) - (np.trapz(de_dr, s, axis=0) if hasattr(np, "trapz")
                                            else np.trapezoid(de_dr, s, axis=0))
    return np.array([dtheta0, n0[0], n0[1]])
