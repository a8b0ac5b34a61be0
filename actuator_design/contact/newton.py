"""Newton's method on a contact NLP's KKT system with the contact set guessed (issue 20: the
≤ 10× benchmark).

A contact solve repeats on a new mesh round after round (the element boundaries moved to the
contact points, :mod:`actuator_design.contact.split`), and a loading path solves scene after scene a small step
apart. In both the set of pressing rows is known beforehand — the round before, the step before —
so the constrained minimum is a root of the KKT system of that set alone,

    ∇Ê(θ) + Jᵀ_A λ_A = 0,     g_A(θ) = 0,

(row 0 the clamp θ(0) = θ0, the others d(r(s_j)) − gap at the pressing points), which Newton's
method solves in a few linear solves where IPOPT's interior point needs 5–10 iterations of its
barrier. The root is accepted only if it is the constrained minimum IPOPT would find: every other
row feasible (d ≥ gap to round-off, :data:`ROW_TOL`) and every force pressing (μ = −λ ≥ 0 to round-off), and
it is then judged by the same checks as IPOPT's answer (residual, stability on the tangent space
of the pressing rows, penetration between the points). Otherwise (a contact appearing or
released, Newton not converging) the caller solves with IPOPT.
"""
from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from actuator_design.contact.report import ACTIVE, verdict
from actuator_design.reduced.linalg import FLOOR_STEP, within_rounding_floor

__all__ = ["newton_on_contact_set", "pressing_rows", "nothing_pressed", "kept_clear", "strict_minimum", "MAX_ITER",
           "SWEEP", "SWEEP_STEPS"]

#: Newton iterations before the guess is given up (quadratic convergence from a start within
#: a path step or a boundary move needs 3–6)
MAX_ITER = 12
#: the spacing (rod lengths of the largest point motion) at which Newton's way from its start to
#: its answer is checked against the obstacles (:func:`kept_clear`)
SWEEP = 0.005
#: the most samples :func:`kept_clear` takes along a way
SWEEP_STEPS = 64
#: a KKT point whose stationarity is this fraction of the requested ``tol`` is solved (Newton's
#: next step would be below round-off)
SOLVED = 0.1
#: how far a row may be off its bound at the answer (rod lengths): round-off of d, not penetration
ROW_TOL = 1e-12
#: a multiplier this far below zero (relative to the largest force, and at least to 1) pulls:
#: the guessed set holds a row that should have lifted off
PULL_TOL = 1e-9


def newton_on_contact_set(nlp, z0: np.ndarray, P: np.ndarray, lbg: np.ndarray, rows: Sequence[int],
                          mass: np.ndarray, tol: float) -> Optional[Tuple[np.ndarray, np.ndarray, int]]:
    """The KKT point of ``nlp`` with the contact rows ``rows`` active (and the clamp row), or None.

    Parameters
    ----------
    nlp : ContactNLP
    z0 : ndarray, shape (n,)
        Start (nodal θ, rad).
    P : ndarray
        The NLP's parameters (:meth:`ContactNLP.parameters`).
    lbg : ndarray, shape (1 + n_rows,)
        Lower bounds of the rows; −inf marks an unused row.
    rows : sequence of int
        Indices (into g, ≥ 1) of the rows guessed to press.
    mass : ndarray, shape (n,)
        The transcription's mass (the stationarity is measured per unit mass, as the solver does).
    tol : float
        Stationarity to reach, max |∇L / mass| (dimensionless).

    Returns
    -------
    (z, lam_g, iterations, (∇L, ∇²L, ∂rows/∂z)) or None
        ``lam_g`` in CasADi's sign (L = Ê + λᵀg, so a pressing row has λ ≤ 0), zero off the set;
        the derivatives at the answer as :meth:`ContactNLP.lagrangian` gives them.
    """
    A = np.array([0] + sorted(set(int(r) for r in rows)), int)
    n, m = z0.size, A.size
    z, lam = np.array(z0, float), np.zeros(lbg.size)
    used = np.isfinite(lbg)
    small, last = False, np.inf

    def stationary(grad, H, z, target, last):
        # within ``target``, or within each unknown's rounding floor after a step below FLOOR_STEP
        # (the small end elements of a graded mesh beside a contact: |∇L|/m stalls at ~5e-10)
        return (np.max(np.abs(grad[1:] / mass[1:])) <= target
                or (last <= FLOOR_STEP and within_rounding_floor(grad[1:], H[1:, 1:], z[1:], mass[1:], target)))

    for it in range(MAX_ITER + 1):
        grad, H, jac, g = nlp.kkt(z, P, lam)
        if (small or it == MAX_ITER  # the answer's derivatives, evaluated once more after the last step
                or (it > 0 and stationary(grad, H, z, SOLVED * tol, last)
                    and np.max(np.abs(g[A] - lbg[A])) <= ROW_TOL)):
            small = True
            break
        K = np.zeros((n + m, n + m))
        J = np.vstack([np.eye(1, n), jac[A[1:] - 1]])  # the clamp row's gradient, then the contacts'
        K[:n, :n], K[:n, n:], K[n:, :n] = H, J.T, J
        rhs = -np.concatenate([grad, g[A] - lbg[A]])
        if not np.all(np.isfinite(K)) or not np.all(np.isfinite(rhs)):
            return None
        try:
            step = np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            return None
        z += step[:n]
        lam[A] += step[n:]
        last = float(np.max(np.abs(step[:n])))
        small = bool(last <= 1e-13 * (1.0 + np.max(np.abs(z))))
    if not small or not np.all(np.isfinite(grad)) or not stationary(grad, H, z, tol, last):
        return None
    if np.max(np.abs(g[A] - lbg[A])) > ROW_TOL:
        return None
    free = used.copy()
    free[A] = False
    if np.any(g[free] < lbg[free] - ROW_TOL):  # a row off the set entered its obstacle
        return None
    mu = -lam[A[1:]]
    if np.any(mu < -PULL_TOL * max(1.0, float(np.max(mu, initial=0.0)))):  # a row pulls the rod on
        return None
    return z, lam, it, (grad, H, jac)


