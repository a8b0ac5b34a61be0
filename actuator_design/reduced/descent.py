"""Energy descent from a given start: the minimiser of the loading path's escapes in fitted fields.

Past a branch point the path from rest leaves the unstable state along its unstable mode, and at a
fold it snaps (:mod:`actuator_design.continuation.from_rest`): both mean *minimise the energy from
here*, and the answer must be the minimum that descent from the start reaches — not one that
depends on how many iterations a solver was allowed. IPOPT with the exact Hessian does that. In a
fitted field IPOPT runs quasi-Newton (the exact Hessian of the whole energy would take seconds to
build as an expression); it spent its whole iteration cap in the stiff well next to a magnet, and
the state reached hinged on that cap.

:func:`trust_region_descent` minimises with the exact Hessian the kernel evaluates (the structured
Φᵀ K Φ of a fitted field; such meshes are small, n ≤ ``MAX_DENSE_UNKNOWNS``): a trust-region Newton
method (Moré & Sorensen 1983; Nocedal & Wright 2006, alg. 4.1 and §4.3) in the mass-weighted
unknowns y = M^½ u, in which the trust region is a ball of the L² norm of the rod's rotation (rad)
whatever the mesh, the subproblem solved exactly in the Hessian's eigenbasis. Every accepted step
lowers the energy, so the descent cannot climb back over the unstable state it left. It hands over
to the damped Newton of :mod:`.newton` (the package's one convergence rule) only where the Hessian is
positive definite and the Newton step, inside the trust region, has fallen below
:data:`HANDOVER_STEP` — deep in Newton's basin of a minimum — and never at a point merely of small
gradient. The iterates do not depend on the
iteration cap; the cap only decides whether the descent is reported as finished.
"""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np

from actuator_design.reduced.newton import RawSolution, damped_newton

__all__ = ["trust_region_descent", "DESCENT_MAX_ITER"]

#: most trust-region steps of one descent; a descent that has not reached Newton's basin by then failed
DESCENT_MAX_ITER = 2000
#: most Newton steps of the finish (from inside Newton's basin it converges quadratically)
NEWTON_FINISH = 50
#: the first and the largest trust radius (L² norm of the rotation, rad)
FIRST_RADIUS = 0.05
MAX_RADIUS = 4.0
#: a step is taken when the energy falls by at least this fraction of the model's prediction
ACCEPT = 0.1
#: the descent hands over to Newton where the Hessian is positive definite and the Newton step is
#: below this (L² norm of the rotation, rad): well inside Newton's quadratic basin of that minimum
HANDOVER_STEP = 1e-6
#: the rounding of an energy value, relative: a Newton step in a convex well is taken while the
#: energy does not rise above it
NOISE = 1e-13


def _boundary_step(lam: np.ndarray, gq: np.ndarray, radius: float):
    """The minimiser of the model gᵀs + ½ sᵀ diag(λ) s on |s| = radius, in the eigenbasis (λ ascending;
    called when the Newton step is not inside): s(μ) = −g/(λ + μ) with |s(μ)| = radius and
    μ > max(0, −λ_0), found by bisection on μ (|s(μ)| decreases in μ) to round-off. Returns
    (s, hard): in the hard case (λ_0 ≤ 0 and g ⟂ the lowest eigenvectors, so that |s(μ)| stays
    below the radius) s(−λ_0) without those components, and the caller adds the lowest eigenvector
    to reach the boundary, choosing its sign."""
    low = max(0.0, -float(lam[0]))
    gnorm = float(np.linalg.norm(gq))
    shifted = lam + low
    lowest = shifted <= 1e-14 * max(1.0, float(np.max(np.abs(lam))))
    if lam[0] <= 0.0 and np.all(np.abs(gq[lowest]) <= 1e-12 * gnorm):
        s_low = np.where(lowest, 0.0, -gq / np.where(lowest, 1.0, shifted))
        if np.linalg.norm(s_low) <= radius:
            return s_low, True
    lo, hi = low, low + gnorm / radius + 1e-300
    while np.linalg.norm(gq / (lam + hi)) > radius:
        hi *= 2.0
    for _ in range(200):  # halves the bracket to round-off
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if np.linalg.norm(gq / (lam + mid)) > radius:
            lo = mid
        else:
            hi = mid
    s = -gq / (lam + hi)
    short = radius ** 2 - float(np.dot(s, s))
    if lam[0] <= 0.0 and short > 1e-12 * radius ** 2:
        # nearly the hard case: μ cannot come closer to −λ_0 than its rounding, and the step falls
        # short of the boundary; the rest of the way along the lowest eigenvector, downhill
        s[0] = (-1.0 if gq[0] > 0.0 else 1.0) * np.sqrt(s[0] ** 2 + short)
    return s, False


