"""Shared set-up of fold tests: shooting folds, and the field-free elastica near its first fold."""
import numpy as np
from scipy.optimize import fsolve

from actuator_design.continuation import BifurcationProblem
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reduced import reduced_system
from actuator_design.reference.shooting import ShootingParams, shoot
from actuator_design.model.scene import default_scene
from actuator_design.equilibrium.solver import get_solver


def reference_fold(p_guess, gamma_guess, h=0.0):
    """(p, γ) of a fold of the shooting reference: r = ∂r/∂γ = 0 (THEORY §7), by fsolve."""
    def F(x):
        s = shoot(x[0], ShootingParams(h=h, fy=x[1]), variational=True)
        return [s.residual, s.dresidual]
    # Converged is judged by the residual, not by fsolve's step test: the shooting residual carries
    # round-off of ~1e-16 (DOP853 at rtol 1e-12), so a step test at xtol = 1e-13 can fail on one
    # BLAS/scipy build and pass on another at the same answer ("not making good progress", ier 5).
    # At a regular fold the Jacobian of (r, r_γ) is non-singular, so |F| ≤ 1e-11 puts (γ, p)
    # within ~1e-10 of the fold.
    sol, info, ier, msg = fsolve(F, [gamma_guess, p_guess], xtol=1e-12, full_output=True)
    assert np.max(np.abs(info["fvec"])) <= 1e-11, f"shooting fold not located: {msg}"
    return sol[1], sol[0]


def elastica_fold_problem():
    """(problem, p1): continuation in p started at p1 + 1 on the first mode, p1 the fold load
    located independently by shooting (:func:`reference_fold`)."""
    p1, g1 = reference_fold(10.3, -2.8)
    scene = default_scene(h=0.0, p=p1 + 1.0)
    solver = get_solver(scene, SolverOptions())
    guess = shoot(g1 + 0.2, ShootingParams(fy=p1 + 1.0))
    u0 = np.array([guess.theta(s) for s in solver.transcription.nodes[1:]])
    prob = BifurcationProblem(reduced_system(solver, ["p"]), solver.parameter_vector(scene), u0, p1 + 1.0)
    return prob, p1
