"""Energy descent from a given start: the minimiser of the loading path's escapes.

Past a branch point the path from rest leaves the unstable state along its unstable mode, and at a
fold it snaps (:mod:`actuator_design.continuation.from_rest`): both mean *minimise the energy from
here*, and the answer must be the minimum that descent from the start reaches — not one that
depends on how many iterations a solver was allowed. IPOPT with an exact Hessian does that; in a
fitted field IPOPT runs quasi-Newton (the exact Hessian of the whole energy would take seconds to
build) and spent its whole iteration cap in the stiff well next to a magnet, so that the state
reached hinged on that cap.

:func:`trust_region_descent` minimises with the exact Hessian the kernel already evaluates (the
structured Φᵀ K Φ of a fitted field included): scipy's ``trust-exact`` (Moré–Sorensen trust-region
Newton; every accepted step lowers the energy, so it cannot climb back over the unstable state),
in the mass-weighted unknowns y = M^½ u, in which the trust region is a ball of the L² norm of the
rotation of the rod (rad) whatever the mesh. Its end is handed to the damped Newton of
:mod:`.newton`, which converges by the package's one rule. The sequence of iterates does not depend
on the iteration cap: the cap only decides whether the descent is reported as finished.
"""
from __future__ import annotations

import warnings
from typing import Callable

import numpy as np
from scipy.optimize import minimize

from actuator_design.reduced.newton import RawSolution, damped_newton

__all__ = ["trust_region_descent", "DESCENT_MAX_ITER"]

#: most trust-region steps of one descent; a descent that has not reached a minimum by then failed
DESCENT_MAX_ITER = 2000
#: the descent hands over to Newton when the mass-weighted gradient norm is below this fraction of
#: the residual scale (Newton's basin: the gradient left is far above its rounding, far below the
#: forces)
HANDOVER = 1e-7
#: the first trust radius (L² norm of the rotation, rad)
FIRST_RADIUS = 0.05


class _NotFinite(ArithmeticError):
    """A gradient or Hessian with a non-finite entry: the descent cannot go on."""


def _finite(a: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(a)):
        raise _NotFinite
    return a


def trust_region_descent(kernel, energy: Callable[[np.ndarray], float], z0: np.ndarray,
                         theta0: float, scale: float, atol: float, xtol: float,
                         max_iter: int = DESCENT_MAX_ITER) -> RawSolution:
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
    scale : float
        The size of the forces (``EquilibriumSolver.residual_scale``): the descent stops at a
        gradient :data:`HANDOVER` times it.
    atol, xtol : float
        Newton's residual and step tolerances (:func:`~.newton.damped_newton`).
    max_iter : int
        Most trust-region steps; more is a failure (``converged=False``), never a different answer.

    Returns
    -------
    RawSolution
        ``iterations`` counts the trust-region and the Newton steps.
    """
    z = np.array(z0, float)
    z[0] = theta0
    root_m = 1.0 / np.sqrt(kernel.inv_mass)  # y = √m u
    full = z.copy()

    def unknowns(y):
        return y / root_m

    def fun(y):
        full[1:] = unknowns(y)
        e = energy(full)
        return e if np.isfinite(e) else np.inf  # a trial step to a non-finite energy is refused

    def grad(y):
        kernel.evaluate(unknowns(y), hessian=False)
        return _finite(kernel.g / root_m)

    def hess(y):
        kernel.evaluate(unknowns(y), hessian=True)
        return _finite(kernel.hessian_dense() / np.outer(root_m, root_m))

    y0 = z[1:] * root_m
    if not np.isfinite(fun(y0)):
        return RawSolution(z, False, "not_finite", "trust-region descent: energy not finite at the start", 0, np.inf)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy's notes on a step that cannot predict a decrease
            out = minimize(fun, y0, jac=grad, hess=hess, method="trust-exact",
                           options={"gtol": HANDOVER * scale, "maxiter": int(max_iter),
                                    "initial_trust_radius": FIRST_RADIUS})
    except (_NotFinite, ValueError, np.linalg.LinAlgError):  # (scipy's subproblem refuses a
        # non-finite matrix with ValueError: an overflow of the Hessian's shifted factor)
        return RawSolution(z, False, "not_finite", "trust-region descent: the energy's gradient or "
                           "Hessian is not finite where the descent went (a rod point on or inside a "
                           "field source?)", 0, np.inf)
    if not np.all(np.isfinite(out.x)) or int(out.nit) >= max_iter:
        z[1:] = unknowns(out.x) if np.all(np.isfinite(out.x)) else z[1:]
        return RawSolution(z, False, "max_iter",
                           f"trust-region descent: no minimum within {max_iter} steps", int(out.nit), np.inf)
    z[1:] = unknowns(out.x)
    raw = damped_newton(kernel, z, theta0, atol, xtol, 50)
    raw.iterations += int(out.nit)
    raw.message = f"trust-region descent ({int(out.nit)} steps), then " + raw.message
    return raw
