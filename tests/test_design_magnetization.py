"""Inverse design of the remanent magnetisation profile β(s) of a hard-magnetic rod (issue 12 item
1, THEORY §9: the shape-programming problem).

Independent references: the targets are tips of the shooting solver of ``actuator_design.reference``
(numpy/scipy, its own right-hand side θ'' = h_r sin(θ + β − φ) + …, β evaluated by numpy's Legendre
series) at known design values; the design is determined (as many design values as pinned tip
values, the other variables fixed), so the known values must come back; the achieved tip is checked
by a second shooting solve at the *recovered* values; the verification ramp against the lens's
field-scaling rule (h, h_r ∝ H).
"""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.inverse.design import design
from actuator_design.inverse.design_map import prepare_scene
from actuator_design.inverse.nlp import DESIGN_VARIABLES
from actuator_design.inverse.settings import DesignSettings, normalise_phi, phi_period
from actuator_design.inverse.verify import _ramp, _ramp_then_rotate, ramped_groups
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics import parameters as lens
from actuator_design.reference.shooting import ShootingParams, solve_shooting

DEFAULT = SolverOptions()


def legendre_beta(coefficients):
    """β(s) = Σ b_k P_k(2s − 1) evaluated by numpy (not by the tool's profiles)."""
    c = np.asarray(coefficients, float)
    return lambda s: np.polynomial.legendre.legval(2 * np.asarray(s) - 1, c)


def shooting_tip(coefficients, h_r, phi, h=0.0, gamma_guess=0.5):
    ref = solve_shooting(ShootingParams(h=h, phi=phi, h_r=h_r, beta=legendre_beta(coefficients)), gamma_guess)
    assert ref.converged
    return np.asarray(ref.tip, float)  # (x, y, angle)


def hard_scene(h_r, phi, h=0.0):
    return Scene(field=UniformField(phi=phi), h=h, h_r=h_r, magnetization=constant_profile(0.0))


def test_magnetization_is_a_design_variable_of_the_lens():
    assert lens.parameter("magnetization").designable and lens.parameter("magnetization").per_point
    assert "magnetization" in DESIGN_VARIABLES
    assert not lens.parameter("h_r").designable  # the remanence is the material's, given


def test_magnetisation_profile_design_recovers_a_shooting_made_target():
    """Issue 12's acceptance: β(s) with 3 Legendre terms at a fixed transverse field, h_r = 2; the
    tip pose (x, y, angle) from a shooting solve at known coefficients; the design varies the
    magnetisation only (3 unknowns, 3 pinned values) and recovers the coefficients to 1e-6."""
    b_true = np.array([0.3, -0.4, 0.2])
    h_r, phi = 2.0, math.pi / 2
    target = shooting_tip(b_true, h_r, phi)
    res = design(tuple(target), scene=hard_scene(h_r, phi), vary=("magnetization",), options=DEFAULT,
                 settings=DesignSettings(alpha_terms=3))
    assert res.success and res.verified and res.stable and res.snap_free, res.message
    b = np.array(res.design["magnetization"]["legendre_coefficients"])
    np.testing.assert_allclose(b, b_true, atol=1e-6)
    # the achieved tip, by an independent shooting solve at the recovered coefficients
    again = shooting_tip(b, h_r, phi)
    np.testing.assert_allclose(again, target, atol=1e-7)
    got = res.achieved
    np.testing.assert_allclose([got["x"], got["y"], got["angle"]], again, atol=1e-7)
    # the reported profile is the Legendre series of the reported coefficients
    s = np.array(res.design["magnetization"]["s"])
    np.testing.assert_allclose(res.design["magnetization"]["value"], legendre_beta(b)(s), atol=1e-12)
    assert res.design["h_r"] == h_r and res.design_scene.h_r == h_r  # the remanence as given
    assert "moved off" not in res.message  # a determined design cannot move