def nothing_pressed(lam: np.ndarray) -> bool:
    """Whether no contact row of the multipliers ``lam`` (CasADi's sign, the clamp row first)
    carries a force (relative to :data:`~actuator_design.contact.report.ACTIVE`): a ramp step from
    such a state guesses that none presses after it either. (Carrying a pressing pair's force to the
    pairs chosen afresh for the next step was tried: Newton's answers passed every check, yet led a
    ramp where IPOPT's did not go on.)"""
    mu = -np.asarray(lam, float)[1:]
    return not np.any(mu > ACTIVE * max(1.0, float(np.max(mu, initial=0.0))))


def kept_clear(nlp, z0: np.ndarray, P: np.ndarray, newton) -> bool:
    """Whether the rows off the contact set stay clear along the straight way from the start to
    Newton's answer, sampled every :data:`SWEEP` (with self-contact rows: every gap, if less) of
    the largest motion of a constrained point (each row at least where it started, if that was
    inside by round-off); False for a way longer than :data:`SWEEP_STEPS` samples. Newton's one
    long step may jump a rod past a peg, where IPOPT's interior point keeps every iterate on the
    free side. (The samples were capped at 64 before, whatever the way's length: a thin strip's
    point could pass through the rod's own turn between two of them.)"""
    z, lam = newton[:2]
    free = lam[1:] == 0.0
    X0, Y0 = (np.asarray(v, float).ravel() for v in nlp.f_xy(z0))
    X1, Y1 = (np.asarray(v, float).ravel() for v in nlp.f_xy(z))
    # a point passing through the rod's own turn is inside it over 4·gap of its way
    spacing = min(SWEEP, nlp.gap) if nlp.slots else SWEEP
    steps = int(np.ceil(np.max(np.hypot(X1 - X0, Y1 - Y0), initial=0.0) / spacing))
    if steps > SWEEP_STEPS:  # too long a way to vouch for: IPOPT decides
        return False
    floor = np.minimum(np.asarray(nlp.f_rows(z0, P), float).ravel()[free], 0.0) - 1e-12
    for t in np.arange(1, steps + 1) / steps:
        if np.any(np.asarray(nlp.f_rows(z0 + t * (z - z0), P), float).ravel()[free] < floor):
            return False
    return True


def strict_minimum(nlp, newton, mass: np.ndarray):
    """The stability verdict of Newton's KKT point on the tangent space of its rows, and those rows
    (indices into the contact rows), when it is a stable constrained minimum (the Lagrangian's
    Hessian positive definite there: what IPOPT, a descent method, converges to); else None."""
    z, lam, _, (_, H, jac) = newton
    rows = np.flatnonzero(lam[1:] != 0.0)
    found = verdict(H[1:, 1:], jac[rows][:, 1:], mass[1:])
    return (found, rows) if found.stable else None


def pressing_rows(nlp, lam_before, refine, splits, self_rows: Sequence[int] = ()) -> Optional[List[int]]:
    """The rows (indices into g) guessed to press: those with a force in ``lam_before`` (the
    multipliers of the state before, on this NLP), or the rows at the contacts of ``refine`` (the
    round before, on another mesh: each interior obstacle contact now an element boundary of
    ``splits``, a tip contact the tip; its self-contacts the pair rows ``self_rows``, one per
    contact with both ends at boundaries); None when there is no guess (a self-contact the pairs
    do not hold)."""
    if lam_before is not None:
        mu = -np.asarray(lam_before, float)[1:]
        return list(1 + np.flatnonzero(mu > ACTIVE * max(1.0, float(np.max(mu, initial=0.0)))))
    if refine is None:
        return None
    rows, s_pts, m = [], np.asarray(nlp.s_points, float), nlp.n_points
    own = [p for p in refine.contact["points"] if p.get("self") and not p["weak"] and p["s"] < p["partner_s"]]
    if len(own) != len(self_rows):
        return None
    rows += list(self_rows)
    for p in refine.contact["points"]:
        if p["weak"] or p.get("self"):
            continue
        if p["obstacle"] is None:
            return None
        target = 1.0 if p["s"] == 1.0 else min(splits, key=lambda b: abs(b - p["s"]), default=None)
        j = int(np.argmin(np.abs(s_pts - target))) if target is not None else -1
        if target is None or abs(s_pts[j] - target) > 1e-12 or abs(target - p["s"]) > 0.05:
            return None
        rows.append(1 + p["obstacle"] * m + j)
    return rows
