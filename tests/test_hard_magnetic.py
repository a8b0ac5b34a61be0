"""The hard-magnetic term (THEORY §9) against independent references.

References: the shooting solver of ``actuator_design.reference`` (numpy/scipy, its own right-hand
side with the remanent torque h_r sin(θ + β − φ)); the linearised closed forms of §9 — tip rise
h_r/3 for a transverse field and small h_r, buckling of the straight rod at h_r = π²/4 for a field
anti-parallel to an axial magnetisation; the mirror symmetry (φ, β, θ) → (−φ, −β, −θ); and the
field-ramp rule (h_r ∝ H, h² ∝ H²).
"""
import math

import numpy as np
import pytest

from actuator_design.physics import parameters as lens
from actuator_design.continuation.follow import continue_branch
from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import constant_profile, expression_profile
from actuator_design.reference.shooting import ShootingParams, jacobi_morse_index, solve_shooting
from actuator_design.model.scene import DipoleField, Scene, UniformField

DEFAULT = SolverOptions()


def hard_scene(h_r, phi, beta=0.0, h=0.0, alpha=0.0, p=None):
    beta_p = beta if hasattr(beta, "kind") else constant_profile(beta)
    return Scene(field=UniformField(phi=phi), h=h, fibres=constant_profile(alpha),
                 tip_force=None if p is None else (0.0, p), h_r=h_r, magnetization=beta_p)


CASES = [(0.5, math.pi / 2), (2.0, math.pi / 2), (1.0, 0.7), (4.0, 2.5), (6.0, -1.2), (9.0, 3.0)]


@pytest.mark.parametrize("h_r,phi", CASES)
def test_uniform_field_matches_shooting(h_r, phi):
    r = solve(hard_scene(h_r, phi), DEFAULT)
    assert r.success and r.stable
    ref = solve_shooting(ShootingParams(phi=phi, h_r=h_r), gamma_guess=r.gamma)
    assert ref.converged
    for k, v in zip(("x", "y", "angle"), ref.tip):
        assert r.tip[k] == pytest.approx(v, abs=1e-8)
    assert r.energy == pytest.approx(ref.energy, abs=1e-8)
    s = np.linspace(0, 1, 17)
    np.testing.assert_allclose(r.evaluate(s)["theta"], ref.theta(s), atol=1e-8)
    assert r.el_residual < 1e-8 * max(1.0, h_r)  # the balance check knows the remanent torque
    assert jacobi_morse_index(ref, ref.params).index == r.morse_index == 0


def test_graded_magnetisation_combined_with_soft_term_and_load_matches_shooting():
    beta = "0.8*sin(pi*s)"
    sc = hard_scene(3.0, 1.9, beta=expression_profile(beta), h=0.8, alpha=0.3, p=-0.4)
    r = solve(sc, DEFAULT)
    assert r.success and r.stable
    params = ShootingParams(h=0.8, phi=1.9, fy=-0.4, alpha=0.3, h_r=3.0,
                            beta=lambda s: 0.8 * np.sin(np.pi * s))
    ref = solve_shooting(params, gamma_guess=r.gamma)
    assert ref.converged
    for k, v in zip(("x", "y", "angle"), ref.tip):
        assert r.tip[k] == pytest.approx(v, abs=1e-8)
    assert r.energy == pytest.approx(ref.energy, abs=1e-8)


@pytest.mark.parametrize("h_r", [1e-4, 1e-3])
def test_small_h_r_transverse_tip_rise_is_h_r_over_3(h_r):
    """θ = h_r (s − s²/2) to first order, so y(1) = h_r/3 + O(h_r³) (THEORY §9)."""
    r = solve(hard_scene(h_r, math.pi / 2), DEFAULT)
    assert r.tip["y"] == pytest.approx(h_r / 3, abs=h_r**3)
    assert r.tip["angle"] == pytest.approx(h_r / 2, abs=h_r**3)


def test_antiparallel_field_buckles_at_pi_squared_over_4():
    """θ'' + h_r sin θ = 0 linearised: the straight rod loses stability at h_r = (π/2)²; the
    continuation in h_r finds the branch point there (a pitchfork by the mirror symmetry)."""
    sc = hard_scene(0.0, math.pi)
    res = continue_branch(sc, "h_r", 1.0, 3.5, ds_max=0.2)
    bps = res.branch.branch_points
    assert len(bps) == 1
    assert bps[0].located and bps[0].value == pytest.approx(math.pi**2 / 4, abs=1e-6)
    # below it the straight rod is stable, above it unstable with Morse index 1
    lam, idx = res.branch.lam, res.branch.morse_index
    assert np.all(idx[lam < 2.4] == 0) and np.all(idx[lam > 2.55] == 1)


