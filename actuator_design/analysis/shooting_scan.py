"""The shooting scan behind :func:`~.equilibria.find_equilibria` and the multiplicity maps (THEORY §5, §7, §9).

Method A of :mod:`.equilibria`: a complete scan of the shooting parameter
γ = θ'(0). For a uniform field (or none) the Euler–Lagrange equation of any scene of
:class:`~actuator_design.model.scene.Scene` (fibre layout α(s), stiffness b(s), tip force f, tip moment
m, uniform distributed dead load q, hard-magnetic group h_r with magnetisation angle β(s)) reads

    (b θ')' − h² sin(2(θ + α − φ)) − h_r sin(θ + β − φ) + n_y cos θ − n_x sin θ = 0,
    n(s) = f + q (1 − s),   θ(0) = θ0,   b(1) θ'(1) = m,                                   (EL)

an initial-value problem in s once γ is chosen: the moment M = b θ' obeys M' = h² sin 2ψ
+ h_r sin(θ + β − φ) − n_y cos θ + n_x sin θ (ψ = θ + α − φ) and θ' = M/b. In a uniform field the
remanent torque (THEORY §9) is that of an internal force: −h_r cos(θ + β − φ) = −n_r·(cos θ, sin θ)
with n_r(s) = h_r (cos(β − φ), −sin(β − φ)), so the integration simply adds n_r to n (and to
the Jacobi coefficient Q, where it gives h_r cos(θ + β − φ)). Every equilibrium is a root of the
free-end residual r(γ) = M(1; γ) − m, and every root lies in a window known a priori:

* **integral bound** (any scene): integrating (EL) over [0, 1],
  b(1)θ'(1) − b(0)θ'(0) = ∫₀¹ (h² sin 2ψ + h_r sin(θ + β − φ) − n_y cos θ + n_x sin θ) ds, so

      |γ| ≤ (|m| + h² + h_r + ∫₀¹ |n(s)| ds) / b(0),   ∫₀¹ |n| ds ≤ |f| + |q|/2,

  which for THEORY §5's scene is |θ'(0)| ≤ h² + |p| (+ h_r for a hard-magnetic rod);
* **first-integral bound** (b, α and β constant, q = 0: the equation is autonomous):
  E₁ = ½ b θ'² + V(θ), V(θ) = ½ h² cos 2ψ + h_r cos(θ + β − φ) + n_y sin θ + n_x cos θ, is
  constant along s, so ½ b γ² = ½ m²/b + V(θ(1)) − V(θ0) ≤ ½ m²/b + ½ h² + h_r + |n| − V(θ0)
  (for φ = 0, θ0 = 0, m = 0, h_r = 0: |γ| ≤ √(2|p|)).

The scan uses the smaller bound, widened by :data:`SAFETY` (5 % + 1e-3). r(γ) is evaluated on a
uniform γ grid for all γ at once (a fixed-step classical Runge–Kutta integration in numpy over the
whole grid), each sign change is refined by ``scipy.optimize.brentq`` (a scalar RK4 with twice as
many steps), and each root is confirmed by the collocation NLP (Newton from the shooting shape,
no saddle escape) and deduplicated. Completeness is ensured up to the resolution: the window is a
rigorous bound, r is smooth in γ, and the number of sign changes must be the same on the grid
and on a grid of half the step (else the step is halved again, up to :data:`MAX_REFINE` times and
the result says ``complete: false``). Roots closer together than the final γ step (scenes within
about that distance of a fold) can still be missed: this is stated in the result.
"""
from __future__ import annotations

import functools
import math
from typing import Dict, Optional

import numpy as np

from actuator_design.model.scene import Scene
from actuator_design.physics.registry import (declaring, present_parts, registered_terms, registry_version,
                                              signed_end_moment)
from actuator_design.physics.term_protocol import snap_zero

__all__ = ["ShootingProblem", "gamma_bound", "curvature_bound", "steps_for", "brackets",
           "shooting_terms", "SAFETY", "MAX_REFINE", "require_uniform", "growth_exponent",
           "scan_validity", "TRUST_LIMIT", "MAX_STEPS", "min_gamma_points",
           "MAX_GAMMA_POINTS", "is_autonomous"]

