"""The collocation solver against THEORY §6's closed forms and the independent shooting solver.

References: ``actuator_design.reference`` (numpy/scipy only, no CasADi): the elliptic transverse
modes, the stable low-load stiffness s(h), shooting on the Euler–Lagrange BVP, and the Jacobi
(Prüfer) conjugate-point test for the Morse index.
"""
import math
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import expression_profile, table_profile
from actuator_design.reference.closed_forms import (critical_field_transverse, lowload_stiffness,
                                                    transverse_mode)
from actuator_design.reference.shooting import ShootingParams, jacobi_morse_index, solve_shooting
from actuator_design.model.scene import Scene, UniformField, default_scene

DEFAULT = SolverOptions()


# -- THEORY §6: transverse field, φ = π/2, p = 0 -----------------------------------------------------
@pytest.mark.parametrize("h", [1.2, 1.5, 2.0, 3.0, 6.0])
def test_transverse_first_mode_matches_elliptic_closed_form(h):
    """β, u1, v1 of the stable first mode at the DEFAULT settings, to 1e-9 (issue: 1e-6)."""
    ref = transverse_mode(h, 1)
    r = solve(default_scene(h=h, phi=math.pi / 2), DEFAULT)
    assert r.success and r.stable and r.morse_index == 0
    sign = np.sign(r.tip["angle"])
    assert abs(r.tip["angle"]) == pytest.approx(ref.beta, abs=1e-9)
    assert r.tip["x"] - 1 == pytest.approx(ref.u1, abs=1e-9)
    assert sign * r.tip["y"] == pytest.approx(ref.v1, abs=1e-9)
    # θ'(0) is a derivative at the boundary: less accurate than nodal values at steep shapes
    assert sign * r.gamma == pytest.approx(ref.gamma, rel=2e-5)


def test_transverse_second_mode_is_an_index_one_equilibrium():
    """Mode 2 at h = 4 (> h_crit^(2)): found by Newton from a nearby guess with ensure_stable off
    (IPOPT, a minimiser, would slide off this saddle), it matches the closed form and has Morse
    index 1, like the Jacobi test says."""
    h = 4.0
    ref = transverse_mode(h, 2)
    s = DEFAULT
    guess = ref.theta(np.asarray(solve(default_scene(h=0.1), s).s)) * 0.95
    r = solve(default_scene(h=h, phi=math.pi / 2), replace(s, ensure_stable=False, method="newton"), initial=guess)
    assert r.success and r.message.startswith("Newton")
    assert abs(r.tip["angle"]) == pytest.approx(ref.beta, abs=1e-8)
    assert r.tip["x"] - 1 == pytest.approx(ref.u1, abs=1e-8)
    assert abs(r.tip["y"]) == pytest.approx(ref.v1, abs=1e-8)
    assert r.morse_index == 1
    params = ShootingParams(h=h, phi=math.pi / 2)
    assert jacobi_morse_index(solve_shooting(params, ref.gamma), params).index == 1


@pytest.mark.parametrize("h", [0.5, 1.0, 1.1])
def test_below_critical_field_only_straight_rod(h):
    assert h < critical_field_transverse(1)
    r = solve(default_scene(h=h, phi=math.pi / 2), DEFAULT)
    assert r.stable and not r.escaped_saddle
    np.testing.assert_allclose(r.theta, 0.0, atol=1e-12)


# -- THEORY §6: low-load stiffness, φ = 0 ------------------------------------------------------------
@pytest.mark.parametrize("h", [0.0, 0.3, 1.0, 2.0, 5.0])
def test_lowload_stiffness_matches_s_of_h(h):
    """Central difference of v1 in p at p = 0 gives 1/s(h) (THEORY §6)."""
    dp = 1e-4
    v = [solve(default_scene(h=h, phi=0.0, p=sgn * dp), DEFAULT).tip["y"] for sgn in (+1, -1)]
    stiffness = 2 * dp / (v[0] - v[1])
    assert stiffness == pytest.approx(float(lowload_stiffness(h)), rel=1e-7)


# -- second method: shooting on the Euler–Lagrange BVP -----------------------------------------------
SHOOTING_CASES = {
    "elastica p=2": (default_scene(h=0.0, p=2.0), ShootingParams(h=0.0, phi=0.0, fy=2.0)),
    "elastica p=9": (default_scene(h=0.0, p=9.0), ShootingParams(h=0.0, phi=0.0, fy=9.0)),
    "oblique field": (default_scene(h=1.3, phi=1.0, p=0.7), ShootingParams(h=1.3, phi=1.0, fy=0.7)),
    "tilted fibres": (default_scene(h=1.1, phi=0.2, p=-0.5, alpha=0.5),
                      ShootingParams(h=1.1, phi=0.2, fy=-0.5, alpha=0.5)),
    "graded fibres, stiffness, all loads": (
        Scene(field=UniformField(phi=2.0), h=0.9, fibres=expression_profile("0.6*sin(pi*s)"),
              stiffness=expression_profile("1 + 0.5*s**2"), tip_force=(0.3, -0.8), tip_moment=0.4,
              distributed_load=(-0.2, -1.5), theta0=0.25),
        ShootingParams(h=0.9, phi=2.0, fx=0.3, fy=-0.8, m=0.4, qx=-0.2, qy=-1.5, theta0=0.25,
                       alpha=lambda s: 0.6 * np.sin(np.pi * s), b=lambda s: 1 + 0.5 * s**2)),
}


