"""The least-effort hardware setting that puts the tip on a target: a trust-region SQP over the
forward map (:class:`~actuator_design.hardware.map.HardwareMap`), each step a small quadratic programme (issue 19
item 2). Written for coil currents; a magnet's pose (:mod:`actuator_design.hardware.pose_design`) is the same problem with
its travel as the box, the least move as the effort and its clearance as the pointwise limit.

Unknowns: the coil weights w (n,), I_k = w_k I_k⁰. Problem:

    min  Σ c_k (w_k − w̄_k)²                  (c_k = R_k I_k⁰² : the coils' power, W; or I_k⁰²; w̄ = 0)
    s.t. tip(w) = target                     (m = 2 or 3 equations)
         lo_k ≤ w_k ≤ hi_k                   (each driver's limit: ±I_max,k / |I_k⁰|)
         Σ R_k I_k⁰² w_k² ≤ P_max            (total power, when given)
         c(r_q; w) ≤ c_max                   (|ĥ|² ≤ ĥ_max²: the field the rod sees, at its quadrature points)

Each step linearises the tip and the field at the current w (exact derivatives from the map) and
solves the quadratic programme in the step d, inside a trust region |d|∞ ≤ Δ; where the linearised
target cannot be met within the limits it takes the step that comes nearest (least squares). A
step is taken only where the map can follow the equilibrium to it (stable all the way) and it
brings the tip nearer, or keeps it within tolerance and lowers the effort; otherwise Δ shrinks.
The quadratic programmes are solved by scipy's SLSQP (a few unknowns, no forward solves); with as
many unknowns as tip equations the linearised target alone fixes the step.
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
#: evaluations of the Levenberg–Marquardt projection onto the target; iterations of the feasible
#: descent along it (each bounds the work; the verdict rests on the tip, limits and stability)
PROJECTION_STEPS, DESCENT_ITERATIONS = 60, 60
#: the projection gives up after this many refused steps in a row (each must cut the miss by 0.1 %)
PROJECTION_REFUSALS = 6
#: the feasible descent aims along the tip's singular directions with σ ≥ this × σ1 only
RESOLVED = 1e-4
#: the tips within reach form a thin band where σ_min < THIN_BAND σ1 (the tip's Jacobian over the
#: unknowns' scales): a search that ends there off the target, no limit binding, stopped short
THIN_BAND = 1e-2
#: first-order optimality of the feasible descent's end point (relative residual of the gradient:
#: where the tip's Jacobian is nearly singular, σ2/σ1 ~ 1e-3, the tip tolerance leaves ~1e-4)
KKT_TOL = 1e-3
#: on the target with the trust region below this, the SQP hands over to the feasible descent
SWITCH_DELTA = 1e-3
#: SLSQP's tolerance on the scaled effort (O(1)) and iteration cap on each step's programme; its
#: last iterate is taken if it keeps the constraints (the SQP's merit test judges every step)
QP_FTOL, QP_ITERATIONS = 1e-12, 200


@dataclass
class CurrentProblem:
    """The data of the SQP (dimensionless weights; see the module docstring).

    Attributes
    ----------
    target : ndarray, shape (m,)
        Tip x, y (and angle) in rod lengths (rad).
    cost : ndarray, shape (n,)
        c_k of the effort Σ c_k (w_k − w̄_k)².
    bound : ndarray, shape (n,)
        |w_k| ≤ bound_k (when ``lower`` and ``upper`` are not given).
    power : ndarray, shape (n,) or None
        R_k I_k⁰² (W at w = 1), with ``max_power`` (W); None: no power limit.
    max_limit : float
        The cap on the map's pointwise quantity (ĥ_max² for currents; inf: no limit).
    tip_tol : float
        The tip must meet the target to this (rod lengths, rad).
    lower, upper : ndarray, shape (n,), optional
        lo_k ≤ w_k ≤ hi_k instead of ±bound_k.
    centre : ndarray, shape (n,), optional
        w̄ of the effort (zero when not given).
    """

    target: np.ndarray
    cost: np.ndarray
    bound: np.ndarray
    power: Optional[np.ndarray] = None
    max_power: float = math.inf
    max_limit: float = math.inf
    tip_tol: float = 1e-8
    lower: Optional[np.ndarray] = None
    upper: Optional[np.ndarray] = None
    centre: Optional[np.ndarray] = None

    def __post_init__(self):
        self.lo = -np.asarray(self.bound, float) if self.lower is None else np.asarray(self.lower, float)
        self.hi = np.asarray(self.bound, float) if self.upper is None else np.asarray(self.upper, float)
        self.half = (self.hi - self.lo) / 2  # the scale of each unknown: its trust region is a fraction of it
        self.mid = np.zeros_like(self.hi) if self.centre is None else np.asarray(self.centre, float)


@dataclass
class SQPOutcome:
    """Where the SQP ended: ``w``, the evaluation there (``point``: tip, derivatives, state),
    ``reached`` (the tip within ``tip_tol``), ``iterations``, ``converged`` (a least-effort point,
    not only a feasible one: the SQP's last step was below :data:`STEP_TOL` in every unknown, or
    the feasible descent ended at a KKT point, :func:`_stationary`), ``stopped_short`` (the search
    ended off the target in a thin band with no limit binding, :func:`_stopped_short`: the target
    may be reachable), and
    ``history`` (per iteration: the tip error and the effort)."""

    w: np.ndarray
    point: dict
    reached: bool
    iterations: int
    converged: bool
    stopped_short: bool = False
    history: List[tuple] = field(default_factory=list)


def _effort(prob: CurrentProblem, w: np.ndarray) -> float:
    return float(np.dot(prob.cost, (w - prob.mid) ** 2))


def within_limits(prob: CurrentProblem, w: np.ndarray, pt: dict, slack: float = 1e-9) -> bool:
    """Whether the weights ``w`` and the field ``pt["limit"]`` they give the rod keep every limit (to
    ``slack``, relative)."""
    if np.any(w > prob.hi + slack * prob.half) or np.any(w < prob.lo - slack * prob.half):
        return False
    if prob.power is not None and float(np.dot(prob.power, w * w)) > prob.max_power * (1 + slack):
        return False
    return not (math.isfinite(prob.max_limit) and float(np.max(pt["limit"])) > prob.max_limit * (1 + slack))


def _qp_step(prob: CurrentProblem, w: np.ndarray, pt: dict, delta: float, exact: bool,
             hess: Optional[np.ndarray] = None, lin: Optional[tuple] = None) -> tuple:
    """The step d of the linearised problem within the trust region |d_k| ≤ delta·bound_k: least
    effort meeting the target (``exact``: solved directly when there are as many unknowns as tip
    equations, else by SLSQP), or least tip miss (not ``exact``: bounded linear least squares, then
    shortened to keep the linearised power and field limits). Returns (d, solved): d None if there
    is no such step; ``solved`` when d is the programme's optimum (SLSQP converged), not only a
    feasible point of it. With ``hess`` (n, n) the effort is modelled as ∇f·d + ½ dᵀ hess d (the
    Lagrangian's curvature, :func:`_feasible_descent`) instead of itself; with ``lin`` = (J, e) the
    tip's linearisation is J d + e = 0 instead of the map's own."""
    from scipy.optimize import minimize

    if not exact:
        return _least_miss_step(prob, w, pt, delta), False
    m = prob.target.size
    J, e = lin if lin is not None else (pt["tip_jac"][:m], pt["tip"][:m] - prob.target)
    scale = max(float(np.sum(prob.cost)), 1e-300)
    cons = []
    cons.append({"type": "eq", "fun": lambda d: J @ d + e, "jac": lambda d: J})

    def fun(d):
        if hess is not None:
            g = 2 * prob.cost * (w - prob.mid)
            return (float(g @ d) + 0.5 * float(d @ hess @ d)) / scale, (g + hess @ d) / scale
        v = w + d - prob.mid
        return float(np.dot(prob.cost, v * v)) / scale, 2 * prob.cost * v / scale
    if prob.power is not None:
        cons.append({"type": "ineq", "fun": lambda d: (prob.max_power - float(np.dot(prob.power, (w + d) ** 2))) / prob.max_power,
                     "jac": lambda d: -2 * prob.power * (w + d) / prob.max_power})
    bounds = _box(prob, w, delta)
    if math.isfinite(prob.max_limit):
        h2, G = np.asarray(pt["limit"], float), np.asarray(pt["limit_jac"], float)
        cap = prob.max_limit * (1 - FIELD_MARGIN)
        # only rows the box can bring to the cap (max of G_i·d over it: Σ_k max(G_ik lo_k, G_ik hi_k))
        lo, hi = (np.array(v, float) for v in zip(*bounds))
        reach = h2 + np.sum(np.maximum(G * lo, G * hi), axis=1)
        rows = np.flatnonzero(reach >= cap)
        if rows.size:
            h2, G = h2[rows], G[rows]
            cons.append({"type": "ineq", "fun": lambda d: (cap - h2 - G @ d) / prob.max_limit,
                         "jac": lambda d: -G / prob.max_limit})
    lo, hi = (np.array(v, float) for v in zip(*bounds))
    if J.shape[0] == J.shape[1] and np.linalg.cond(J) < 1e12:
        d = np.linalg.solve(J, -e)  # as many unknowns as equations: the step is the linearised target's
        solved = True
    else:
        res = minimize(fun, np.clip(np.zeros_like(w), lo, hi), jac=True, method="SLSQP", bounds=bounds,
                       constraints=cons, options={"ftol": QP_FTOL, "maxiter": QP_ITERATIONS})
        d, solved = np.asarray(res.x, float), bool(res.success)
    # a step that keeps the linearised problem's constraints is taken, optimal or not (SLSQP at its
    # iteration limit included: the SQP judges it by its merit); only an optimal one may end the SQP
    if not np.all(np.isfinite(d)) or np.max(np.abs(J @ d + e)) > 1e-9 + 1e-6 * np.max(np.abs(e)):
        return None, False
    span = np.maximum(hi - lo, 1e-300)
    if np.any(d < lo - 1e-12 * span) or np.any(d > hi + 1e-12 * span):
        return None, False
    if any(np.min(np.atleast_1d(c["fun"](d))) < -1e-12 for c in cons if c["type"] == "ineq"):
        return None, False
    return np.clip(d, lo, hi), solved


def _box(prob: CurrentProblem, w: np.ndarray, delta: float) -> list:
    """Bounds of the step: the limits and the trust region (a fraction of each unknown's scale)."""
    return [(max(lo - wk, -delta * b), min(hi - wk, delta * b)) for wk, lo, hi, b in zip(w, prob.lo, prob.hi, prob.half)]


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
    if math.isfinite(prob.max_limit):
        rate = pt["limit_jac"] @ d
        room = prob.max_limit * (1 - FIELD_MARGIN) - pt["limit"]
        grow = rate > 0
        if np.any(grow):
            t = min(t, max(0.0, float(np.min(room[grow] / rate[grow]))))
    d = t * d
    return d if np.all(np.isfinite(d)) and np.any(d != 0) else None


def _merit_weight(prob: CurrentProblem, w: np.ndarray, J: np.ndarray, mu: float) -> float:
    """The ℓ2 merit's penalty μ ≥ 2‖λ‖ (λ: least-squares multipliers of the tip equations,
    ∇f + Jᵀλ ≈ 0), never decreased."""
    grad = 2 * prob.cost * (w - prob.mid) / max(float(np.sum(prob.cost)), 1e-300)
    lam = np.linalg.lstsq(J.T, -grad, rcond=None)[0]
    return max(mu, 2.0 * float(np.linalg.norm(lam)) + 1e-3)


def least_effort_currents(prob: CurrentProblem, evaluate: Callable[[np.ndarray], Optional[dict]],
                          w0: np.ndarray, progress: Optional[Callable[[str], None]] = None,
                          restore_first: bool = False) -> SQPOutcome:
    """Run the SQP from ``w0`` (whose evaluation must succeed, within the limits); see the module
    docstring. Every step taken keeps the limits, so the point returned does.

    ``evaluate(w)`` returns the map's point at w (``tip``, ``tip_jac``, ``limit``, ``limit_jac``) or None
    where the equilibrium cannot be followed there. Steps are judged by the ℓ2 merit
    φ = f + μ‖tip − target‖ (actual against predicted decrease), with one second-order correction
    (the tip equations re-linearised at the trial point) before a step is refused. Where the SQP
    stops short of the target, a Levenberg–Marquardt projection (:func:`_project`) tries to meet it;
    where it is on the target but has not settled (its trust region collapsed), the feasible
    descent (:func:`_feasible_descent`) lowers the effort along the target. With ``restore_first``
    the projection comes first, and where it meets the target the feasible descent follows without
    the SQP (for maps whose tip Jacobian is nearly singular, where the merit's linear model fails:
    a magnet's pose, :mod:`actuator_design.hardware.pose_design`)."""
    m = prob.target.size
    scale = max(float(np.sum(prob.cost)), 1e-300)
    f = lambda w: _effort(prob, w) / scale
    resid = lambda p: p["tip"][:m] - prob.target
    phi = lambda w, p, mu: f(w) + mu * float(np.linalg.norm(resid(p)))
    w = np.asarray(w0, float).copy()
    pt = evaluate(w)
    history, converged, it = [], False, 0
    if restore_first:
        w, pt, _ = _project(prob, evaluate, w, pt)
        if float(np.max(np.abs(resid(pt)))) <= prob.tip_tol:
            w, pt, it, converged = _feasible_descent(prob, evaluate, w, pt, it, history, progress)
            return SQPOutcome(w=w, point=pt, reached=True, iterations=it, converged=converged, history=history)
    # the SQP; then, where it did not settle on the target, a projection onto it and the feasible descent
    delta, mu = DELTA_START, 0.0
    for it in range(1, MAX_ITERATIONS + 1):
        e, J = resid(pt), pt["tip_jac"][:m]
        err = float(np.max(np.abs(e)))
        history.append((err, _effort(prob, w)))
        if err > prob.tip_tol and len(history) > STALL_ITERATIONS and \
                err > (1 - STALL_FRACTION) * history[-1 - STALL_ITERATIONS][0]:
            break  # the target is out of reach here: the miss no longer shrinks (the nearest found)
        if err <= prob.tip_tol and delta < SWITCH_DELTA:
            break  # on the target, the trust region collapsed: the merit's linear model fails here
        if progress is not None:
            progress(f"  iteration {it}: tip miss {err:.3g}, effort {_effort(prob, w):.6g}")
        d, exact = _qp_step(prob, w, pt, delta, exact=True)
        if d is None:
            d, _ = _qp_step(prob, w, pt, delta, exact=False)
        if d is None:
            break
        step = float(np.max(np.abs(d) / prob.half))
        if step <= STEP_TOL:
            converged = exact and err <= prob.tip_tol
            break
        mu = _merit_weight(prob, w, J, mu)
        closer = float(np.linalg.norm(e)) - float(np.linalg.norm(e + J @ d))
        if closer > 0 and f(w + d) > f(w):  # a step towards the target that costs effort: μ large enough
            mu = max(mu, 2 * (f(w + d) - f(w)) / closer)  # that the model predicts ≥ μ/2 of its approach
        pred = f(w) - f(w + d) + mu * closer
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
                trial = np.clip(trial, prob.lo - w, prob.hi - w)
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
    if float(np.max(np.abs(resid(pt)))) > prob.tip_tol and not _limits_bind(prob, w, pt):
        w, pt, _ = _project(prob, evaluate, w, pt)  # (its steps keep the box only: not where a limit binds)
    if float(np.max(np.abs(resid(pt)))) <= prob.tip_tol and not converged:
        w, pt, it, converged = _feasible_descent(prob, evaluate, w, pt, it, history, progress)
    reached = float(np.max(np.abs(resid(pt)))) <= prob.tip_tol
    return SQPOutcome(w=w, point=pt, reached=reached, iterations=it, converged=converged, history=history,
                      stopped_short=not reached and _stopped_short(prob, w, pt))


def _stopped_short(prob: CurrentProblem, w: np.ndarray, pt: dict) -> bool:
    """Whether a search that ended off the target may have stopped short of it: no limit binds
    (the unknowns' bounds included) and the tips within reach form a thin band there (the tip's
    Jacobian over the unknowns' scales has σ_min < :data:`THIN_BAND` σ1), across which the search
    creeps — rather than ending at a nearest tip that limits or the rod's own reach explain."""
    if _limits_bind(prob, w, pt, bounds=True):
        return False
    m = prob.target.size
    sv = np.linalg.svd(pt["tip_jac"][:m] * prob.half, compute_uv=False)
    return bool(sv.size >= 2 and sv[-1] < THIN_BAND * sv[0])


def _limits_bind(prob: CurrentProblem, w: np.ndarray, pt: dict, bounds: bool = False) -> bool:
    """Whether the power or the pointwise limit (and with ``bounds`` an unknown's bound) is active
    at ``w`` (to 1e-6, relative)."""
    if prob.power is not None and float(np.dot(prob.power, w * w)) >= prob.max_power * (1 - 1e-6):
        return True
    if math.isfinite(prob.max_limit) and float(np.max(pt["limit"])) >= prob.max_limit * (1 - 1e-6):
        return True
    return bounds and bool(np.any(w >= prob.hi - 1e-6 * prob.half) or np.any(w <= prob.lo + 1e-6 * prob.half))


def _feasible_descent(prob: CurrentProblem, evaluate, w: np.ndarray, pt: dict, it: int, history: list,
                      progress=None):
    """Lower the effort while staying on the target: each step is the QP step of the linearised
    problem (the tip's linearised miss kept at zero, the limits, a trust region; the effort
    modelled with the Lagrangian's curvature, damped BFGS — on a strongly bent target set the
    constraint's curvature, times its large multiplier, dominates), followed by a
    projection back onto the target (:func:`_project`); it is taken when the projected point meets
    the target to ``tip_tol``, keeps every limit and lowers the effort by at least a tenth of the
    step's predicted decrease. Where the tip's Jacobian is nearly singular (the tips a rod can
    reach form a thin band) the SQP's merit mistakes the curvature of the thin direction for a
    miss and its trust region collapses; here the miss is never traded. Ends (``converged``) when
    the step falls below :data:`STEP_TOL`. Returns (w, pt, iterations, converged)."""
    delta, converged, last = DELTA_START, False, it + DESCENT_ITERATIONS
    m = prob.target.size
    grad = lambda v: 2 * prob.cost * (v - prob.mid)
    B = np.diag(2 * prob.cost).astype(float)  # the Lagrangian's Hessian, by damped BFGS
    while it < last:
        it += 1
        history.append((float(np.max(np.abs(pt["tip"][:m] - prob.target))), _effort(prob, w)))
        if progress is not None:
            progress(f"  iteration {it}: on the target, effort {_effort(prob, w):.6g}")
        d, solved = _qp_step(prob, w, pt, delta, exact=True, hess=B, lin=_resolved(prob, pt))
        if d is None:
            delta /= 4
            if delta < DELTA_MIN:
                break
            continue
        step = float(np.max(np.abs(d) / prob.half))
        if step <= STEP_TOL:
            converged = solved  # a least-effort point only when the step's programme was solved
            break
        pred = -(float(grad(w) @ d) + 0.5 * float(d @ B @ d))
        new = evaluate(w + d)
        taken = None
        if new is not None and pred > 0:
            # (onto the target well inside the tolerance: a point left at its edge would slide
            # along it, lowering the effort by the tolerance's worth, and never be stationary)
            w2, p2, _ = _project(prob, evaluate, w + d, new, goal=1e-2 * prob.tip_tol)
            if float(np.max(np.abs(p2["tip"][:m] - prob.target))) <= prob.tip_tol and within_limits(prob, w2, p2) \
                    and _effort(prob, w) - _effort(prob, w2) >= 0.1 * pred:
                taken = (w2, p2)
        if taken is None:
            delta = step / 4
            if delta < DELTA_MIN:
                break
            continue
        (w2, p2), s_ = taken, taken[0] - w
        lam = np.linalg.lstsq(p2["tip_jac"][:m].T, -grad(w2), rcond=None)[0]
        y = grad(w2) - grad(w) + (p2["tip_jac"][:m] - pt["tip_jac"][:m]).T @ lam
        B = _bfgs(B, s_, y)
        w, pt = w2, p2
        if step >= 0.99 * delta:
            delta = min(2 * delta, DELTA_MAX)
    return w, pt, it, converged or _stationary(prob, w, pt)


def _resolved(prob: CurrentProblem, pt: dict) -> tuple:
    """The tip's linearisation (J, e) kept to the directions it resolves: J's singular directions
    (over the unknowns' scales) with σ ≥ :data:`RESOLVED` σ1. Along the others the tip moves too
    little for a step to aim at — the projection onto the target (:func:`_project`) walks them."""
    m = prob.target.size
    J, e = pt["tip_jac"][:m], pt["tip"][:m] - prob.target
    U, sv, _ = np.linalg.svd(J * prob.half, full_matrices=False)
    keep = sv >= RESOLVED * sv[0]
    return U[:, keep].T @ J, U[:, keep].T @ e


def _bfgs(B: np.ndarray, s: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Powell's damped BFGS update of ``B`` by the step ``s`` and the change ``y`` of the
    Lagrangian's gradient (kept positive definite)."""
    Bs = B @ s
    sBs = float(s @ Bs)
    if sBs <= 0:
        return B
    sy = float(s @ y)
    if sy < 0.2 * sBs:
        theta = 0.8 * sBs / (sBs - sy)
        y, sy = theta * y + (1 - theta) * Bs, 0.2 * sBs
    return B + np.outer(y, y) / sy - np.outer(Bs, Bs) / sBs


def _stationary(prob: CurrentProblem, w: np.ndarray, pt: dict) -> bool:
    """First-order (KKT) optimality on the target, each unknown over its scale: the effort's
    gradient g is balanced, to :data:`KKT_TOL` relative, by the tip's gradients (multipliers of
    either sign), the active limits' (power, pointwise: multipliers ≥ 0) and the bounds an unknown
    sits at (≥ 0, pushing outwards only):

        g + Jᵀλ + Σ μ_i ∇c_i − ν_lo + ν_hi = 0,   μ, ν ≥ 0.

    Where the feasible descent's trust region has shrunk away (its projections no longer meet the
    target to ``tip_tol`` within the steps it tries), this says whether it stopped at a
    least-effort point."""
    from scipy.optimize import lsq_linear

    m = prob.target.size
    grad = 2 * prob.cost * (w - prob.mid) * prob.half
    if np.linalg.norm(grad) == 0.0:
        return True
    cols, lo = [(pt["tip_jac"][:m] * prob.half).T], [np.full(m, -np.inf)]
    if math.isfinite(prob.max_limit):
        active = pt["limit"] >= prob.max_limit * (1 - 1e-6)
        cols.append((pt["limit_jac"][active] * prob.half).T)
        lo.append(np.zeros(int(np.sum(active))))
    if prob.power is not None and float(np.dot(prob.power, w * w)) >= prob.max_power * (1 - 1e-6):
        cols.append((2 * prob.power * w * prob.half)[:, None])
        lo.append(np.zeros(1))
    eye = np.eye(w.size)
    at_lo, at_hi = w <= prob.lo + 1e-9 * prob.half, w >= prob.hi - 1e-9 * prob.half
    cols += [-eye[:, at_lo], eye[:, at_hi]]
    lo += [np.zeros(int(np.sum(at_lo))), np.zeros(int(np.sum(at_hi)))]
    A, lower = np.hstack(cols), np.concatenate(lo)
    x = lsq_linear(A, -grad, bounds=(lower, np.full(lower.size, np.inf))).x
    return bool(np.linalg.norm(A @ x + grad) <= KKT_TOL * np.linalg.norm(grad))


def _project(prob: CurrentProblem, evaluate, w: np.ndarray, pt: dict, goal: Optional[float] = None):
    """Levenberg–Marquardt onto the target: steps d = S u with (AᵀA + λI) u = −Aᵀe (A = J S, S the
    unknowns' scales, e the tip's miss), clipped to the limits, taken where the miss shrinks (λ
    then falls), refused otherwise (λ rises), for at most :data:`PROJECTION_STEPS` evaluations.
    Where the tip's Jacobian is nearly singular — a rod whose reachable tips form a thin band —
    the damping walks the thin direction only as far as its linearisation holds; the SQP's trust
    region, judged by a merit that mistakes that curvature for a miss, collapses there instead.
    Aims at a miss of ``goal`` (default ``tip_tol``). Returns (w, pt, moved)."""
    m = prob.target.size
    miss = lambda p: float(np.max(np.abs(p["tip"][:m] - prob.target)))
    goal = prob.tip_tol if goal is None else goal
    moved, lam, refused = False, None, 0
    for _ in range(PROJECTION_STEPS):
        if miss(pt) <= goal or refused >= PROJECTION_REFUSALS:
            break
        e, A = pt["tip"][:m] - prob.target, pt["tip_jac"][:m] * prob.half
        G = A.T @ A
        size = float(np.trace(G))
        if not (size > 0 and math.isfinite(size)):
            break  # the tip does not move with the unknowns here
        lam = 1e-3 * size if lam is None else min(max(lam, 1e-14 * size), 1e14 * size)
        u = np.linalg.lstsq(G + lam * np.eye(G.shape[0]), -A.T @ e, rcond=None)[0]
        d = np.clip(prob.half * u, prob.lo - w, prob.hi - w)
        new = evaluate(w + d)
        if new is not None and within_limits(prob, w + d, new) and \
                np.linalg.norm(new["tip"][:m] - prob.target) < (1 - 1e-3) * np.linalg.norm(e):
            w, pt, moved, refused = w + d, new, True, 0
            lam /= 4
        else:
            lam, refused = lam * 4, refused + 1
    return w, pt, moved