#: Relative widening of the a-priori γ bound (and an absolute 1e-3).
SAFETY = 0.05
#: How many times the γ step may be halved when the bracket count is not yet stable.
MAX_REFINE = 4
_EPS = np.finfo(float).eps


def _parts(scene: Scene):
    """Every present term's :class:`~actuator_design.physics.term_protocol.ShootingPart`, in
    registration order; ValueError naming a non-uniform field or the first term without one."""
    return _parts_of(scene, registry_version())


@functools.lru_cache(maxsize=4096)
def _parts_of(scene: Scene, version: int):
    # (a map asks for the same scene's bounds several times; the registry's version keys a re-registered term)
    return tuple(part for _, part in present_parts(scene, "shooting_part", "equilibria (shooting scan)"))


def require_uniform(scene: Scene) -> None:
    """The shooting scan's requirements: a uniform field (or none), and only terms that declare their
    part of the equation (``EnergyTerm.shooting_part``: :func:`shooting_terms`)."""
    _parts(scene)


def shooting_terms() -> tuple:
    """The registered terms whose Euler–Lagrange equation (EL) the shooting scan integrates (module
    docstring); a scene with any other term is refused, never silently scanned without it."""
    return tuple(declaring("shooting_part"))


def _dead_force(parts, s: np.ndarray):
    """The dead loads' internal force n(s) (n_x, n_y): arrays shaped like ``s``, or numbers for a
    constant force."""
    nx, ny = 0.0, 0.0
    for part in parts:
        if part.force is not None and part.dead:
            fx, fy = part.force(s)
            nx, ny = nx + fx, ny + fy
    return nx, ny


def is_autonomous(scene: Scene) -> bool:
    """b, α and β constant and no distributed load: (EL) does not depend on s explicitly (False for a
    scene the scan refuses)."""
    try:
        return all(part.autonomous for part in _parts(scene))
    except ValueError:
        return False


def _twofold(parts, s: np.ndarray):
    """(h², cos ψ0(s), sin ψ0(s)) of the two-fold torque h² sin(2θ + ψ0(s)) the parts add up to:
    one term's own (ψ0 = 2(α − φ)), several summed as k_i sin(2θ + ψ_i) = sin 2θ Σ k_i cos ψ_i +
    cos 2θ Σ k_i sin ψ_i (h² = 1), none: zero."""
    twofold = [p for p in parts if p.twofold_angle is not None]
    if len(twofold) <= 1:
        psi = twofold[0].twofold_angle(s) if twofold else np.zeros_like(s)
        h2 = twofold[0].twofold if twofold else 0.0
        return h2, snap_zero(np.cos(psi)), snap_zero(np.sin(psi))
    angles = [(p.twofold, p.twofold_angle(s)) for p in twofold]
    return (1.0, sum(k * snap_zero(np.cos(psi)) for k, psi in angles),
            sum(k * snap_zero(np.sin(psi)) for k, psi in angles))


def gamma_bound(scene: Scene) -> Dict[str, float]:
    """A-priori bound on |θ'(0)| over all equilibria of a uniform-field scene (module docstring).

    Returns
    -------
    dict
        ``integral`` (always), ``first_integral`` (autonomous scenes, else ``None``), ``bound``
        (the smaller, before widening) and ``window`` (the widened half-width actually scanned).
    """
    parts = _parts(scene)
    m = signed_end_moment(scene)
    b0 = float(scene.stiffness(0.0))
    varies = any(p.force is not None and p.dead and not p.autonomous for p in parts)
    t = np.linspace(0.0, 1.0, 2001) if varies else np.zeros(1)  # a constant n: one point
    n_abs = np.hypot(*_dead_force(parts, t))
    int_n = min(sum(p.force_integral for p in parts if p.dead), float(np.max(n_abs)))
    integral = (abs(m) + sum(p.torque for p in parts) + int_n) / b0
    first = None
    potentials = _potentials(scene) if all(p.autonomous for p in parts) else None
    if potentials is not None:  # ½ b γ² ≤ ½ m²/b + max V − V(θ0), V the first integral's potential
        b, th0 = float(scene.stiffness.value), np.array(float(scene.theta0))
        rise = sum(p.potential_max for p in parts) - sum(float(v(th0)) for v in potentials)
        val = (m * m / b + 2 * rise) / b
        first = math.sqrt(max(val, 0.0))
    bound = integral if first is None else min(integral, first)
    return {"integral": integral, "first_integral": first, "bound": bound,
            "window": bound * (1 + SAFETY) + 1e-3}