@pytest.mark.parametrize("name", list(SHOOTING_CASES))
def test_collocation_matches_shooting(name):
    scene, params = SHOOTING_CASES[name]
    r = solve(scene, DEFAULT)
    assert r.success and r.stable
    ref = solve_shooting(params, gamma_guess=r.gamma)
    assert ref.converged
    assert r.tip["angle"] == pytest.approx(ref.tip_angle, abs=1e-9)
    assert r.tip["x"] == pytest.approx(ref.tip_x, abs=1e-9)
    assert r.tip["y"] == pytest.approx(ref.tip_y, abs=1e-9)
    assert r.gamma == pytest.approx(ref.gamma, abs=1e-7)
    assert r.energy == pytest.approx(ref.energy, abs=1e-9)
    s = np.linspace(0, 1, 23)
    np.testing.assert_allclose(r.evaluate(s)["theta"], ref.theta(s), atol=1e-9)
    assert r.el_residual < 1e-8


# -- stability: reduced Hessian against the Jacobi conjugate-point test ------------------------------
MORSE_CASES = [
    # (scene, initial guess factory or None, shooting params)
    (default_scene(h=1.0, phi=math.pi / 2), ShootingParams(h=1.0, phi=math.pi / 2)),
    (default_scene(h=1.5, phi=math.pi / 2), ShootingParams(h=1.5, phi=math.pi / 2)),
    (default_scene(h=3.0, phi=math.pi / 2), ShootingParams(h=3.0, phi=math.pi / 2)),
    (default_scene(h=4.0, phi=math.pi / 2), ShootingParams(h=4.0, phi=math.pi / 2)),
    (default_scene(h=0.0, p=-4.0), ShootingParams(h=0.0, fy=-4.0)),
    (default_scene(h=2.0, phi=math.pi, p=-1.0), ShootingParams(h=2.0, phi=math.pi, fy=-1.0)),
]


@pytest.mark.parametrize("k", range(len(MORSE_CASES)))
def test_morse_index_of_straight_and_unstable_states_matches_jacobi(k):
    """Equilibria reached without the saddle escape (the straight rod and others) keep whatever
    index they have; the Hessian's count must equal the Jacobi test's on the same equilibrium."""
    scene, params = MORSE_CASES[k]
    r = solve(scene, replace(DEFAULT, ensure_stable=False))
    assert r.success
    ref = jacobi_morse_index(solve_shooting(params, gamma_guess=r.gamma), params)
    assert not ref.degenerate
    assert r.morse_index == ref.index
    assert r.stable == (ref.index == 0)


def test_unstable_elastica_branch_index():
    """Field-free elastica with a large load has coexisting equilibria; a state found from a
    looping guess is checked against the Jacobi test (whatever its index)."""
    p = 20.0
    params = ShootingParams(h=0.0, fy=p)
    for gamma in (-9.0, 7.5):
        ref_sol = solve_shooting(params, gamma_guess=gamma)
        if not ref_sol.converged:
            continue
        nodes = solve(default_scene(h=0.0, p=0.1), DEFAULT).s
        r = solve(default_scene(h=0.0, p=p), replace(DEFAULT, ensure_stable=False), initial=ref_sol.theta(nodes))
        assert r.success
        assert r.tip["angle"] == pytest.approx(ref_sol.tip_angle, abs=1e-8)
        assert r.morse_index == jacobi_morse_index(ref_sol, params).index


# -- convergence order of each transcription (rockit-style grid refinement) --------------------------
def _tip_error(opts, h=1.5):
    ref = transverse_mode(h, 1)
    r = solve(default_scene(h=h, phi=math.pi / 2), opts)
    return max(abs(abs(r.tip["angle"]) - ref.beta), abs(r.tip["x"] - 1 - ref.u1), abs(abs(r.tip["y"]) - ref.v1))


def test_midpoint_is_second_order():
    errors = [_tip_error(SolverOptions(transcription="midpoint", elements=n)) for n in (25, 50, 100, 200)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 2.0, atol=0.1)


@pytest.mark.parametrize("d", [2, 3])
def test_lgl_element_refinement_order_is_about_2d(d):
    # each on its own mesh (adapt off: solve would refine a mesh that misses the residual limit)
    errors = [_tip_error(SolverOptions(elements=e, degree=d, adapt=False)) for e in (4, 8, 16)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 2 * d - 0.5), orders


def test_lgl_degree_refinement_is_spectral():
    """One element, degree d: the error falls faster than any fixed power, down to rounding."""
    errors = np.array([_tip_error(SolverOptions(elements=1, degree=d, adapt=False)) for d in (4, 6, 8, 10, 12)])
    ratios = errors[:-1] / errors[1:]
    assert np.all(ratios > 50), ratios
    assert _tip_error(SolverOptions(elements=1, degree=18, adapt=False)) < 1e-13
