"""The contact NLP's Hessian and Jacobian assembled from their parts (actuator_design.contact_kkt)
against CasADi's own derivatives of the whole Lagrangian (IPOPT's nlp_hess_l and nlp_jac_g),
with a multiplier on every row (not only the pressing ones): a wall, a polygon, a peg, a curved
lumen and self-contact pairs."""
import math

import numpy as np
import pytest

from actuator_design.contact import contact_nlp
from actuator_design.equilibrium import solve
from actuator_design.obstacles import Lumen, Peg, Polygon, Wall
from actuator_design.profiles import expression_profile
from actuator_design.scene import Scene
from actuator_design.solver import get_solver

SCENES = {
    "wall": Scene(field=None, tip_force=(0.0, -1.0), obstacles=(Wall((0.0, -0.1), 0.5 * math.pi),)),
    "polygon": Scene(field=None, tip_force=(0.0, -1.0),
                     obstacles=(Polygon(((0.5, -0.5), (1.5, -0.5), (1.5, -0.1), (0.5, -0.1))),)),
    "peg": Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025),
    "lumen": Scene(field=None, contact_gap=0.01, obstacles=(
        Lumen((-0.1, 0.0), 0.0, 0.06, (("straight", 0.3), ("arc", 0.5, math.radians(70)), ("straight", 0.6))),)),
    "self-contact": Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01),
}


@pytest.mark.parametrize("name", list(SCENES))
def test_assembled_kkt_matches_casadi_derivatives_of_the_lagrangian(name):
    sc = SCENES[name]
    r = solve(sc)
    assert r.success, r.message
    solver = get_solver(sc, r.options)
    nlp = contact_nlp(solver, sc, bool(r.contact.get("self_contact")))
    _, pairs, lam = r._contact_multipliers
    P = nlp.parameters(solver.parameter_vector(sc), pairs)
    used = np.isfinite(nlp.bounds(pairs)[0])
    rng = np.random.default_rng(7)
    for mult in (lam, np.where(used, rng.normal(size=lam.size), 0.0)):
        z = r.z + 0.01 * rng.normal(size=r.z.size) * (np.arange(r.z.size) > 0)  # off the solution too
        for at in (r.z, z):
            _, H, jac, g = nlp.kkt(at, P, mult)
            triu = nlp.f_hess(at, P, 1.0, mult).full()
            H_ref = triu + triu.T - np.diag(np.diag(triu))
            g_ref, jac_ref = (m.full() for m in nlp.f_jac_g(at, P))
            # row and column 0 (the clamp's θ, fixed by its own row) are not assembled: module doc
            scale = np.max(np.abs(H_ref[1:, 1:]))
            assert np.max(np.abs(H[1:, 1:] - H_ref[1:, 1:])) <= 1e-8 * scale, name
            assert np.max(np.abs(jac - jac_ref[1:])) <= 1e-12 * max(1.0, np.max(np.abs(jac_ref))), name
            assert np.max(np.abs(g - g_ref.ravel())) <= 1e-13, name