def _potentials(scene: Scene):
    """The present terms' parts of the first integral (``EnergyTerm.phase_potential``), or None when
    a term declares none (the first-integral bound is then not taken)."""
    return _potentials_of(scene, registry_version())


@functools.lru_cache(maxsize=4096)
def _potentials_of(scene: Scene, version: int):
    names = set(declaring("phase_potential"))
    if any(cls.present(scene) and cls.name not in names for cls in registered_terms()):
        return None
    return tuple(v for _, v in present_parts(scene, "phase_potential", "equilibria (shooting scan)"))


class ShootingProblem:
    """The initial-value problem of (EL) for a batch of B uniform-field scenes on a fixed grid.

    Integrated with classical RK4 in ``n_steps`` equal steps, in the variables (c, s, M) =
    (cos θ, sin θ, b θ'): c' = −s M/b, s' = c M/b, M' = h² sin 2ψ − n_y c + n_x s, which needs no
    trigonometric function per stage (sin 2ψ = 2sc·cos 2(α−φ) + (c² − s²)·sin 2(α−φ)); n includes
    the hard-magnetic force n_r (``HardMagnetic.shooting_part``). The coefficients are precomputed at the
    2·n_steps + 1 half-step points with shape (S, B, 1) (S = 1 when every scene of the batch is
    autonomous: α, β, b constant, q = 0), so a (B, G) array of γ values is integrated at once with
    in-place numpy operations.

    Parameters
    ----------
    scenes : Scene or sequence of Scene
        Uniform-field (or field-free) scenes.
    n_steps : int
        Number of RK4 steps on s ∈ [0, 1].
    """

    def __init__(self, scenes, n_steps: int):
        scenes = [scenes] if isinstance(scenes, Scene) else list(scenes)
        parts = [_parts(sc) for sc in scenes]
        self.scenes, self.N = scenes, int(n_steps)
        s = np.linspace(0.0, 1.0, 2 * self.N + 1)
        self.s = s
        self.autonomous = all(p.autonomous for ps in parts for p in ps)
        if self.autonomous:
            s = s[:1]  # the coefficients do not depend on s: evaluate them once
        col = lambda vals: np.asarray(vals, float).T[:, :, None]  # (B, S) -> (S, B, 1)
        h2, C, S = zip(*(_twofold(ps, s) for ps in parts))
        self.h2 = np.array(h2, float)[None, :, None]
        self.C, self.S = col(C), col(S)
        self.invb = col([1.0 / sc.stiffness(s) for sc in scenes])
        forces = [[p.force(s) for p in ps if p.force is not None] for ps in parts]
        self.nx = col([sum((f[0] for f in fs), 0.0) + np.zeros_like(s) for fs in forces])
        self.ny = col([sum((f[1] for f in fs), 0.0) + np.zeros_like(s) for fs in forces])
        # derived stage coefficients of M' = s·(A c − Bs s + nx) + D − ny c
        self.A = 2 * self.h2 * self.C
        self.Bs = 2 * self.h2 * self.S
        self.D = self.h2 * self.S
        self.unit_b = bool(np.all(self.invb == 1.0))
        self.no_S = bool(np.all(self.S == 0.0))
        self.theta0 = np.array([sc.theta0 for sc in scenes], float)[:, None]
        self.m = np.array([signed_end_moment(sc) for sc in scenes])[:, None]
        self.b0 = np.array([float(sc.stiffness(0.0)) for sc in scenes])[:, None]

    def residual(self, gammas: np.ndarray, jacobi: bool = False):
        """r(γ) = b(1)θ'(1) − m for γ of shape (B, G) (or (G,) for B = 1) → same shape.

        With ``jacobi=True`` also integrates the Jacobi field η = ∂θ/∂γ (η(0) = 0, bη'(0) = b(0);
        (bη')' = Q η with Q = 2h² cos 2ψ + n_x cos θ + n_y sin θ, n including n_r, so that Q
        contains h_r cos(θ + β − φ), THEORY §7, §9) and returns
        (r, zeros, eta1): the number of sign changes of η over the step points in (0, 1] and η(1).
        By Sturm theory the Morse index of an equilibrium is zeros + [η(1)·bη'(1) < 0], with
        bη'(1) = r'(γ) (cf. :func:`actuator_design.reference.shooting.sturm_morse_index`).
        """
        g = np.asarray(gammas, float)
        squeeze = g.ndim == 1
        g = np.atleast_2d(g)
        coef = {name: getattr(self, name) for name in ("A", "Bs", "D", "nx", "ny", "invb")}
        out = self.integrate(g, coef, self.theta0, self.m, self.b0, jacobi)
        if jacobi:
            out = out[:3]
            return tuple(o[0] for o in out) if squeeze else out
        return out[0] if squeeze else out

    def integrate(self, g, coef, theta0, m, b0, jacobi, steps=None):
        """RK4 over s ∈ [0, 1] for γ = ``g`` (shape (B, G) or (K,); rad per rod length), the kernel
        of :meth:`residual`. ``coef``: the stage coefficients ``A``, ``Bs``, ``D``, ``nx``, ``ny``,
        ``invb`` (class docstring) indexed [half-step point], shapes (S, B, 1) or (S, K); ``theta0``,
        ``m``, ``b0`` broadcast against ``g``; ``steps`` (shape (K,), ascending; autonomous scenes
        only): RK4 steps per element, done elements dropping out of the loop
        (:func:`~.multiplicity_scan.residual_at`). Returns r, or with ``jacobi`` (r, zeros, η(1),
        bη'(1) = r'(γ)), shaped like ``g``.
        """
        shape = g.shape
        A, Bs, D, nx, ny, invb = (coef[k] for k in ("A", "Bs", "D", "nx", "ny", "invb"))
        y = [np.broadcast_to(np.cos(theta0), shape).copy(),
             np.broadcast_to(np.sin(theta0), shape).copy(), g * b0]
        if jacobi:
            y += [np.zeros(shape), np.broadcast_to(b0, shape).copy()]
            zeros = np.zeros(shape, int)
        nv = len(y)
        k = [[np.empty(shape) for _ in range(nv)] for _ in range(4)]
        ys = [np.empty(shape) for _ in range(nv)]
        tmp, tmp2, eta_prev = np.empty(shape), np.empty(shape), np.empty(shape)
        S1 = A.shape[0]
        ds = 1.0 / self.N
        n_loop = self.N
        if steps is not None:
            full = dict(y=y, k=k, ys=ys, t=(tmp, tmp2, eta_prev, zeros), A=A, Bs=Bs, D=D, nx=nx,
                        ny=ny, invb=invb, ds=1.0 / steps)
            n_loop, start = int(steps[-1]), -1
        half, sixth = 0.5 * ds, ds / 6.0

        def rhs(idx, st, out):
            i = idx if S1 > 1 else 0
            T1, T2 = tmp, tmp2
            c, s_, M = st[0], st[1], st[2]
            if self.unit_b:
                kap = M
            else:
                kap = T1
                np.multiply(M, invb[i], out=kap)
            np.multiply(s_, kap, out=out[0])
            np.negative(out[0], out=out[0])
            np.multiply(c, kap, out=out[1])
            if jacobi:
                if self.unit_b:
                    np.copyto(out[3], st[4])
                else:
                    np.multiply(st[4], invb[i], out=out[3])
            # M' = s (A c − Bs s + nx) + D − ny c, written straight into out[2]
            dM = out[2]
            np.multiply(A[i], c, out=dM)
            if not self.no_S:
                np.multiply(Bs[i], s_, out=T2)
                dM -= T2
            dM += nx[i]
            dM *= s_
            np.multiply(ny[i], c, out=T2)
            dM -= T2
            if not self.no_S:
                dM += D[i]
            if jacobi:
                # Q = 2h²[(c² − s²) C − 2 s c S] + nx c + ny s ;  P' = Q η
                q = out[4]
                np.multiply(c, c, out=q)
                np.multiply(s_, s_, out=T2)
                q -= T2
                q *= A[i]
                if not self.no_S:
                    np.multiply(s_, c, out=T2)
                    T2 *= 2 * Bs[i]
                    q -= T2
                np.multiply(nx[i], c, out=T2)
                q += T2
                np.multiply(ny[i], s_, out=T2)
                q += T2
                q *= st[3]

        for j in range(n_loop):
            if steps is not None and (start < 0 or steps[start] <= j):
                # the elements with more than j steps: a suffix (views, so the work lands in place)
                start = int(np.searchsorted(steps, j, side="right"))
                cut = lambda a: a[start:]
                y, ys = [cut(a) for a in full["y"]], [cut(a) for a in full["ys"]]
                k = [[cut(a) for a in kv] for kv in full["k"]]
                tmp, tmp2, eta_prev, zeros = (cut(a) for a in full["t"])
                A, Bs, D, nx, ny, invb = (a[:, start:] for a in (full[n] for n in ("A", "Bs", "D", "nx", "ny", "invb")))
                ds = cut(full["ds"])
                half, sixth = 0.5 * ds, ds / 6.0
            kk = 2 * j
            rhs(kk, y, k[0])
            for v in range(nv):
                np.multiply(k[0][v], half, out=ys[v]); ys[v] += y[v]
            rhs(kk + 1, ys, k[1])
            for v in range(nv):
                np.multiply(k[1][v], half, out=ys[v]); ys[v] += y[v]
            rhs(kk + 1, ys, k[2])
            for v in range(nv):
                np.multiply(k[2][v], ds, out=ys[v]); ys[v] += y[v]
            rhs(kk + 2, ys, k[3])
            if jacobi:
                np.copyto(eta_prev, y[3])
            for v in range(nv):
                k[1][v] += k[2][v]
                k[1][v] *= 2.0
                k[1][v] += k[0][v]
                k[1][v] += k[3][v]
                k[1][v] *= sixth
                y[v] += k[1][v]
            if jacobi:
                if j > 0:
                    zeros += (eta_prev * y[3] < 0)
        if steps is not None:
            y, zeros = full["y"], full["t"][3]
        r = y[2] - m
        return (r, zeros, y[3], y[4]) if jacobi else r

    def scalar(self, i: int = 0):
        """A scalar RK4 shot for batch item ``i``: ``f(gamma, record=False)`` returning the
        residual, or (residual, s, θ, θ') at the step points when ``record``."""
        h2 = float(self.h2[0, i, 0])
        full = lambda a: np.broadcast_to(a[:, i, 0], (2 * self.N + 1,)).tolist()
        C, S, invb, nx, ny = (full(a) for a in (self.C, self.S, self.invb, self.nx, self.ny))
        th0, m, b0, N = float(self.theta0[i, 0]), float(self.m[i, 0]), float(self.b0[i, 0]), self.N
        sin, cos, ds = math.sin, math.cos, 1.0 / N

        def shot(gamma, record=False):
            th, M = th0, gamma * b0
            if record:
                ths, dths = [th], [M * invb[0]]
            for j in range(N):
                k = 2 * j
                st, ct = sin(th), cos(th)
                a1, b1 = M * invb[k], h2 * (2 * st * ct * C[k] + (1 - 2 * st * st) * S[k]) - ny[k] * ct + nx[k] * st
                t2, M2 = th + 0.5 * ds * a1, M + 0.5 * ds * b1
                st, ct = sin(t2), cos(t2)
                a2, b2 = M2 * invb[k + 1], h2 * (2 * st * ct * C[k + 1] + (1 - 2 * st * st) * S[k + 1]) - ny[k + 1] * ct + nx[k + 1] * st
                t3, M3 = th + 0.5 * ds * a2, M + 0.5 * ds * b2
                st, ct = sin(t3), cos(t3)
                a3, b3 = M3 * invb[k + 1], h2 * (2 * st * ct * C[k + 1] + (1 - 2 * st * st) * S[k + 1]) - ny[k + 1] * ct + nx[k + 1] * st
                t4, M4 = th + ds * a3, M + ds * b3
                st, ct = sin(t4), cos(t4)
                a4, b4 = M4 * invb[k + 2], h2 * (2 * st * ct * C[k + 2] + (1 - 2 * st * st) * S[k + 2]) - ny[k + 2] * ct + nx[k + 2] * st
                th += ds / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
                M += ds / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
                if record:
                    ths.append(th)
                    dths.append(M * invb[k + 2])
            if record:
                return M - m, np.linspace(0, 1, N + 1), np.array(ths), np.array(dths)
            return M - m

        return shot


