"""The contact NLP's Hessian and Jacobian assembled from their parts (actuator_design.contact.kkt)
against CasADi's own derivatives of the whole Lagrangian σÊ + λᵀg (built here from the NLP's
expressions), with a multiplier on every row (not only the pressing ones), on and off the
solution: a wall, a polygon, a peg, a curved lumen, self-contact pairs and a wall in a dipole's
field (an energy that reads positions); IPOPT with the assembled Hessian lands where it does with
its own, and an error inside the assembly is raised, not taken for a failed solve."""
import math

import casadi as ca
import numpy as np
import pytest

from actuator_design.contact.equilibrium import contact_nlp
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Lumen, Peg, Polygon, Wall
from actuator_design.model.profiles import expression_profile
from actuator_design.model.scene import DipoleField, Scene
from actuator_design.equilibrium.solver import get_solver

SCENES = {
    "wall": Scene(field=None, tip_force=(0.0, -1.0), obstacles=(Wall((0.0, -0.1), 0.5 * math.pi),)),
    "polygon": Scene(field=None, tip_force=(0.0, -1.0),
                     obstacles=(Polygon(((0.5, -0.5), (1.5, -0.5), (1.5, -0.1), (0.5, -0.1))),)),
    "peg": Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025),
    "lumen": Scene(field=None, contact_gap=0.01, obstacles=(
        Lumen((-0.1, 0.0), 0.0, 0.06, (("straight", 0.3), ("arc", 0.5, math.radians(70)), ("straight", 0.6))),)),
    "self-contact": Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01),
    "dipole": Scene(field=DipoleField(x0=0.5, y0=0.8, moment_angle=0.5 * math.pi), h=0.5, contact_gap=0.01,
                    obstacles=(Wall((0.0, 0.1), -0.5 * math.pi),)),
}


def _reference(nlp):
    """[z, P, σ, λ] -> (∇²(σÊ + λᵀg), ∂g/∂z, g) by CasADi's symbolic derivatives of the NLP."""
    prob = nlp._problem
    sigma, lam = ca.SX.sym("sigma"), ca.SX.sym("lam", prob["g"].numel())
    lag = sigma * prob["f"] + ca.dot(lam, prob["g"])
    return ca.Function("reference", [prob["x"], prob["p"], sigma, lam],
                       [ca.hessian(lag, prob["x"])[0], ca.jacobian(prob["g"], prob["x"]), prob["g"]])


@pytest.mark.parametrize("name", list(SCENES))
def test_assembled_kkt_matches_casadi_derivatives_of_the_lagrangian(name):
    sc = SCENES[name]
    r = solve(sc)
    assert r.success, r.message
    solver = get_solver(sc, r.options)
    nlp = contact_nlp(solver, sc, bool(r.contact.get("self_contact")))
    reference = _reference(nlp)
    _, pairs, lam, signs = r._contact_multipliers
    P = nlp.parameters(solver.parameter_vector(sc), pairs, signs)
    used = np.isfinite(nlp.bounds(pairs)[0])
    rng = np.random.default_rng(7)
    for mult in (lam, np.where(used, rng.normal(size=lam.size), 0.0)):
        z = r.z + 0.01 * rng.normal(size=r.z.size) * (np.arange(r.z.size) > 0)  # off the solution too
        for at in (r.z, z):
            sigma = 0.5 + rng.uniform()
            H_ref, jac_ref, g_ref = (m.full() for m in reference(at, P, sigma, mult))
            H_unit = reference(at, P, 1.0, mult)[0].full()
            _, H, jac, g = nlp.kkt(at, P, mult)
            # kkt: row and column 0 (the clamp's θ, fixed by its own row) carry no energy (module doc)
            scale = np.max(np.abs(H_unit[1:, 1:]))
            assert np.max(np.abs(H[1:, 1:] - H_unit[1:, 1:])) <= 1e-8 * scale, name
            assert np.max(np.abs(jac - jac_ref[1:])) <= 1e-12 * max(1.0, np.max(np.abs(jac_ref))), name
            assert np.max(np.abs(g - g_ref.ravel())) <= 1e-13, name
            # IPOPT's hess_lag: the whole matrix, the objective weighted by IPOPT's σ
            H_ipopt = nlp.lagrangian_hessian(at, P, sigma, mult)
            assert np.max(np.abs(H_ipopt - H_ref)) <= 1e-8 * np.max(np.abs(H_ref)), name


@pytest.mark.parametrize("name", ["lumen", "self-contact"])
def test_ipopt_with_the_assembled_hessian_lands_where_it_does_with_its_own(name):
    """A first contact round (the lumen from the rod laid along it; the coil with its contact pairs
    from the straight rod): the same iterations and the same minimiser as IPOPT with CasADi's own
    Hessian of the Lagrangian."""
    from actuator_design.contact.equilibrium import _lumen_start

    sc = SCENES[name]
    r = solve(sc)
    solver = get_solver(sc, r.options)
    nlp = contact_nlp(solver, sc, bool(r.contact.get("self_contact")))
    assert nlp._hess_callback is not None
    pairs, signs = r._contact_multipliers[1], r._contact_multipliers[3]
    P = nlp.parameters(solver.parameter_vector(sc), pairs, signs)
    lbg, ubg = nlp.bounds(pairs)
    z0 = (_lumen_start(sc, np.asarray(solver.transcription.nodes, float)) if name == "lumen"
          else np.asarray(r.z, float) * 0.9)
    own = ca.nlpsol("own", "ipopt", nlp._problem, {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                                                    "ipopt.tol": 1e-12, "ipopt.mu_strategy": "adaptive",
                                                    "ipopt.bound_relax_factor": 0.0})
    a = own(x0=z0, p=P, lbg=lbg, ubg=ubg)
    assembled = nlp.nlpsol(False)
    b = assembled(x0=z0, p=P, lbg=lbg, ubg=ubg)
    assert own.stats()["success"] and assembled.stats()["success"]
    assert abs(own.stats()["iter_count"] - assembled.stats()["iter_count"]) <= 1
    assert np.max(np.abs(np.asarray(a["x"]) - np.asarray(b["x"]))) < 1e-10


def test_an_error_inside_the_hessian_callback_is_raised_after_the_solve(monkeypatch):
    """IPOPT sees a failed evaluation; the error itself comes back from raise_callback_error, once."""
    from actuator_design.contact.kkt import RowDerivatives

    sc = SCENES["peg"]
    r = solve(sc)
    solver = get_solver(sc, r.options)
    nlp = contact_nlp(solver, sc)
    P = nlp.parameters(solver.parameter_vector(sc))
    lbg, ubg = nlp.bounds()

    def boom(*args, **kwargs):
        raise RuntimeError("boom in the assembly")

    monkeypatch.setattr(RowDerivatives, "rows_hessian_jacobian", boom)
    ipopt = nlp.nlpsol(False)
    ipopt(x0=np.zeros(r.z.size), p=P, lbg=lbg, ubg=ubg)
    assert not ipopt.stats()["success"]
    with pytest.raises(RuntimeError, match="boom in the assembly"):
        nlp.raise_callback_error()
    nlp.raise_callback_error()  # reported once
