"""Canonical benchmark scenes, each with a reference answer computed independently of the solvers
under test (issue 4, item 1).

Every :class:`Problem` carries a dimensionless scene (THEORY §5), a cold-start guess θ(s) that picks
the benchmarked branch, a small parameter perturbation used to time warm re-solves, and a lazily
computed reference tip (x(1), y(1), θ(1)) from one of

* the closed forms of THEORY §6 (:mod:`actuator_design.reference.closed_forms`): elliptic transverse
  mode; the cantilever elastica in quadrature form (Bisshopp–Drucker, :func:`elastica_tip`);
* the uniform-field shooting solver (:mod:`actuator_design.reference.shooting`, DOP853 at
  rtol 1e-12, atol 1e-13, free-end residual ≤ 1e-10; tip error estimated ≤ 1e-10);
* general shooting on the first-order BVP with the internal force as state
  (:func:`actuator_design.benchmarks.bvp.shoot_general`, DOP853 at rtol 1e-12) for the dipole field,
  reached by continuation in h from the straight rod — no collocation, no CasADi.

The error of a method is max(|Δx(1)|, |Δy(1)|, |Δθ(1)|) against the reference (units of ℓ, rad).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
from scipy.integrate import IntegrationWarning, quad
from scipy.optimize import brentq

from actuator_design.benchmarks.bvp import RodBVP, bvp_from_scene, shoot_general
from actuator_design.model.profiles import constant_profile, expression_profile
from actuator_design.model.scene import DipoleField, Scene, UniformField, default_scene
from actuator_design.reference.closed_forms import transverse_mode
from actuator_design.reference.shooting import ShootingParams, shoot, solve_shooting

__all__ = ["Problem", "PROBLEMS", "get_problem", "problem_names", "elastica_tip", "elastica_tip_quadrature", "elastica_fold",
           "shooting_params_from_scene"]


# -- closed form: the cantilever elastica with a dead transverse tip load ---------------------------
def _elastica_integrals(theta1: float):
    """I0 = ∫₀^θ1 dθ/√(sin θ1 − sin θ) and I1 = ∫₀^θ1 sin θ dθ/√(sin θ1 − sin θ).

    With t = θ1 − θ, sin θ1 − sin θ = 2 cos(θ1 − t/2) sin(t/2) (no cancellation), and the
    integrable t^(−1/2) singularity is handled by QUADPACK's algebraic weight (``weight="alg"``)."""
    def g(t):
        t = max(t, 1e-300)
        return math.sqrt(t / (2.0 * math.cos(theta1 - 0.5 * t) * math.sin(0.5 * t)))

    kw = dict(weight="alg", wvar=(-0.5, 0.0), epsabs=1e-15, epsrel=1e-14, limit=200)
    with warnings.catch_warnings():  # QUADPACK warns that 1e-14 is at its rounding limit
        warnings.simplefilter("ignore", IntegrationWarning)
        I0 = quad(g, 0.0, theta1, **kw)[0]
        I1 = quad(lambda t: math.sin(theta1 - t) * g(t), 0.0, theta1, **kw)[0]
    return I0, I1


def elastica_tip_quadrature(p: float) -> Tuple[float, float, float]:
    """Tip (x(1), y(1), θ(1)) of the first mode of θ'' + p cos θ = 0, θ(0) = 0, θ'(1) = 0, p > 0,
    by quadrature of the first integral (a cross-check of :func:`elastica_tip`; p ≲ 100).

    ½θ'² = p (sin θ1 − sin θ): θ1 solves √(2p) = I0(θ1), then x(1) = √(2 sin θ1 / p) and
    y(1) = I1(θ1)/√(2p).
    """
    if not p > 0:
        raise ValueError(f"elastica_tip_quadrature: p must be > 0, got {p!r}")
    target = math.sqrt(2.0 * p)
    # I0 grows from 0 (θ1 → 0) to +∞ (θ1 → π/2): a bracketed root
    t1 = brentq(lambda th: _elastica_integrals(th)[0] - target, 1e-12, 0.5 * math.pi - 1e-6,
                xtol=1e-15, rtol=1e-15, maxiter=200)
    _, I1 = _elastica_integrals(t1)
    return math.sqrt(2.0 * math.sin(t1) / p), I1 / target, t1


