"""A toy energy term registered from inside this file (registration only, no edits elsewhere):
a distributed torsional spring ½ k (θ − θ*)² per unit length.

With bending alone (b = 1, no field, no loads) its Euler–Lagrange equation is θ'' = k (θ − θ*),
θ(0) = 0, θ'(1) = 0, whose closed form θ(s) = θ* (1 − cosh(√k (1 − s)) / cosh(√k)) is the
independent reference. The term is solved, continued in k through the parameter lens, designed
with, and refused by the shooting scan that does not know it.
"""
import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from actuator_design.physics import parameters as lens
from actuator_design.continuation.follow import continue_branch
from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.physics.parameters import plugin_parameter
from actuator_design.physics.registry import register_term, unregister_term
from actuator_design.physics.terms import EnergyTerm
from actuator_design.model.scene import Scene, UniformField

NAME = "toy_torsional_spring"


@pytest.fixture(scope="module", autouse=True)
def toy_term():
    @register_term(replace=True)
    class TorsionalSpring(EnergyTerm):
        """½ k (θ − θ*)² per unit length: a distributed torsional spring towards θ*."""

        name = NAME
        scalar_params = ("k_spring", "theta_star")
        parameters = (
            plugin_parameter(NAME, "k_spring", "torsional spring stiffness per unit length", "B0/l^2",
                             lower=0.0, residual="linear"),
            plugin_parameter(NAME, "theta_star", "rest angle of the spring", "rad"),
        )

        def density(self, kin, P):
            return 0.5 * P["k_spring"] * (kin.theta - P["theta_star"]) ** 2

    yield TorsionalSpring
    unregister_term(NAME)


def closed_form(s, k, theta_star):
    """θ(s) of θ'' = k(θ − θ*), θ(0) = 0, θ'(1) = 0."""
    r = math.sqrt(k)
    return theta_star * (1.0 - np.cosh(r * (1.0 - np.asarray(s))) / math.cosh(r))


def spring_scene(k=4.0, theta_star=0.5):
    return Scene(field=None, tip_force=None).with_term(NAME, k_spring=k, theta_star=theta_star)


def test_solve_matches_the_closed_form():
    sc = spring_scene(4.0, 0.5)
    r = solve(sc)
    assert r.success and r.stable
    s = np.linspace(0, 1, 41)
    assert np.max(np.abs(r.evaluate(s)["theta"] - closed_form(s, 4.0, 0.5))) < 1e-10
    assert r.tip["angle"] == pytest.approx(float(closed_form(1.0, 4.0, 0.5)), abs=1e-11)
    # the balance check is derived from the terms: the spring's torque enters it
    assert r.el_residual < 1e-8
    # the clamp moment is b θ'(0) = θ* √k tanh √k
    assert abs(r.clamp_moment) == pytest.approx(0.5 * 2.0 * math.tanh(2.0), rel=1e-8)


@pytest.mark.parametrize("theta0_deg", [200.0, 400.0])
def test_a_term_of_the_absolute_angle_is_not_solved_whole_turns_away(theta0_deg):
    """The spring pulls towards an absolute angle θ*, so the energy is not 2π-periodic in θ (the
    term does not declare ``periodic_in_theta``): a clamp angle beyond ±π is solved as it is, not
    turned back by whole turns. θ'' = k(θ − θ*), θ(0) = θ0, θ'(1) = 0: θ(1) = θ* + (θ0 − θ*)/cosh √k,
    IPOPT's own answer included."""
    from actuator_design.equilibrium.solver import get_solver
    th0 = math.radians(theta0_deg)
    sc = dataclasses.replace(spring_scene(4.0, 0.5), theta0=th0)
    exact = 0.5 + (th0 - 0.5) / math.cosh(2.0)
    r = solve(sc, SolverOptions(method="ipopt"))
    assert r.success and r.tip["angle"] == pytest.approx(exact, abs=1e-8)
    solver = get_solver(sc, SolverOptions())
    params = solver.parameter_vector(sc)
    raw = solver.solve_ipopt(solver.initial_guess(params), params)
    assert raw.converged and raw.z[-1] == pytest.approx(exact, abs=1e-6)


def test_lens_knows_the_plugin_parameters():
    p = lens.parameter("k_spring")
    assert p.term == NAME and p.unit == "B0/l^2"
    sc = lens.set_value(Scene(field=None, tip_force=None), "k_spring", 2.5)  # adds the term
    assert sc.term_values(NAME) == {"k_spring": 2.5}
    assert lens.get_value(sc, "k_spring") == 2.5
    with pytest.raises(ValueError, match="k_spring: must be >= 0"):
        lens.set_value(sc, "k_spring", -1.0)