def test_field_and_uniform_magnetisation_design_recovers_a_combined_target():
    """Soft + hard rod: h, φ and a uniform β (one Legendre term) from a tip pose made by shooting at
    (h, φ, β) = (0.8, 1.2, 0.5): determined, recovered to 1e-6. The field is one field (issue 17):
    the scene's h = 0.5, h_r = 1.5 give h_r = 3 h at every field, so the target is made at
    h_r = 2.4 and h_r comes back with h."""
    h_true, phi_true, beta_true = 0.8, 1.2, 0.5
    h_r = 3.0 * h_true
    target = shooting_tip([beta_true], h_r, phi_true, h=h_true)
    res = design(tuple(target), scene=hard_scene(1.5, 0.0, h=0.5), vary=("h", "phi", "magnetization"),
                 options=DEFAULT, settings=DesignSettings(alpha_terms=1))
    assert res.reachable and res.verified and res.stable, res.message
    assert res.design["h"] == pytest.approx(h_true, abs=1e-6)
    assert res.design["h_r"] == pytest.approx(3.0 * res.design["h"], rel=1e-12)
    # φ is reported modulo 2π with a hard-magnetic term (the energy's period), not modulo π
    assert res.design["phi"] == pytest.approx(normalise_phi(phi_true, 2 * math.pi), abs=1e-6)
    assert res.design["magnetization"]["legendre_coefficients"][0] == pytest.approx(beta_true, abs=1e-6)
    np.testing.assert_allclose(shooting_tip([res.design["magnetization"]["legendre_coefficients"][0]],
                                            res.design["h_r"], res.design["phi"], h=res.design["h"]),
                               target, atol=1e-7)


def test_the_verification_ramp_scales_h_r_with_the_field_like_h():
    """Along the ramp from zero field both groups are ∝ H (lens field_power 1): h/h_d = h_r/h_r,d =
    t at every step, ending at the design; a rotation keeps both at their design values."""
    assert lens.parameter("h").field_power == lens.parameter("h_r").field_power == 1
    groups = ramped_groups(hard_scene(2.5, 1.0, h=0.8))  # h and h_r, each with its design value
    ramp = _ramp(groups, 1.0, 0.0, 11, False)
    t = np.linspace(0, 1, 11)
    np.testing.assert_allclose([q["h"] for q in ramp], 0.8 * t ** lens.parameter("h").field_power)
    np.testing.assert_allclose([q["h_r"] for q in ramp], 2.5 * t ** lens.parameter("h_r").field_power)
    turn = _ramp_then_rotate(groups, 0.0, 1.0, 0.0, 11, False)[11:]
    assert all(q["h"] == 0.8 and q["h_r"] == 2.5 for q in turn)
    soft = ramped_groups(Scene(field=UniformField(phi=1.0), h=0.8))
    assert "h_r" not in _ramp(soft, 1.0, 0.0, 3, False)[0]  # a soft rod's schedule is unchanged


def test_phi_period_is_two_pi_with_a_remanent_term():
    """−h_r cos(θ + β − φ) changes sign under φ → φ + π; h² cos²(…) does not."""
    assert phi_period(hard_scene(1.0, 0.0)) == pytest.approx(2 * math.pi)
    assert phi_period(hard_scene(0.0, 0.0)) == pytest.approx(math.pi)
    assert phi_period(Scene(field=UniformField(phi=0.0), h=1.0)) == pytest.approx(math.pi)
    a = shooting_tip([0.0], 1.0, 1.0)
    b = shooting_tip([0.0], 1.0, 1.0 + math.pi, gamma_guess=-0.5)
    assert np.max(np.abs(a - b)) > 0.1


def test_designing_the_magnetisation_without_remanence_is_one_clear_error():
    with pytest.raises(ValueError, match=r"^--vary magnetization: the scene's h_r is 0"):
        design((0.5, 0.5), scene=hard_scene(0.0, 0.0), vary=("magnetization",), options=DEFAULT)
    with pytest.raises(ValueError, match="h_r is 0"):
        prepare_scene(Scene(field=UniformField(phi=0.0), h=1.0), ("h", "magnetization"))


def _cli(*argv, cwd):
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "actuator_design.cli.main", *argv], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=300)