def elastica_tip(p: float) -> Tuple[float, float, float]:
    """Tip (x(1), y(1), θ(1)) of the first mode of the cantilever elastica under a dead transverse
    tip load, θ'' + p cos θ = 0, θ(0) = 0, θ'(1) = 0, p > 0 (THEORY §6, Bisshopp–Drucker).

    With 1 + sin θ = 2k² sin²ψ, k² = (1 + sin θ1)/2 and sin ψ0 = 1/(√2 k):
        √p = K(k) − F(ψ0, k),   y(1) = 1 − (2/√p) [E(k) − E(ψ0, k)],   x(1) = √(2 sin θ1 / p).
    The unknown is q = 1 − sin θ1 = 2(1 − k²), found on a logarithmic scale, with K from
    ``ellipkm1`` (complementary parameter), so the form stays accurate when θ1 → π/2 (huge p);
    θ1 = π/2 − 2 asin(√(q/2)) without cancellation. For p < 1, where y(1) = 1 − (…) cancels,
    the quadrature form (:func:`elastica_tip_quadrature`) is used instead. Accurate to ~1e-14.
    """
    from scipy.special import ellipe, ellipeinc, ellipkinc, ellipkm1
    if not p > 0:
        raise ValueError(f"elastica_tip: p must be > 0, got {p!r}")
    if p < 1.0:
        return elastica_tip_quadrature(p)
    sp = math.sqrt(p)

    def parts(logq):
        q = math.exp(logq)
        m = 1.0 - 0.5 * q                       # k²
        psi0 = math.asin(1.0 / math.sqrt(2.0 - q))
        return q, m, psi0

    def F(logq):
        q, m, psi0 = parts(logq)
        return float(ellipkm1(0.5 * q)) - float(ellipkinc(psi0, m)) - sp

    # F decreases from +∞ (q → 0, K → ∞) to K(1/2) − F(π/2, 1/2) − √p = −√p < 0 at q = 1
    lo = -2.0 * sp - 10.0
    while F(lo) <= 0.0:
        lo *= 2.0
    logq = brentq(F, lo, 0.0, xtol=1e-15, rtol=1e-15, maxiter=300)
    q, m, psi0 = parts(logq)
    y = 1.0 - (2.0 / sp) * (float(ellipe(m)) - float(ellipeinc(psi0, m)))
    x = math.sqrt(2.0 * (1.0 - q) / p)
    theta1 = 0.5 * math.pi - 2.0 * math.asin(math.sqrt(0.5 * q))
    return x, y, theta1


#: (θ'(0), p) near the first two folds of the cantilever elastica, read off a scan of the
#: free-end residual M(1; θ'(0), p) (its local extrema that touch zero); the fold solver refines them
_ELASTICA_FOLD_GUESS = {1: (-2.8, 10.3), 2: (-3.7, 51.0)}


def elastica_fold(m: int = 1):
    """Fold (saddle-node) m of the field-free cantilever elastica, by shooting (THEORY §6, §8).

    Solves M(1; γ, p) = 0 and ∂M(1)/∂γ = 0 for (γ = θ'(0), p) with the shooting solver
    (DOP853 rtol 1e-12) and its variational equation, by MINPACK ``hybr``. At p = p_fold a pair of
    equilibria is born (they exist for p > p_fold near the fold state).

    Returns
    -------
    (p_fold, gamma_fold, solution) : float, float, ShootingSolution
    """
    from scipy.optimize import root
    if m not in _ELASTICA_FOLD_GUESS:
        raise ValueError(f"elastica_fold: m must be one of {sorted(_ELASTICA_FOLD_GUESS)}")

    def F(u):
        sol = shoot(u[0], ShootingParams(fy=u[1]), variational=True)
        return [sol.residual, sol.dresidual]

    out = root(F, _ELASTICA_FOLD_GUESS[m], method="hybr", options={"xtol": 1e-14})
    if not out.success or max(abs(v) for v in out.fun) > 1e-9:
        raise RuntimeError(f"elastica_fold({m}): {out.message}")
    g, p = (float(v) for v in out.x)
    return p, g, shoot(g, ShootingParams(fy=p))