@np.errstate(over="ignore", divide="ignore", invalid="ignore")  # a Newton step through a near-zero
# eigenvalue is infinite, so judged too long: no warning on the user's terminal
def trust_region_descent(kernel, energy: Callable[[np.ndarray], float], z0: np.ndarray,
                         theta0: float, atol: float, xtol: float, max_iter: int = DESCENT_MAX_ITER,
                         admissible: Optional[Callable[[np.ndarray], bool]] = None) -> RawSolution:
    """Minimise the reduced energy from ``z0`` by trust-region Newton, then converge by Newton.

    Parameters
    ----------
    kernel : FastKernel
        With its parameters already set (gradient and exact Hessian in the free unknowns).
    energy : callable
        ``z (n + 1,) -> Ê``, the energy at the full node vector (θ_0 the clamp angle).
    z0 : ndarray, shape (n + 1,)
        Start (θ at the nodes, rad; θ_0 is reset to ``theta0``).
    theta0 : float
        Clamp angle (rad).
    atol, xtol : float
        Newton's residual and step tolerances (:func:`~.newton.damped_newton`).
    max_iter : int
        Most trust-region steps; more is a failure (``converged=False``), never a different answer.
    admissible : callable, optional
        ``z (n + 1,) -> bool``: whether a trial state may be taken (e.g. the rod inside the region
        where a fitted field holds). A step to an inadmissible state is refused like one that
        raises the energy; a descent that cannot go on without one ends with status
        ``"inadmissible"``. Not asked when the start itself is not admissible.

    Returns
    -------
    RawSolution
        ``iterations`` counts the trust-region and the Newton steps. Not converged, with the
        reason in ``status`` and ``message``, when the derivatives are not finite, the descent
        found no decrease or ran out of steps, or Newton did not converge from its end.
    """
    z = np.array(z0, float)
    z[0] = theta0
    root_m = 1.0 / np.sqrt(kernel.inv_mass)  # y = √m u: the step s in y is M^½ Δu
    outer = np.outer(root_m, root_m)
    u = z[1:].copy()
    full = z.copy()

    def energy_at(v):
        full[1:] = v
        if admissible is not None and not admissible(full):
            return None
        e = energy(full)
        return e if np.isfinite(e) else np.inf

    def stop(status, message, it, refused=False):
        z[1:] = u
        if refused and status == "no_decrease":
            status, message = "inadmissible", message + ", every step it tried leaving the admissible states"
        return RawSolution(z, False, status, f"trust-region descent: {message}", it, np.inf)

    full[1:] = u
    if admissible is not None and not admissible(full):
        admissible = None  # a start already outside: the descent is not kept from where it is (its
        # end is judged by the caller)
    f = energy_at(u)
    if f is None or not np.isfinite(f):
        return stop("not_finite", "the energy at the start is not finite or not admissible", 0)
    radius, refused = FIRST_RADIUS, False
    for it in range(max_iter):
        kernel.evaluate(u, hessian=True)
        g = kernel.g / root_m
        H = kernel.hessian_dense() / outer
        if not (np.all(np.isfinite(g)) and np.all(np.isfinite(H))):
            return stop("not_finite", "the energy's gradient or Hessian is not finite", it)
        lam, Q = np.linalg.eigh(0.5 * (H + H.T))
        gq = Q.T @ g
        inside = bool(lam[0] > 0.0 and np.linalg.norm(gq / lam) <= radius)
        if inside:  # the Newton step is the model's minimiser
            sq = -gq / lam
            if np.linalg.norm(sq) <= HANDOVER_STEP:
                break  # Newton's basin of a minimum: hand over
        else:
            sq, hard = _boundary_step(lam, gq, radius)
            if hard:  # down the lowest mode; on a saddle itself (g ⟂ it) towards its tip entry ≥ 0
                sign = -np.sign(gq[0]) if gq[0] != 0.0 else (1.0 if Q[-1, 0] >= 0.0 else -1.0)
                sq[0] = sign * np.sqrt(max(radius ** 2 - float(np.dot(sq, sq)), 0.0))
        predicted = -float(np.dot(gq, sq) + 0.5 * np.dot(lam * sq, sq))
        step = Q @ sq
        trial = u + step / root_m
        f_trial = energy_at(trial)
        refused = f_trial is None  # (the last trial's: a descent that ends refused ends there)
        size = float(np.linalg.norm(step))
        ratio = (f - f_trial) / predicted if (f_trial is not None and predicted > 0.0) else -np.inf
        if inside and f_trial is not None and f_trial <= f + NOISE * abs(f):
            ratio = max(ratio, 1.0)  # a Newton step into a convex well whose decrease is below the
            # energy's rounding: the model, not the rounding, tells
        if ratio > ACCEPT:
            u, f = trial, f_trial
        if ratio < 0.25:
            radius = 0.25 * size
        elif ratio > 0.75 and size > 0.99 * radius:
            radius = min(2.0 * radius, MAX_RADIUS)
        if radius <= 1e-13:
            return stop("no_decrease", "no step lowers the energy (trust radius below 1e-13 rad)", it + 1, refused)
    else:
        return stop("max_iter", f"no minimum within {max_iter} steps", max_iter, refused)
    z[1:] = u
    raw = damped_newton(kernel, z, theta0, atol, xtol, NEWTON_FINISH)
    raw.iterations += it
    raw.message = f"trust-region descent ({it} steps), then " + raw.message
    return raw