def test_mirror_symmetry():
    a = solve(hard_scene(2.0, 0.9, beta=0.3, h=0.5, alpha=0.2), DEFAULT)
    b = solve(hard_scene(2.0, -0.9, beta=-0.3, h=0.5, alpha=-0.2), DEFAULT)
    assert a.tip["y"] == pytest.approx(-b.tip["y"], abs=1e-12)
    assert a.tip["x"] == pytest.approx(b.tip["x"], abs=1e-12)


def test_a_field_ramp_scales_h_r_linearly_and_h2_quadratically():
    sc = hard_scene(2.0, 0.5, h=1.0)
    up = lens.apply_values(sc, {"h": 3.0})  # H × 3
    assert up.h_r == pytest.approx(6.0, rel=1e-15)
    up2 = lens.apply_values(sc, {"h2": 4.0})  # H × 2
    assert up2.h_r == pytest.approx(4.0, rel=1e-15)


def test_lens_adds_the_term_and_checks_the_range():
    sc = lens.set_value(Scene(field=None, tip_force=None), "h_r", 1.5)
    assert sc.magnetization is not None and sc.field is not None and sc.h_r == 1.5
    assert lens.get_value(sc, "magnetization") == 0.0
    with pytest.raises(ValueError, match="h_r: must be >= 0"):
        lens.set_value(sc, "h_r", -1.0)