def curvature_bound(scene: Scene, window: float, bound: Optional[dict] = None) -> float:
    """A bound on max_s |θ'(s)| over the shots with |γ| ≤ ``window``.

    Autonomous scenes (b, α, β constant, q = 0): the first integral ½bθ'² + V(θ) = const with
    max V − min V ≤ h² + 2|f| + 2h_r gives θ'² ≤ γ² + 2(h² + 2|f| + 2h_r)/b. Otherwise the
    integral bound on [0, s]: |bθ'(s)| ≤ b(0)|γ| + |m| + h² + h_r + ∫|n|, divided by min b.
    ``bound``: :func:`gamma_bound` of ``scene`` when already known.
    """
    gb = gamma_bound(scene) if bound is None else bound
    if gb["first_integral"] is not None:
        b = float(scene.stiffness.value)
        spread = sum(p.spread for p in _parts(scene))
        return math.sqrt(window**2 + 2 * spread / b)
    bmin = float(np.min(scene.stiffness(np.linspace(0, 1, 201))))
    b0 = float(scene.stiffness(0.0))
    return (b0 * window + gb["integral"] * b0) / bmin


def steps_for(scene: Scene, window: float, min_steps: int = 64, rad_per_step: float = 0.1,
              kappa: Optional[float] = None) -> int:
    """RK4 steps so that the tangent turns by at most ``rad_per_step`` per step (``kappa``: the
    :func:`curvature_bound` when already known)."""
    kappa = curvature_bound(scene, window) if kappa is None else kappa
    return int(min(max(min_steps, math.ceil(kappa / rad_per_step)), MAX_STEPS))