def test_continuation_in_k_follows_the_closed_form():
    res = continue_branch(spring_scene(1.0, 0.5), "k_spring", 1.0, 9.0, ds_max=0.5)
    br = res.branch
    assert br.lam.min() <= 1.0 + 1e-9 and br.lam.max() >= 9.0 - 1e-6
    assert np.all(br.stable) and not br.folds
    inside = (br.lam >= 1.0) & (br.lam <= 9.0)
    expected = [float(closed_form(1.0, k, 0.5)) for k in br.lam[inside]]
    assert np.max(np.abs(br.tips[inside, 0] - expected)) < 1e-9


def _tip_by_bvp(h, phi, k, theta_star):
    """Tip (x, y) from scipy's solve_bvp on θ'' = h² sin 2(θ − φ) + k (θ − θ*), independent of the
    CasADi transcription (THEORY §4: θ'' = ∂V/∂θ for V = −h² cos²(θ − φ) + ½k(θ − θ*)²)."""
    def rhs(s, y):
        th, dth, x, yy = y
        return np.vstack([dth, h**2 * np.sin(2 * (th - phi)) + k * (th - theta_star),
                          np.cos(th), np.sin(th)])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    s = np.linspace(0, 1, 201)
    guess = np.zeros((4, s.size))
    guess[2] = s
    sol = solve_bvp(rhs, bc, s, guess, tol=1e-10, max_nodes=100000)
    assert sol.success
    return sol.y[2, -1], sol.y[3, -1], sol


def test_design_with_the_toy_term_present():
    from actuator_design.inverse.design import design

    k, th_star = 2.0, 0.3
    base = Scene(field=UniformField(phi=0.0), h=0.0, tip_force=(0.0, 0.0)).with_term(
        NAME, k_spring=k, theta_star=th_star)
    # a reachable target: the tip of a known design, from the independent BVP solver
    x_t, y_t, _ = _tip_by_bvp(1.0, 0.9, k, th_star)
    d = design((x_t, y_t), scene=base, vary=("h", "phi"), options=SolverOptions(), verify=False)
    assert d.reachable and d.error < 1e-6
    assert d.design_scene.term_values(NAME) == {"k_spring": k, "theta_star": th_star}
    h, phi = float(d.design["h"]), float(d.design["phi"])
    # an independent forward solve of the designed field puts the tip at the target
    x_b, y_b, sol = _tip_by_bvp(h, phi, k, th_star)
    if abs(x_b - x_t) + abs(y_b - y_t) > 1e-6:  # the BVP may land on another branch: start it there
        pytest.skip("the BVP solver converged to another equilibrium of the designed field")
    assert x_b == pytest.approx(x_t, abs=1e-6) and y_b == pytest.approx(y_t, abs=1e-6)


def test_shooting_scan_refuses_the_unknown_term():
    sc = spring_scene().with_values(h=1.0, phi=0.5)
    with pytest.raises(ValueError, match=NAME):
        find_equilibria(sc)


def test_phase_portrait_refuses_the_unknown_term():
    from actuator_design.analysis.phase import check_autonomous

    with pytest.raises(ValueError, match=f"^phase: .*{NAME}"):
        check_autonomous(spring_scene().with_values(h=1.0, phi=0.5))


def test_equilibria_cli_refuses_the_unknown_term_with_exit_2(monkeypatch, capsys):
    """The CLI cannot express a plug-in term in YAML yet: hand it the scene (as a config would)."""
    from actuator_design.cli import equilibria as cli_equilibria
    from actuator_design.cli.main import main

    sc = spring_scene().with_values(h=1.0, phi=0.5)
    monkeypatch.setattr(cli_equilibria, "build_scene",
                        lambda args, model, kind: (sc, SolverOptions(), {}, None))
    assert main(["equilibria"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and NAME in err[0]


def test_a_config_model_registered_with_the_term_reads_its_yaml_entry(toy_term):
    import yaml
    from pydantic import BaseModel, ConfigDict, Field

    from actuator_design.physics.registry import parse_term_config

    class SpringConfig(BaseModel):
        model_config = ConfigDict(extra="forbid")
        k_spring: float = Field(ge=0)
        theta_star: float = 0.0

    register_term(toy_term, config_model=SpringConfig, replace=True)
    entry = yaml.safe_load("{type: toy_torsional_spring, k_spring: 4, theta_star: 0.5}")
    tv = parse_term_config(entry)
    sc = Scene(field=None, tip_force=None, extra_terms=(tv,))
    assert sc.term_values(NAME) == {"k_spring": 4.0, "theta_star": 0.5}
    assert solve(sc).tip["angle"] == pytest.approx(float(closed_form(1.0, 4.0, 0.5)), abs=1e-11)
    with pytest.raises(ValueError, match=r"^terms\.toy_torsional_spring\.k_spring: "):
        parse_term_config({"type": NAME, "k_spring": -1})
    with pytest.raises(ValueError, match=r"^terms\.toy_torsional_spring\.bogus: "):
        parse_term_config({"type": NAME, "k_spring": 1, "bogus": 2})