def test_continuation_in_field_angle_matches_shooting():
    res = continue_branch(hard_scene(2.0, 0.0), "phi", 0.0, 2.0, ds_max=0.3)
    br = res.branch
    for lam, tip in list(zip(br.lam, br.tips))[:: max(1, len(br.lam) // 4)]:
        ref = solve_shooting(ShootingParams(phi=lam, h_r=2.0), gamma_guess=0.0)
        if not ref.converged or abs(ref.tip_angle - tip[0]) > 1e-3:
            ref = solve_shooting(ShootingParams(phi=lam, h_r=2.0), gamma_guess=float(tip[0]))
        assert tip[0] == pytest.approx(ref.tip_angle, abs=1e-8)


def test_dipole_field_gives_the_gradient_force():
    """Non-uniform field: the balance check (clamp reactions from the pointwise loads) closes, and
    the energy is invariant under the mirror y → −y of the whole scene."""
    up = Scene(field=DipoleField(x0=0.5, y0=-0.6, moment_angle=0.0), h=0.0, tip_force=None,
               h_r=0.3, magnetization=constant_profile(0.0))
    dn = Scene(field=DipoleField(x0=0.5, y0=0.6, moment_angle=0.0), h=0.0, tip_force=None,
               h_r=0.3, magnetization=constant_profile(0.0))
    a, b = solve(up, DEFAULT), solve(dn, DEFAULT)
    assert a.success and b.success and a.el_residual < 1e-8
    assert a.tip["y"] == pytest.approx(-b.tip["y"], abs=1e-10)
    assert abs(a.clamp_force[0]) + abs(a.clamp_force[1]) > 1e-3  # the gradient pulls the rod


def test_shooting_scan_refuses_the_hard_term_in_a_non_uniform_field():
    """The scan integrates the uniform-field torque only (issue 12 made it support the term there;
    tests/test_hard_magnetic_scan.py checks it): the dipole's gradient force is refused."""
    sc = Scene(field=DipoleField(x0=0.5, y0=-0.6, moment_angle=0.0), h=0.0, tip_force=None,
               h_r=0.3, magnetization=constant_profile(0.0))
    with pytest.raises(ValueError, match="only uniform fields"):
        find_equilibria(sc)


# -- analyses that support the term -------------------------------------------------------------
@pytest.mark.parametrize("h, h_r", [(0.0, 0.5), (0.0, 4.0), (0.7, 1.3)])
def test_lowload_stiffness_with_an_axial_magnetisation(h, h_r):
    """φ = 0, β = 0, p = 0: θ1'' − (2h² + h_r) θ1 + 1 = 0, so the stiffness is THEORY §6's s at
    h_eff = √(h² + h_r/2) (closed form, independent of the solver)."""
    from actuator_design.analysis.stiffness import tip_stiffness
    from actuator_design.reference.closed_forms import lowload_stiffness

    st = tip_stiffness(hard_scene(h_r, 0.0, h=h, p=0.0), DEFAULT)
    assert st.vertical == pytest.approx(float(lowload_stiffness(math.sqrt(h * h + h_r / 2))), rel=1e-8)


def test_stiffness_field_sweep_scales_h_r_with_the_field():
    from actuator_design.analysis.stiffness import stiffness_field_curve
    from actuator_design.reference.closed_forms import lowload_stiffness

    sc = hard_scene(1.0, 0.0, h=0.5, p=0.0)  # h_r/h = 2 stays fixed along the sweep
    curve = stiffness_field_curve(sc, DEFAULT, [0.5, 1.0, 2.0])
    for h, k in zip(curve.h, curve.vertical):
        assert k == pytest.approx(float(lowload_stiffness(math.sqrt(h * h + h))), rel=1e-8)
    assert not curve.lowload_applies  # s(h) alone is not this rod's stiffness
    with pytest.raises(ValueError, match="h_values: the scene's h is 0"):
        stiffness_field_curve(hard_scene(1.0, 0.0, p=0.0), DEFAULT, [0.5])


def test_phase_first_integral_is_conserved_along_a_hard_magnetic_equilibrium():
    """H = ½θ'² + h² cos²(θ+α−φ) + h_r cos(θ+β−φ) + p sin θ is constant along the solution of the
    NLP (derived by hand from the Euler–Lagrange equation; the NLP knows nothing of H)."""
    from actuator_design.analysis.phase import check_autonomous, phase_portrait

    sc = hard_scene(3.0, 2.0, beta=0.4, h=0.6, alpha=0.2, p=0.3)
    r = solve(sc, DEFAULT)
    pp = phase_portrait(sc, [r])
    assert pp.trajectories[0].spread < 1e-8
    with pytest.raises(ValueError, match="^magnetization: "):
        check_autonomous(hard_scene(1.0, 0.5, beta=expression_profile("0.3*s")))


def test_design_with_the_hard_term_present_recovers_a_shooting_made_target():
    """The target is the tip of the shooting solution at (h, φ) = (0.9, 1.3) with h_r = 1.8; the
    design (varying h and φ) recovers the field. The field is one field (issue 17): the base scene's
    h = 0.5, h_r = 1.0 fix h_r = 2 h at every field, so h_r comes back with h (THEORY §9)."""
    from actuator_design.inverse.design import design

    ref = solve_shooting(ShootingParams(phi=1.3, h=0.9, h_r=1.8), 0.5)
    assert ref.converged
    base = Scene(field=UniformField(phi=0.0), h=0.5, tip_force=(0.0, 0.0), h_r=1.0,
                 magnetization=constant_profile(0.0))
    d = design((ref.tip[0], ref.tip[1]), scene=base, vary=("h", "phi"), options=DEFAULT, verify=False)
    assert d.reachable and d.error < 1e-8
    assert float(d.design["h"]) == pytest.approx(0.9, abs=1e-6)
    assert d.design_scene.h_r == pytest.approx(2.0 * d.design_scene.h, rel=1e-12)
    assert d.design["h_r"] == d.design_scene.h_r
    assert float(d.design["phi"]) == pytest.approx(1.3, abs=1e-6)


def test_fit_scales_h_r_with_the_field_instead_of_holding_it_fixed(tmp_path):
    """A hard-magnetic scene is fitted (issue 12: M_r is a fit parameter), and h_r is never held
    fixed while the field changes: it follows the measured field linearly, h_r(H) = h_r H/H_ref
    (THEORY §9), where h follows it too (h² ∝ H²). More in tests/test_fit_hard_magnetic.py."""
    import numpy as np

    from actuator_design.calibration import prepare_fit

    data = tmp_path / "d.csv"
    data.write_text("field [kA/m], tip_angle [deg]\n1, 1\n2, 2\n3, 3\n")
    cfg = {"scene": {"type": "dimensionless", "h": 1.0, "h_r": 0.5},
           "study": {"type": "fit", "reference_field": "10 kA/m", "parameters": {"h": {}}}}
    prob = prepare_fit(cfg, data)
    q = np.asarray(prob.f_map(np.array([1.0]), np.array([20e3, 0.0, 0.0, 0.0]))[0]).ravel()
    assert q[prob.slots.index("h_r")] == pytest.approx(1.0, rel=1e-15)
    assert q[prob.slots.index("h")] == pytest.approx(2.0, rel=1e-15)


@pytest.mark.parametrize("h_r, index", [(1.0, 0), (5.0, 1), (30.0, 2), (70.0, 3)])
def test_jacobi_index_of_the_straight_rod_counts_euler_modes(h_r, index):
    """Axial magnetisation, field anti-parallel: the straight rod's Morse index by the independent
    Jacobi test is the number of Euler modes below h_r, ((2k − 1)π/2)² < h_r (THEORY §9)."""
    import math as _m

    from actuator_design.reference.shooting import ShootingParams, shoot
    from actuator_design.reference.jacobi import jacobi_morse_index

    sol = shoot(0.0, ShootingParams(h_r=h_r, phi=_m.pi, beta=0.0))
    assert abs(sol.residual) < 1e-12  # the straight rod is an equilibrium
    assert index == sum(((2 * k - 1) * _m.pi / 2) ** 2 < h_r for k in range(1, 10))
    assert jacobi_morse_index(sol).index == index
