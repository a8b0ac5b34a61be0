"""The least-effort currents that put the tip on a target: a trust-region SQP over the forward map
(:class:`~.current_map.CurrentMap`), each step a small quadratic programme (issue 19 item 2).

Unknowns: the coil weights w (n,), I_k = w_k I_k⁰. Problem:

    min  Σ c_k w_k²                          (c_k = R_k I_k⁰² : the coils' power, W; or I_k⁰²)
    s.t. tip(w) = target                     (m = 2 or 3 equations)
         |w_k| ≤ I_max,k / |I_k⁰|            (each driver's limit)
         Σ R_k I_k⁰² w_k² ≤ P_max            (total power, when given)
         |ĥ(r_q; w)|² ≤ ĥ_max²               (the field the rod sees, at its quadrature points)

Each step linearises the tip and the field at the current w (exact derivatives from the map) and
solves the quadratic programme in the step d, inside a trust region |d|∞ ≤ Δ; where the linearised
target cannot be met within the limits it takes the step that comes nearest (least squares). A
step is taken only where the map can follow the equilibrium to it (stable all the way) and it
brings the tip nearer, or keeps it within tolerance and lowers the effort; otherwise Δ shrinks.
The quadratic programmes are solved by scipy's SLSQP (a few unknowns, no forward solves).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

__all__ = ["CurrentProblem", "SQPOutcome", "least_effort_currents", "within_limits"]

#: iterations of the SQP (each one forward evaluation at least); the verdict never rests on it:
#: a design is judged by its tip, limits and stability, whatever the iteration count
MAX_ITERATIONS = 80
#: the trust region's first, smallest and largest half-widths, as fractions of each current limit
DELTA_START, DELTA_MIN, DELTA_MAX = 0.25, 1e-9, 1.0
#: the linearised field limit is kept this far (relative) inside the limit, so that a step whose
#: field comes out a little above the linear prediction is still within it
FIELD_MARGIN = 1e-6
#: a step below this (each coil's change over its limit) ends the SQP: a least-effort point
STEP_TOL = 1e-8
#: away from the target, the SQP stops once the miss shrank by less than this fraction over
#: this many iterations (it crawls along the edge of what the limits and the branch allow)
STALL_FRACTION, STALL_ITERATIONS = 1e-3, 6


@dataclass
class CurrentProblem:
    """The data of the SQP (dimensionless weights; see the module docstring).

    Attributes
    ----------
    target : ndarray, shape (m,)
        Tip x, y (and angle) in rod lengths (rad).
    cost : ndarray, shape (n,)
        c_k of the effort Σ c_k w_k².
    bound : ndarray, shape (n,)
        |w_k| ≤ bound_k.
    power : ndarray, shape (n,) or None
        R_k I_k⁰² (W at w = 1), with ``max_power`` (W); None: no power limit.
    max_h2 : float
        ĥ_max² (inf: no field limit).
    tip_tol : float
        The tip must meet the target to this (rod lengths, rad).
    """

    target: np.ndarray
    cost: np.ndarray
    bound: np.ndarray
    power: Optional[np.ndarray] = None
    max_power: float = math.inf
    max_h2: float = math.inf
    tip_tol: float = 1e-8


@dataclass
class SQPOutcome:
    """Where the SQP ended: ``w``, the evaluation there (``point``: tip, derivatives, state),
    ``reached`` (the tip within ``tip_tol``), ``iterations``, ``converged`` (the last step was
    below :data:`STEP_TOL` in every weight: a least-effort point, not only a feasible one), and ``history``
    (per iteration: the tip error and the effort)."""

    w: np.ndarray
    point: dict
    reached: bool
    iterations: int
    converged: bool
    history: List[tuple] = field(default_factory=list)


def _effort(prob: CurrentProblem, w: np.ndarray) -> float:
    return float(np.dot(prob.cost, w * w))


def within_limits(prob: CurrentProblem, w: np.ndarray, pt: dict, slack: float = 1e-9) -> bool:
    """Whether the weights ``w`` and the field ``pt["h2"]`` they give the rod keep every limit (to
    ``slack``, relative)."""
    if np.any(np.abs(w) > prob.bound * (1 + slack)):
        return False
    if prob.power is not None and float(np.dot(prob.power, w * w)) > prob.max_power * (1 + slack):
        return False
    return not (math.isfinite(prob.max_h2) and float(np.max(pt["h2"])) > prob.max_h2 * (1 + slack))


def _qp_step(prob: CurrentProblem, w: np.ndarray, pt: dict, delta: float, exact: bool) -> Optional[np.ndarray]:
    """The step d of the linearised problem within the trust region |d_k| ≤ delta·bound_k: least
    effort meeting the target (``exact``, SLSQP), or least tip miss (not ``exact``: bounded linear
    least squares, then shortened to keep the linearised power and field limits); None if there is
    no such step."""
    from scipy.optimize import minimize

    if not exact:
        return _least_miss_step(prob, w, pt, delta)
    m = prob.target.size
    e = pt["tip"][:m] - prob.target
    J = pt["tip_jac"][:m]
    scale = max(float(np.sum(prob.cost)), 1e-300)
    cons = []
    cons.append({"type": "eq", "fun": lambda d: J @ d + e, "jac": lambda d: J})

    def fun(d):
        v = w + d
        return float(np.dot(prob.cost, v * v)) / scale, 2 * prob.cost * v / scale
    if prob.power is not None:
        cons.append({"type": "ineq", "fun": lambda d: (prob.max_power - float(np.dot(prob.power, (w + d) ** 2))) / prob.max_power,
                     "jac": lambda d: -2 * prob.power * (w + d) / prob.max_power})
    if math.isfinite(prob.max_h2):
        h2, G = pt["h2"], pt["h2_jac"]
        cap = prob.max_h2 * (1 - FIELD_MARGIN)
        cons.append({"type": "ineq", "fun": lambda d: (cap - h2 - G @ d) / prob.max_h2,
                     "jac": lambda d: -G / prob.max_h2})
    bounds = _box(prob, w, delta)
    d0 = np.clip(np.zeros_like(w), [lo for lo, _ in bounds], [hi for _, hi in bounds])
    res = minimize(fun, d0, jac=True, method="SLSQP", bounds=bounds, constraints=cons,
                   options={"ftol": 1e-15, "maxiter": 200})
    d = np.asarray(res.x, float)
    if not np.all(np.isfinite(d)):
        return None
    if not res.success or np.max(np.abs(J @ d + e)) > 1e-9 + 1e-6 * np.max(np.abs(e)):
        return None
    return d


def _box(prob: CurrentProblem, w: np.ndarray, delta: float) -> list:
    """Bounds of the step: the current limits and the trust region (a fraction of each limit)."""
    return [(max(-b - wk, -delta * b), min(b - wk, delta * b)) for wk, b in zip(w, prob.bound)]


def _least_miss_step(prob: CurrentProblem, w: np.ndarray, pt: dict, delta: float) -> Optional[np.ndarray]:
    """argmin ‖J d + e‖ in the step's box (scipy ``lsq_linear``, rank-deficient J included),
    shortened to the largest fraction that keeps the power (exact) and the linearised field."""
    from scipy.optimize import lsq_linear

    m = prob.target.size
    e, J = pt["tip"][:m] - prob.target, pt["tip_jac"][:m]
    lo, hi = (np.array(v) for v in zip(*_box(prob, w, delta)))
    d = lsq_linear(J, -e, bounds=(lo, hi), method="bvls").x
    t = 1.0
    if prob.power is not None:  # Σ p (w + t d)² ≤ P: the larger root of a convex quadratic in t
        a, b, c = (float(np.dot(prob.power, d * d)), 2 * float(np.dot(prob.power, w * d)),
                   float(np.dot(prob.power, w * w)) - prob.max_power)
        if a > 0 and a + b + c > 0:
            t = min(t, max(0.0, (-b + math.sqrt(max(b * b - 4 * a * c, 0.0))) / (2 * a)))
    if math.isfinite(prob.max_h2):
        rate = pt["h2_jac"] @ d
        room = prob.max_h2 * (1 - FIELD_MARGIN) - pt["h2"]
        grow = rate > 0
        if np.any(grow):
            t = min(t, max(0.0, float(np.min(room[grow] / rate[grow]))))
    d = t * d
    return d if np.all(np.isfinite(d)) and np.any(d != 0) else None


def _merit_weight(prob: CurrentProblem, w: np.ndarray, J: np.ndarray, mu: float) -> float:
    """The ℓ2 merit's penalty μ ≥ 2‖λ‖ (λ: least-squares multipliers of the tip equations,
    ∇f + Jᵀλ ≈ 0), never decreased."""
    grad = 2 * prob.cost * w / max(float(np.sum(prob.cost)), 1e-300)
    lam = np.linalg.lstsq(J.T, -grad, rcond=None)[0]
    return max(mu, 2.0 * float(np.linalg.norm(lam)) + 1e-3)


def least_effort_currents(prob: CurrentProblem, evaluate: Callable[[np.ndarray], Optional[dict]],
                          w0: np.ndarray, progress: Optional[Callable[[str], None]] = None) -> SQPOutcome:
    """Run the SQP from ``w0`` (whose evaluation must succeed, within the limits); see the module
    docstring. Every step taken keeps the limits, so the point returned does.

    ``evaluate(w)`` returns the map's point at w (``tip``, ``tip_jac``, ``h2``, ``h2_jac``) or None
    where the equilibrium cannot be followed there. Steps are judged by the ℓ2 merit
    φ = f + μ‖tip − target‖ (actual against predicted decrease), with one second-order correction
    (the tip equations re-linearised at the trial point) before a step is refused."""
    m = prob.target.size
    scale = max(float(np.sum(prob.cost)), 1e-300)
    f = lambda w: float(np.dot(prob.cost, w * w)) / scale
    resid = lambda p: p["tip"][:m] - prob.target
    phi = lambda w, p, mu: f(w) + mu * float(np.linalg.norm(resid(p)))
    w = np.asarray(w0, float).copy()
    pt = evaluate(w)
    delta, mu, history, converged = DELTA_START, 0.0, [], False
    it = 0
    for it in range(1, MAX_ITERATIONS + 1):
        e, J = resid(pt), pt["tip_jac"][:m]
        err = float(np.max(np.abs(e)))
        history.append((err, _effort(prob, w)))
        if err > prob.tip_tol and len(history) > STALL_ITERATIONS and \
                err > (1 - STALL_FRACTION) * history[-1 - STALL_ITERATIONS][0]:
            break  # the target is out of reach here: the miss no longer shrinks (the nearest found)
        if progress is not None:
            progress(f"  iteration {it}: tip miss {err:.3g}, effort {_effort(prob, w):.6g}")
        d = _qp_step(prob, w, pt, delta, exact=True)
        exact = d is not None
        if d is None:
            d = _qp_step(prob, w, pt, delta, exact=False)
        if d is None:
            break
        step = float(np.max(np.abs(d) / prob.bound))
        if step <= STEP_TOL:
            converged = exact and err <= prob.tip_tol
            break
        mu = _merit_weight(prob, w, J, mu)
        pred = f(w) - f(w + d) + mu * (float(np.linalg.norm(e)) - float(np.linalg.norm(e + J @ d)))
        if pred <= 1e-15 * (1.0 + abs(phi(w, pt, mu))):
            converged = exact and err <= prob.tip_tol
            break
        taken = None
        for trial in (d, None):  # the step, then its second-order correction
            if trial is None:  # the Maratos case: the step's miss grew by its curvature, O(|d|²),
                # not by a jump to another branch (a miss far beyond the step's own size)
                if new is None or np.linalg.norm(resid(new)) > 2 * max(np.linalg.norm(e), np.linalg.norm(J @ d)):
                    break
                trial = d - np.linalg.lstsq(J, resid(new), rcond=None)[0]  # back onto the tip equations
                trial = np.clip(trial, -prob.bound - w, prob.bound - w)
            new = evaluate(w + trial)
            if new is None:
                continue
            ared = phi(w, pt, mu) - phi(w + trial, new, mu)
            if ared >= 0.1 * pred and within_limits(prob, w + trial, new):
                taken = (trial, new, ared)
                break
        if taken is None:
            delta = step / 4
            if delta < DELTA_MIN:
                break
            continue
        d, pt, ared = taken
        w = w + d
        if ared >= 0.75 * pred and step >= 0.99 * delta:
            delta = min(2 * delta, DELTA_MAX)
        elif ared < 0.25 * pred:
            delta = step / 2
    reached = float(np.max(np.abs(resid(pt)))) <= prob.tip_tol
    return SQPOutcome(w=w, point=pt, reached=reached, iterations=it, converged=converged, history=history)