def brackets(g: np.ndarray, r: np.ndarray):
    """Roots on a grid: exact zeros and strict sign changes (a zero is never also a bracket end)."""
    zero = np.flatnonzero(r == 0.0)
    sc = np.flatnonzero(r[:-1] * r[1:] < 0.0)
    return [(g[i], g[i]) for i in zero] + [(g[i], g[i + 1]) for i in sc]


#: The scan is trusted while e^L · ε · max(1, W) stays below this (:func:`scan_validity`).
TRUST_LIMIT = 1e-6
#: The most RK4 steps :func:`steps_for` gives; a scene that needs more is not resolved.
MAX_STEPS = 4000
#: The most γ samples :func:`min_gamma_points` may ask for before the scan is declared untrusted.
MAX_GAMMA_POINTS = 20001


def min_gamma_points(scene: Scene, window: float, exponent: Optional[float] = None) -> int:
    """γ samples over [−W, W] needed to separate the closest pairs of roots, 8 e^{L/2} + 1.

    Shots that pass close to a hyperbolic state of the IVP (the rod aligned with the field, where
    the Jacobi field grows like e^{Ls}) come in pairs that leave it on either side; such a pair is
    about W e^{−L/2} apart in γ (measured for THEORY §5's scene at φ = 45°: 0.19 at h = 6, 0.038 at
    h = 8). The step 2W/(n − 1) is kept below a quarter of that, so that halving it (the bracket
    count check) sees them rather than stepping over both. ``exponent``: :func:`growth_exponent`
    of ``scene`` when already known.
    """
    L = growth_exponent(scene) if exponent is None else exponent
    return int(8.0 * math.exp(0.5 * L)) + 1