def shooting_params_from_scene(scene: Scene) -> ShootingParams:
    """The uniform-field shooting parameters of a scene (no field → h = 0)."""
    if scene.field is not None and not scene.field.is_uniform:
        raise ValueError("shooting_params_from_scene: uniform fields only")
    f = scene.tip_force or (0.0, 0.0)
    q = scene.distributed_load or (0.0, 0.0)
    return ShootingParams(
        h=float(scene.h) if scene.field is not None else 0.0, phi=float(scene.phi),
        fx=float(f[0]), fy=float(f[1]), m=float(scene.tip_moment or 0.0), qx=float(q[0]), qy=float(q[1]),
        theta0=float(scene.theta0),
        alpha=scene.fibres.value if scene.fibres.is_constant else scene.fibres,
        b=scene.stiffness.value if scene.stiffness.is_constant else scene.stiffness)


# -- problems ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Problem:
    """A benchmark scene with its independent reference.

    Attributes
    ----------
    name, description : str
    scene : Scene
        Dimensionless scene (THEORY §5).
    guess : callable
        θ(s) (rad) for the cold start that selects the benchmarked branch; arrays of shape (n,).
    perturb : callable
        ``perturb(scene, eps) -> Scene``: the same structure with a parameter moved by ``eps``
        (relative, ~1e-3) — the warm re-solves of the timing protocol.
    reference_kind : {"closed_form", "shooting", "shooting_general"}
    reference_note : str
        Method and stated tolerance of the reference.
    reference_tol : float
        Stated bound on the reference's own tip error.
    gamma_guess : float
        θ'(0) guess for the shooting reference (uniform fields).
    """

    name: str
    description: str
    scene: Scene
    guess: Callable
    perturb: Callable
    reference_kind: str
    reference_note: str
    reference_tol: float
    gamma_guess: float = 0.0
    _closed: Optional[Callable] = field(default=None, repr=False)

    @property
    def uniform(self) -> bool:
        return self.scene.field is None or self.scene.field.is_uniform

    def reference_tip(self) -> Tuple[float, float, float]:
        """(x(1), y(1), θ(1)) of the reference (computed once, cached per problem name)."""
        return _reference_tip(self.name)

    def reference_at(self, scene: Scene) -> Tuple[float, float, float]:
        """Reference tip for a perturbed scene of this problem (not cached)."""
        return _compute_reference(self, scene)


def _compute_reference(prob: Problem, scene: Scene) -> Tuple[float, float, float]:
    if prob.reference_kind == "closed_form":
        return prob._closed(scene)
    if prob.reference_kind == "shooting":
        params = shooting_params_from_scene(scene)
        sol = solve_shooting(params, gamma_guess=prob.gamma_guess)
        if not sol.converged:
            raise RuntimeError(f"{prob.name}: shooting reference did not converge")
        return sol.tip
    if prob.reference_kind == "shooting_general":
        return _dipole_reference(scene).tip
    raise ValueError(prob.reference_kind)


#: references computed elsewhere (e.g. by parallel workers) for this process
_REF_OVERRIDE: Dict[str, Tuple[float, float, float]] = {}


def _reference_tip(name: str):
    if name in _REF_OVERRIDE:
        return _REF_OVERRIDE[name]
    return _reference_tip_cached(name)


@lru_cache(maxsize=None)
def _reference_tip_cached(name: str):
    prob = PROBLEMS[name]
    return tuple(float(v) for v in _compute_reference(prob, prob.scene))


def _dipole_reference(scene: Scene):
    """General shooting by continuation in h from the straight rod (γ = 0, n = f)."""
    target = bvp_from_scene(scene)
    f = scene.tip_force or (0.0, 0.0)
    u = np.array([0.0, f[0], f[1]])
    sol = None
    for lam in np.linspace(0.0, 1.0, 6)[1:]:
        bvp = replace(target, h=lam * target.h, h_pos=lam * target.h_pos)
        sol = shoot_general(bvp, u)
        if not sol.success:
            raise RuntimeError(f"dipole reference: continuation failed at λ = {lam:.2f}: {sol.message}")
        u = np.array([sol.Y[1, 0], sol.Y[4, 0], sol.Y[5, 0]])
    return sol


def _transverse_closed(scene: Scene):
    ref = transverse_mode(scene.h, 1)
    return (1.0 + ref.u1, ref.v1, ref.beta)


def _elastica_closed(scene: Scene):
    return elastica_tip(scene.p)


def _scale_h(scene, eps):
    return replace(scene, h=scene.h * (1.0 + eps))


def _scale_p(scene, eps):
    fx, fy = scene.tip_force
    return replace(scene, tip_force=(fx, fy * (1.0 + eps)))


