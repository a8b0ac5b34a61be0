"""The rod's Euler–Lagrange boundary-value problem in first-order form (numpy/scipy only).

Independent of the CasADi machinery: used for scipy's ``solve_bvp`` as the *peer* method of the
benchmark and, by shooting, as the *reference* for fields that depend on position (dipole), where
the uniform-field shooting solver of :mod:`actuator_design.reference.shooting` does not apply.

Model (THEORY §4–5, generalised).  With the potential density V(θ, r, s) of the field and the
distributed load, a tip force f, a tip moment m and the Lagrange multiplier n(s) of r' = (cos θ,
sin θ) (the internal force), stationarity of

    Ê = ∫₀¹ ½ b θ'² + V(θ, r, s) ds − f·r(1) − m θ(1)

gives, with M = b θ',

    θ' = M/b,   M' = ∂V/∂θ + n_x sin θ − n_y cos θ,   r' = (cos θ, sin θ),   n' = ∂V/∂r,
    θ(0) = θ0,  r(0) = 0,  M(1) = m,  n(1) = f.                                            (BVP)

Field term (THEORY §4): V = −h² (ã·ĥ(r))² − h_pos² |ĥ(r)|² − q·r with ã = (cos(θ+α), sin(θ+α)).
In a uniform field ĥ = (cos φ, sin φ) and n = f + q (1 − s) is known, so only (θ, M, x, y) are
integrated; for a dipole the state also carries n (6 unknowns, 3 unknown initial values).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Optional, Tuple

import numpy as np
from scipy.integrate import solve_bvp, solve_ivp
from scipy.optimize import root

__all__ = ["RodBVP", "bvp_from_scene", "BVPSolution", "solve_bvp_peer", "shoot_general",
           "dipole_field", "dipole_field_jacobian"]


def _profile_fn(p) -> Callable:
    if callable(p):
        return lambda s: np.broadcast_to(np.asarray(p(np.asarray(s, float)), float), np.shape(s))
    c = float(p)
    return lambda s: np.full(np.shape(s), c)


def dipole_field(rx, ry, x0, y0, angle):
    """ĥ of a planar point dipole at (x0, y0) with moment direction ``angle`` (THEORY §3).

    ĥ(ρ) = [3 (m̂·ρ̂) ρ̂ − m̂] / |ρ|³, ρ = r − r0.  Arrays of equal shape → (hx, hy)."""
    mx, my = math.cos(angle), math.sin(angle)
    px, py = rx - x0, ry - y0
    r2 = px * px + py * py
    r = np.sqrt(r2)
    md = mx * px + my * py
    inv5 = 1.0 / (r2 * r2 * r)
    inv3 = 1.0 / (r2 * r)
    return 3 * md * px * inv5 - mx * inv3, 3 * md * py * inv5 - my * inv3


def dipole_field_jacobian(rx, ry, x0, y0, angle):
    """∂ĥ_i/∂r_j of :func:`dipole_field`: ((Jxx, Jxy), (Jyx, Jyy)), each of the shape of rx.

    J_ij = 3 (m_j ρ_i + (m̂·ρ) δ_ij + m_i ρ_j)/|ρ|⁵ − 15 (m̂·ρ) ρ_i ρ_j/|ρ|⁷."""
    mx, my = math.cos(angle), math.sin(angle)
    px, py = rx - x0, ry - y0
    r2 = px * px + py * py
    r = np.sqrt(r2)
    md = mx * px + my * py
    i5 = 3.0 / (r2 * r2 * r)
    i7 = 15.0 * md / (r2 * r2 * r2 * r)
    jxx = i5 * (2 * mx * px + md) - i7 * px * px
    jyy = i5 * (2 * my * py + md) - i7 * py * py
    jxy = i5 * (my * px + mx * py) - i7 * px * py
    return (jxx, jxy), (jxy, jyy)


@dataclass
class RodBVP:
    """Numbers of one scene, for the first-order BVP (all dimensionless, THEORY §5).

    ``field`` is ``None``, ``("uniform", φ)`` or ``("dipole", x0, y0, moment_angle)``.
    """

    h: float = 0.0
    h_pos: float = 0.0
    field: Optional[tuple] = ("uniform", 0.0)
    fx: float = 0.0
    fy: float = 0.0
    m: float = 0.0
    qx: float = 0.0
    qy: float = 0.0
    theta0: float = 0.0
    alpha: object = 0.0
    b: object = 1.0

    @property
    def uniform(self) -> bool:
        return self.field is None or self.field[0] == "uniform"

    @property
    def n_states(self) -> int:
        return 4 if self.uniform else 6

    # -- first-order system, vectorised over columns ----------------------------------------
    def rhs(self):
        """f(s, Y) with Y of shape (n_states, k) → dY/ds of that shape (eq. BVP)."""
        alpha, bfun = _profile_fn(self.alpha), _profile_fn(self.b)
        h2, hp2 = self.h**2, self.h_pos**2
        fx, fy, qx, qy = self.fx, self.fy, self.qx, self.qy
        if self.uniform:
            phi = 0.0 if self.field is None else float(self.field[1])
            if self.field is None:
                h2 = 0.0

            def f(s, Y):
                th, M = Y[0], Y[1]
                c, sn = np.cos(th), np.sin(th)
                nx, ny = fx + qx * (1 - s), fy + qy * (1 - s)
                dM = h2 * np.sin(2 * (th + alpha(s) - phi)) + nx * sn - ny * c
                return np.vstack([M / bfun(s), dM, c, sn])
            return f
        _, x0, y0, ang = self.field

        def f(s, Y):
            th, M, x, y, nx, ny = Y
            c, sn = np.cos(th), np.sin(th)
            u = th + alpha(s)
            ax, ay = np.cos(u), np.sin(u)
            hx, hy = dipole_field(x, y, x0, y0, ang)
            (jxx, jxy), (_, jyy) = dipole_field_jacobian(x, y, x0, y0, ang)
            ah = ax * hx + ay * hy
            dV_dth = -2 * h2 * ah * (-ay * hx + ax * hy)
            # ∂V/∂r_j = −2h² (ã·ĥ) Σ_i ã_i J_ij − 2 h_pos² Σ_i ĥ_i J_ij − q_j
            dVx = -2 * h2 * ah * (ax * jxx + ay * jxy) - 2 * hp2 * (hx * jxx + hy * jxy) - qx
            dVy = -2 * h2 * ah * (ax * jxy + ay * jyy) - 2 * hp2 * (hx * jxy + hy * jyy) - qy
            return np.vstack([M / bfun(s), dV_dth + nx * sn - ny * c, c, sn, dVx, dVy])
        return f

    def jac(self):
        """Analytic ∂f/∂Y for the uniform case (shape (4, 4, k)); ``None`` otherwise (scipy then
        uses finite differences)."""
        if not self.uniform:
            return None
        alpha, bfun = _profile_fn(self.alpha), _profile_fn(self.b)
        h2 = 0.0 if self.field is None else self.h**2
        phi = 0.0 if self.field is None else float(self.field[1])
        fx, fy, qx, qy = self.fx, self.fy, self.qx, self.qy

        def J(s, Y):
            th = Y[0]
            c, sn = np.cos(th), np.sin(th)
            nx, ny = fx + qx * (1 - s), fy + qy * (1 - s)
            out = np.zeros((4, 4, Y.shape[1]))
            out[0, 1] = 1.0 / bfun(s)
            out[1, 0] = 2 * h2 * np.cos(2 * (th + alpha(s) - phi)) + nx * c + ny * sn
            out[2, 0] = -sn
            out[3, 0] = c
            return out
        return J

    def bc(self):
        """Boundary residuals: θ(0) − θ0, x(0), y(0), M(1) − m [, n(1) − f]."""
        if self.uniform:
            return lambda ya, yb: np.array([ya[0] - self.theta0, ya[2], ya[3], yb[1] - self.m])
        return lambda ya, yb: np.array([ya[0] - self.theta0, ya[2], ya[3], yb[1] - self.m,
                                        yb[4] - self.fx, yb[5] - self.fy])

    def bc_jac(self):
        k = self.n_states

        def J(ya, yb):
            A, B = np.zeros((k, k)), np.zeros((k, k))
            A[0, 0] = A[1, 2] = A[2, 3] = 1.0
            B[3, 1] = 1.0
            if k == 6:
                B[4, 4] = B[5, 5] = 1.0
            return A, B
        return J


def bvp_from_scene(scene) -> RodBVP:
    """The :class:`RodBVP` of a :class:`~actuator_design.model.scene.Scene` (uniform or dipole field)."""
    fld = scene.field
    if fld is None:
        spec = None
    elif fld.kind == "uniform":
        spec = ("uniform", float(fld.phi))
    elif fld.kind == "dipole":
        spec = ("dipole", float(fld.x0), float(fld.y0), float(fld.moment_angle))
    else:
        raise ValueError(f"bvp_from_scene: field kind {fld.kind!r} is not supported")
    f = scene.tip_force or (0.0, 0.0)
    q = scene.distributed_load or (0.0, 0.0)
    alpha = scene.fibres.value if scene.fibres.is_constant else scene.fibres
    b = scene.stiffness.value if scene.stiffness.is_constant else scene.stiffness
    return RodBVP(h=float(scene.h), h_pos=float(scene.h_pos if spec and spec[0] == "dipole" else 0.0),
                  field=spec, fx=float(f[0]), fy=float(f[1]), m=float(scene.tip_moment or 0.0),
                  qx=float(q[0]), qy=float(q[1]), theta0=float(scene.theta0), alpha=alpha, b=b)


@dataclass
class BVPSolution:
    """A solution of (BVP): the dense state and the tip."""

    success: bool
    message: str
    s: np.ndarray                      # mesh, shape (k,)
    Y: np.ndarray                      # state on the mesh, shape (n_states, k)
    sol: Callable = field(repr=False)  # dense s -> state
    tip: Tuple[float, float, float] = (np.nan, np.nan, np.nan)  # x(1), y(1), θ(1)
    time_s: float = 0.0
    n_nodes: int = 0


def solve_bvp_peer(bvp: RodBVP, tol: float, initial: Optional[BVPSolution] = None,
                   guess_theta: Optional[Callable] = None, max_nodes: int = 100000) -> BVPSolution:
    """scipy's ``solve_bvp`` (4th-order collocation, adaptive mesh) on (BVP), warm-startable.

    Parameters
    ----------
    bvp : RodBVP
    tol : float
        ``solve_bvp``'s relative residual tolerance (its ``bc_tol`` is set to the same).
    initial : BVPSolution, optional
        Warm start: its mesh and state (the previous solution).
    guess_theta : callable, optional
        Cold start θ(s) (default: straight rod); M, x, y are derived from it.
    """
    if initial is not None:
        s, Y = initial.s, initial.Y
    else:
        s = np.linspace(0.0, 1.0, 11)
        th = np.full_like(s, bvp.theta0) if guess_theta is None else np.asarray(guess_theta(s), float)
        dth = np.gradient(th, s)
        c, sn = np.cos(th), np.sin(th)
        x = np.concatenate(([0.0], np.cumsum(0.5 * (c[1:] + c[:-1]) * np.diff(s))))
        y = np.concatenate(([0.0], np.cumsum(0.5 * (sn[1:] + sn[:-1]) * np.diff(s))))
        Y = np.vstack([th, dth * _profile_fn(bvp.b)(s), x, y])
        if bvp.n_states == 6:
            Y = np.vstack([Y, np.full_like(s, bvp.fx), np.full_like(s, bvp.fy)])
    t0 = time.perf_counter()
    res = solve_bvp(bvp.rhs(), bvp.bc(), s, Y, fun_jac=bvp.jac(), bc_jac=bvp.bc_jac(), tol=tol,
                    bc_tol=tol, max_nodes=max_nodes)
    dt = time.perf_counter() - t0
    end = res.sol(1.0)
    return BVPSolution(success=bool(res.success), message=res.message, s=res.x, Y=res.y, sol=res.sol,
                       tip=(float(end[2]), float(end[3]), float(end[0])), time_s=dt, n_nodes=res.x.size)


def _scalar_rhs(bvp: RodBVP):
    """(BVP) for one state vector with ``math`` only (the IVP integrator calls it point by point)."""
    afun, bfun = _profile_fn(bvp.alpha), _profile_fn(bvp.b)
    aconst = None if callable(bvp.alpha) else float(bvp.alpha)
    bconst = None if callable(bvp.b) else float(bvp.b)
    if bvp.uniform:
        vec = bvp.rhs()
        return lambda s, y: vec(np.array(s), y[:, None])[:, 0]
    _, x0, y0, ang = bvp.field
    mx, my = math.cos(ang), math.sin(ang)
    h2, hp2, qx, qy = bvp.h**2, bvp.h_pos**2, bvp.qx, bvp.qy
    cos, sin, sqrt = math.cos, math.sin, math.sqrt

    def f(s, Y):
        th, M, x, y, nx, ny = Y
        b = bconst if bconst is not None else float(bfun(s))
        u = th + (aconst if aconst is not None else float(afun(s)))
        ax, ay, c, sn = cos(u), sin(u), cos(th), sin(th)
        px, py = x - x0, y - y0
        r2 = px * px + py * py
        r = sqrt(r2)
        md = mx * px + my * py
        i3, i5 = 1.0 / (r2 * r), 1.0 / (r2 * r2 * r)
        hx, hy = 3 * md * px * i5 - mx * i3, 3 * md * py * i5 - my * i3
        t5, t7 = 3.0 * i5, 15.0 * md * i5 / r2
        jxx = t5 * (2 * mx * px + md) - t7 * px * px          # ∂ĥ_i/∂r_j (dipole_field_jacobian)
        jyy = t5 * (2 * my * py + md) - t7 * py * py
        jxy = t5 * (my * px + mx * py) - t7 * px * py
        ah = ax * hx + ay * hy
        dV_dth = -2 * h2 * ah * (-ay * hx + ax * hy)
        dVx = -2 * h2 * ah * (ax * jxx + ay * jxy) - 2 * hp2 * (hx * jxx + hy * jxy) - qx
        dVy = -2 * h2 * ah * (ax * jxy + ay * jyy) - 2 * hp2 * (hx * jxy + hy * jyy) - qy
        return [M / b, dV_dth + nx * sn - ny * c, c, sn, dVx, dVy]
    return f


def _ivp(bvp: RodBVP, unknowns, rtol, atol):
    """Integrate (BVP) from s = 0 with the unknown initial values (γ = M(0) [, n(0)])."""
    y0 = [bvp.theta0, unknowns[0], 0.0, 0.0] + ([unknowns[1], unknowns[2]] if bvp.n_states == 6 else [])
    return solve_ivp(_scalar_rhs(bvp), (0.0, 1.0), y0, method="DOP853", rtol=rtol, atol=atol,
                     dense_output=True)


def shoot_general(bvp: RodBVP, guess, rtol: float = 1e-12, atol: float = 1e-13,
                  xtol: float = 1e-13) -> BVPSolution:
    """Shooting on (BVP) for any field: unknowns M(0) (uniform) or (M(0), n_x(0), n_y(0)) (dipole).

    DOP853 at ``rtol``/``atol``; the end residual (M(1) − m [, n(1) − f]) is driven to zero by
    MINPACK's ``hybr`` (``scipy.optimize.root``). An independent reference for position-dependent
    fields: no collocation, no CasADi.

    Parameters
    ----------
    guess : array_like, shape (1,) or (3,)
        Initial M(0) [, n_x(0), n_y(0)].
    """
    k = 1 if bvp.n_states == 4 else 3
    target = [bvp.m] + ([bvp.fx, bvp.fy] if k == 3 else [])

    def resid(u):
        sol = _ivp(bvp, u, rtol, atol)
        if not sol.success:
            return np.full(k, 1e10)
        end = sol.y[:, -1]
        return np.array([end[1]] + ([end[4], end[5]] if k == 3 else [])) - target

    t0 = time.perf_counter()
    out = root(resid, np.asarray(guess, float)[:k], method="hybr", options={"xtol": xtol})
    sol = _ivp(bvp, out.x, rtol, atol)
    r = resid(out.x)
    ok = bool(sol.success and np.all(np.isfinite(r)) and np.max(np.abs(r)) <= 1e-9)
    end = sol.y[:, -1]
    return BVPSolution(success=ok, message=f"shooting: |end residual| = {np.max(np.abs(r)):.2e}",
                       s=sol.t, Y=sol.y, sol=sol.sol, tip=(float(end[2]), float(end[3]), float(end[0])),
                       time_s=time.perf_counter() - t0, n_nodes=sol.t.size)