def growth_exponent(scene: Scene) -> float:
    """L such that the shooting IVP amplifies any perturbation by at most e^L over s ∈ [0, 1].

    The Jacobi field (η, P = bη') obeys η' = P/b, P' = Qη with
    |Q| = |2h² cos 2ψ + h_r cos(θ + β − φ) + n_x cos θ + n_y sin θ| ≤ Q̄ = 2h² + h_r + max_s |n(s)|
    (THEORY §7, §9). In the scaled
    variables (κη, P), κ = √(Q̄ b_min), the system matrix is antidiagonal with entries of size at
    most √(Q̄ / b_min), so by Gronwall every solution grows at most like e^{L s}, L = √(Q̄ / b_min).
    The same bound holds for the difference of two shots (rounding, RK4 truncation, γ to γ + δ).
    """
    parts = _parts(scene)
    varies = any(p.force is not None and p.dead and not p.autonomous for p in parts)
    # a constant n and b: the same numbers at one point instead of 201
    t = np.linspace(0.0, 1.0, 201) if varies or not scene.stiffness.is_constant else np.zeros(1)
    n_max = float(np.max(np.hypot(*_dead_force(parts, t if varies else t[:1]))))
    b_min = float(np.min(scene.stiffness(t[:1] if scene.stiffness.is_constant else t)))
    return math.sqrt((sum(p.jacobi for p in parts) + n_max) / b_min)


