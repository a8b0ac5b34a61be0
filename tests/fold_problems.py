"""Shared set-up of continuation tests: the field-free elastica near its first fold in p."""
import numpy as np
from scipy.optimize import fsolve

from actuator_design.continuation import BifurcationProblem
from actuator_design.options import SolverOptions
from actuator_design.reduced import reduced_system
from actuator_design.reference.shooting import ShootingParams, shoot
from actuator_design.scene import default_scene
from actuator_design.solver import get_solver


def elastica_fold_problem():
    """(problem, p1): continuation in p started at p1 + 1 on the first mode, p1 the fold load
    located independently by shooting (r = ∂r/∂γ = 0)."""
    def F(x):
        s = shoot(x[0], ShootingParams(fy=x[1]), variational=True)
        return [s.residual, s.dresidual]

    g1, p1 = fsolve(F, [-2.8, 10.3], xtol=1e-13)
    scene = default_scene(h=0.0, p=p1 + 1.0)
    solver = get_solver(scene, SolverOptions())
    guess = shoot(g1 + 0.2, ShootingParams(fy=p1 + 1.0))
    u0 = np.array([guess.theta(s) for s in solver.transcription.nodes[1:]])
    prob = BifurcationProblem(reduced_system(solver, ["p"]), solver.parameter_vector(scene), u0, p1 + 1.0)
    return prob, p1