def test_cli_designs_the_magnetisation_and_refuses_it_without_remanence(tmp_path):
    b_true = np.array([0.2, 0.3])
    target = shooting_tip(b_true, 3.0, 2.0)
    cfg = tmp_path / "hard.yaml"
    cfg.write_text("scene:\n  type: dimensionless\n  h: 0\n  phi: 2.0\n  h_r: 3.0\n")
    tip = f"{float(target[0])!r},{float(target[1])!r}"  # 2 coefficients, 2 pinned values: determined
    r = _cli("design", str(cfg), "--target-tip", tip, "--vary", "magnetization", "--alpha-terms", "2",
             "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["success"] and d["vary"] == ["magnetization"]
    np.testing.assert_allclose(d["design"]["magnetization"]["legendre_coefficients"], b_true, atol=1e-6)
    assert d["schedule"][0]["h_r"] == 0.0 and d["schedule"][-1]["h_r"] == pytest.approx(3.0)
    assert d["optima"][0]["magnetization_coefficients"] == pytest.approx(list(b_true), abs=1e-6)
    bad = _cli("design", "--target-tip", "0.5,0.5", "--vary", "magnetization", "--json", cwd=tmp_path)
    assert bad.returncode == 2 and bad.stdout == ""
    lines = bad.stderr.strip().splitlines()
    assert len(lines) == 1 and "h_r is 0" in lines[0]


def test_shape_programming_recovers_the_magnetisation_of_a_shooting_shape():
    """The shape-programming problem proper: centreline points (not only the tip) of a shooting
    solution at known β coefficients; the least-squares fit of β(s) passes through them and gives
    the coefficients back."""
    from actuator_design.inverse.shape import design_shape

    b_true, h_r, phi = np.array([0.4, 0.5, -0.3]), 2.5, 1.8
    ref = solve_shooting(ShootingParams(phi=phi, h_r=h_r, beta=legendre_beta(b_true)), 0.5)
    assert ref.converged
    s = np.array([0.25, 0.5, 0.75, 1.0])
    pts = np.column_stack([s, [ref.x(v) for v in s], [ref.y(v) for v in s]]).astype(float)
    res = design_shape(pts, scene=hard_scene(h_r, phi), vary=["magnetization"], options=DEFAULT,
                       settings=DesignSettings(alpha_terms=3))
    assert res.verified and res.stable and res.rms_error < 1e-8, res.message
    # positions are weakly sensitive to the highest coefficient (a shape error of 1e-8 allows a few
    # 1e-6 in b_2): the coefficients to 1e-5; the determined tip design above recovers them to 1e-6
    np.testing.assert_allclose(res.design["magnetization"]["legendre_coefficients"], b_true, atol=1e-5)
    assert all("h_r" in q for q in res.schedule) and res.schedule[-1]["h_r"] == pytest.approx(h_r)


def test_one_magnetisation_for_two_field_angles():
    """Multi-pose shape programming: one β(s) shared by two poses, each with its own field angle.
    The purely remanent energy depends on θ + β − φ only, so a uniform part of β and the field
    angles trade off exactly (b_0 − φ_k is what is determined): the design must recover b_1 and
    φ_k − b_0 of the shooting-made poses."""
    from actuator_design.inverse.poses import design_poses

    b_true, h_r, phis = np.array([0.3, 0.4]), 2.0, (1.2, 2.4)
    tips = [shooting_tip(b_true, h_r, phi) for phi in phis]
    res = design_poses([tuple(float(v) for v in tp[:2]) for tp in tips], scene=hard_scene(h_r, 0.0),
                       vary=("phi", "magnetization"), options=DEFAULT, settings=DesignSettings(alpha_terms=2))
    assert res.success, res.message
    d = res.to_dict()
    b = d["design"]["magnetization"]["legendre_coefficients"]
    assert b[1] == pytest.approx(b_true[1], abs=1e-6)
    for pose, phi in zip(d["poses"], phis):
        assert normalise_phi(pose["design"]["phi"] - b[0] - (phi - b_true[0]), 2 * math.pi) == pytest.approx(
            0.0, abs=1e-6)
    assert d["schedule"][-1]["h_r"] == pytest.approx(h_r)