def scan_validity(scene: Scene, window: float, rad_per_step: float = 0.1,
                  exponent: Optional[float] = None, kappa: Optional[float] = None) -> Dict[str, object]:
    """Whether the shooting scan of ``scene`` over |γ| ≤ ``window`` can be trusted.

    A change of γ by one rounding unit (ε|γ| ≤ ε W), or a rounding error of the integration, moves
    the end state by up to e^L times as much (:func:`growth_exponent`). While e^L ε max(1, W) ≤
    :data:`TRUST_LIMIT` (1e-6) the residual's sign changes are those of the exact problem to that
    accuracy; beyond it (e.g. h ≳ 12 for THEORY §5's scene, where roots near the aligned state lie
    closer together than ε|γ|) and whenever the scan would need more than :data:`MAX_STEPS` RK4
    steps, the scan cannot certify a complete set. For h = 1e4 the IVP overflows outright.

    ``exponent`` and ``kappa``: :func:`growth_exponent` and :func:`curvature_bound` when already
    known.

    Returns
    -------
    dict
        ``valid`` (bool), ``growth_exponent`` L, ``log10_amplification`` (L / ln 10),
        ``reason`` (None when valid, else one sentence).
    """
    L = growth_exponent(scene) if exponent is None else exponent
    limit = math.log(TRUST_LIMIT / (_EPS * max(1.0, float(window))))
    kappa = curvature_bound(scene, window) if kappa is None else kappa
    reason = None
    if L > limit:
        reason = (f"the shooting scan is not trustworthy here: the initial-value problem amplifies "
                  f"errors by up to 10^{L / math.log(10):.3g} (growth exponent L = {L:.4g}), so "
                  f"roots closer together than the rounding of theta'(0) cannot be told apart "
                  f"(trusted while L <= {limit:.4g}; for the straight rod in a field, h up to about "
                  f"{limit / math.sqrt(2):.3g})")
    elif min_gamma_points(scene, window, L) > MAX_GAMMA_POINTS:
        reason = (f"the shooting scan is not trustworthy here: its closest pairs of roots lie about "
                  f"e^(-L/2) = {math.exp(-0.5 * L):.3g} window widths apart (growth exponent "
                  f"L = {L:.4g}), finer than {MAX_GAMMA_POINTS} samples of theta'(0) resolve")
    elif kappa / rad_per_step > MAX_STEPS:
        reason = (f"the shooting scan would need {math.ceil(kappa / rad_per_step)} RK4 steps (more than "
                  f"{MAX_STEPS}) to resolve the curvature bound {kappa:.4g}")
    return {"valid": reason is None, "growth_exponent": L,
            "log10_amplification": L / math.log(10), "reason": reason}