_SHOOT_NOTE = "shooting (DOP853 rtol 1e-12, atol 1e-13, free-end residual <= 1e-10); tip error <= 1e-10"


def _build() -> Dict[str, Problem]:
    probs: List[Problem] = [
        Problem("paper_transverse", "paper case: transverse field phi=pi/2, h=1.5, p=0 (first mode)",
                default_scene(h=1.5, phi=0.5 * math.pi), guess=lambda s: 0.8 * np.sin(0.5 * math.pi * s),
                perturb=_scale_h, reference_kind="closed_form", _closed=_transverse_closed,
                reference_note="elliptic closed form (THEORY §6), ~1e-15", reference_tol=1e-14,
                gamma_guess=1.5),
        Problem("paper_axial", "paper case: axial field phi=0, h=1, tip load p=2",
                default_scene(h=1.0, phi=0.0, p=2.0), guess=lambda s: 0.3 * s, perturb=_scale_p,
                reference_kind="shooting", reference_note=_SHOOT_NOTE, reference_tol=1e-10, gamma_guess=0.6),
        Problem("elastica", "field-free elastica, tip load p=3 (no field term built)",
                Scene(field=None, tip_force=(0.0, 3.0), name="elastica p=3"), guess=lambda s: 0.5 * s,
                perturb=_scale_p, reference_kind="closed_form", _closed=_elastica_closed,
                reference_note="elastica first integral in quadrature (Bisshopp-Drucker), ~1e-13",
                reference_tol=1e-12, gamma_guess=2.0),
        Problem("oblique", "oblique field phi=1.0, h=1.3, p=0.7",
                default_scene(h=1.3, phi=1.0, p=0.7), guess=lambda s: 0.6 * s, perturb=_scale_h,
                reference_kind="shooting", reference_note=_SHOOT_NOTE, reference_tol=1e-10, gamma_guess=1.5),
        Problem("tilted_fibres", "tilted fibres alpha=0.5, phi=0.2, h=1.1, p=-0.5",
                default_scene(h=1.1, phi=0.2, p=-0.5, alpha=0.5), guess=lambda s: -0.3 * s,
                perturb=_scale_h, reference_kind="shooting", reference_note=_SHOOT_NOTE,
                reference_tol=1e-10, gamma_guess=-0.8),
        Problem("varying_fibres", "graded fibres alpha=0.8 sin(pi s/2), stiffness 1-0.4 s, phi=pi/3, h=1.2",
                Scene(field=UniformField(phi=math.pi / 3), h=1.2, fibres=expression_profile("0.8*sin(pi*s/2)"),
                      stiffness=expression_profile("1 - 0.4*s"), tip_force=(0.0, 0.0), name="varying fibres"),
                guess=lambda s: 0.5 * s, perturb=_scale_h, reference_kind="shooting",
                reference_note=_SHOOT_NOTE, reference_tol=1e-10, gamma_guess=1.0),
        Problem("tip_load", "general tip load f=(-0.8, 1.5), m=0.4, field h=1, phi=0.6",
                Scene(field=UniformField(phi=0.6), h=1.0, tip_force=(-0.8, 1.5), tip_moment=0.4,
                      name="general tip load"),
                guess=lambda s: 0.6 * s, perturb=_scale_h, reference_kind="shooting",
                reference_note=_SHOOT_NOTE, reference_tol=1e-10, gamma_guess=1.5),
        Problem("dipole", "point dipole at (0.5, 0.8), moment along c2, h=0.12, h_pos=0.06",
                Scene(field=DipoleField(x0=0.5, y0=0.8, moment_angle=0.5 * math.pi), h=0.12, h_pos=0.06,
                      tip_force=None, name="dipole field"),
                guess=lambda s: 0.2 * s, perturb=_scale_h, reference_kind="shooting_general",
                reference_note="general shooting with the internal force as state (DOP853 rtol 1e-12, "
                               "MINPACK hybr, continuation in h); tip error <= 1e-9",
                reference_tol=1e-9),
    ]
    return {p.name: p for p in probs}


PROBLEMS: Dict[str, Problem] = _build()


def problem_names() -> List[str]:
    return list(PROBLEMS)


def get_problem(name: str) -> Problem:
    try:
        return PROBLEMS[name]
    except KeyError:
        raise ValueError(f"unknown benchmark problem {name!r}; choose from {', '.join(PROBLEMS)}") from None
