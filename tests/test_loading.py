"""Quasi-static loading paths (THEORY §8) against independent references.

The jump values of the hysteresis loops are checked against folds located independently with the
shooting solver (numpy/scipy only): a fold of the shooting family in a parameter λ is a solution of
R(γ, λ) = 0 and ∂R/∂γ(γ, λ) = 0, with R = θ'(1) the free-end residual and ∂R/∂γ from the
variational (Jacobi) equation; the landing states are checked to be shooting equilibria with Jacobi
Morse index 0; continuous paths against closed forms (THEORY §6) and mirror symmetry.
"""
import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from actuator_design.continuation.loading import (apply_values, follow_path, normalise_schedule,
                                              ramp)
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.reference.shooting import (ShootingParams, jacobi_morse_index, shoot,
                                                solve_shooting)
from actuator_design.model.scene import default_scene

HALF_PI = 0.5 * math.pi


def shooting_fold(make_params, gamma0, lam0):
    """Solve R(γ, λ) = 0, ∂R/∂γ = 0 for (γ, λ) with the shooting solver (independent of the NLP)."""
    def F(x):
        s = shoot(x[0], make_params(x[1]), variational=True)
        return [s.residual, s.dresidual]

    sol, info, ier, msg = fsolve(F, [gamma0, lam0], full_output=True, xtol=1e-13)
    assert ier in (1, 3), msg  # 3: no further improvement possible (converged to rounding)
    assert max(abs(v) for v in F(sol)) < 1e-10, msg
    return sol


def check_landing(state, params):
    """The state a jump lands on is a shooting equilibrium with Jacobi Morse index 0."""
    ref = solve_shooting(params, state.gamma)
    assert ref.converged
    assert ref.gamma == pytest.approx(state.gamma, rel=1e-8, abs=1e-8)
    assert ref.tip_angle == pytest.approx(state.tip["angle"], abs=1e-9)
    assert ref.tip_y == pytest.approx(state.tip["y"], abs=1e-9)
    assert jacobi_morse_index(ref).index == 0


def test_imperfect_pitchfork_loop_in_p_matches_shooting_folds():
    """Transverse field above h_crit, tip load ramped down through 0 and back up: the classic
    imperfect-pitchfork snap; both jumps at the fold loads ±p_f of the shooting family."""
    h = 1.5
    path = follow_path(default_scene(h=h, phi=HALF_PI, p=0.5), None, {"p": [0.5, -1.0, 1.0, 0.5]})
    assert path.success and not path.snap_free and path.param == "p"
    assert [j.direction for j in path.jumps] == [-1, 1]
    assert all(j.kind == "fold" for j in path.jumps)

    g0 = transverse_mode(h).gamma  # the upper mode-1 state at p = 0 (closed form, THEORY §6)
    _, p_fold = shooting_fold(lambda p: ShootingParams(h=h, phi=HALF_PI, fy=p), g0, -0.3)
    _, p_fold2 = shooting_fold(lambda p: ShootingParams(h=h, phi=HALF_PI, fy=p), -g0, 0.3)
    assert p_fold < 0 < p_fold2
    assert path.jumps[0].param == pytest.approx(p_fold, rel=1e-8)
    assert path.jumps[1].param == pytest.approx(p_fold2, rel=1e-8)

    hy = path.hysteresis
    assert hy["width"] == pytest.approx(p_fold2 - p_fold, rel=1e-8)
    assert len(hy["loops"]) == 1 and hy["loops"][0]["complete"] and hy["area"] > 0
    for j in path.jumps:
        assert j.energy_released > 0
        assert j.from_state.tip["angle"] * j.to_state.tip["angle"] < 0  # snapped to the other side
        assert abs(j.from_state.eigenvalues[0]) < 1e-6  # the critical state is marginal
        check_landing(j.to_state, ShootingParams(h=h, phi=HALF_PI, fy=j.param))
    # mirror symmetry θ → −θ, p → −p: the loop is symmetric
    assert path.jumps[0].energy_released == pytest.approx(path.jumps[1].energy_released, rel=1e-8)
    # every recorded non-critical state is stable
    assert all(p.stable for p in path.points if p.kind != "critical")


def test_hysteresis_area_against_shooting_quadrature():
    """Loop area of the imperfect-pitchfork loop, ∫ (θ1_upper − θ1_lower) dp over [−p_f, p_f], from
    shooting solves: with the mirror symmetry θ1_lower(p) = −θ1_upper(−p) it is 2 ∫ θ1_upper dp;
    the substitution p = −p_f + 2 p_f u² removes the square-root behaviour at the fold, and
    Gauss–Legendre in u integrates it (the upper root is the one with γ > γ_fold, THEORY §8)."""
    from scipy.optimize import brentq

    h = 1.5
    par = lambda p: ShootingParams(h=h, phi=HALF_PI, fy=p)
    g_f, p_f = shooting_fold(par, transverse_mode(h).gamma, -0.3)
    pf = -p_f
    u, w = np.polynomial.legendre.leggauss(16)
    u, w = 0.5 * (u + 1), 0.5 * w
    theta1 = []
    for uk in u:
        p = -pf + 2 * pf * uk ** 2
        g = brentq(lambda g: shoot(g, par(p)).residual, g_f + 1e-12, h * h + abs(p) + 0.1, xtol=1e-14)
        theta1.append(shoot(g, par(p)).tip_angle)
    area = 2 * np.sum(w * np.array(theta1) * 4 * pf * u)
    path = follow_path(default_scene(h=h, phi=HALF_PI, p=0.5), None, {"p": [0.5, -1.0, 1.0, 0.5]},
                       max_dtheta=0.1)
    assert path.hysteresis["area"] == pytest.approx(area, rel=5e-4)


def test_field_rotation_loop_matches_shooting_folds_and_mirror_symmetry():
    """Rotating a strong field across the rod and back (the 'magnetic catapult'): the jump angles are
    shooting folds in φ and mirror-symmetric about π/2 (θ → −θ, φ → π − φ)."""
    h = 1.5
    path = follow_path(default_scene(h=h, phi=0.5), None, ramp("phi", 0.5, 2.6, back=True))
    assert path.success and len(path.jumps) == 2
    up, down = path.jumps
    assert up.direction == 1 and down.direction == -1
    s0 = solve_shooting(ShootingParams(h=h, phi=1.7), up.from_state.gamma * 1.05)
    _, phi_fold = shooting_fold(lambda ph: ShootingParams(h=h, phi=ph), s0.gamma, 1.7)
    assert up.param == pytest.approx(phi_fold, rel=1e-8)
    assert down.param == pytest.approx(math.pi - phi_fold, rel=1e-8)
    assert path.hysteresis["width"] == pytest.approx(2 * phi_fold - math.pi, rel=1e-7)
    check_landing(up.to_state, ShootingParams(h=h, phi=up.param))


def test_two_parameter_schedule_field_ramped_down_from_the_wrong_branch():
    """(h, p) schedule: flip a small load to pull against the buckled rod, then lower the field; the
    rod snaps at the fold field of the shooting family in h (a magnitude-and-load schedule)."""
    p = -0.2
    sched = [{"h": 2.0, "p": 0.2}, {"h": 2.0, "p": p}, {"h": 0.5, "p": p}]
    path = follow_path(default_scene(h=2.0, phi=HALF_PI, p=0.2), None, sched)
    assert path.success and path.param is None and len(path.jumps) == 1
    jump = path.jumps[0]
    assert jump.values["p"] == pytest.approx(p)
    assert 1.0 < jump.t < 2.0
    _, h_fold = shooting_fold(lambda hh: ShootingParams(h=hh, phi=HALF_PI, fy=p),
                              jump.from_state.gamma * 1.1, 1.4)
    assert jump.values["h"] == pytest.approx(h_fold, rel=1e-8)
    assert h_fold > critical_field_transverse(1)
    check_landing(jump.to_state, ShootingParams(h=jump.values["h"], phi=HALF_PI, fy=p))
    # the final state is the load-aligned equilibrium at h = 0.5 (unique there: below h_crit)
    ref = solve_shooting(ShootingParams(h=0.5, phi=HALF_PI, fy=p), 0.0)
    assert path.final.tip["angle"] == pytest.approx(ref.tip_angle, abs=1e-9)
    assert path.hysteresis["loops"] == []


def test_axial_field_with_small_load_is_snap_free_and_continuous():
    """φ = 0, small upward load, field up and back down: one smooth branch, no snap, and the rod
    returns to the field-free elastica (shooting)."""
    p = 0.3
    path = follow_path(default_scene(h=0.0, phi=0.0, p=p), None, ramp("h", 0.0, 3.0, back=True))
    assert path.success and path.snap_free and not path.jumps and not path.bifurcations
    assert all(pt.stable for pt in path.points)
    ang = path.column("angle")
    assert np.max(np.abs(np.diff(ang))) < 0.05  # continuous
    up = path.column("direction") > 0
    assert np.all(np.diff(ang[up]) <= 1e-12)  # the field straightens the rod monotonically
    ref = solve_shooting(ShootingParams(h=0.0, fy=p), 0.3)
    assert path.final.tip["angle"] == pytest.approx(ref.tip_angle, abs=1e-9)
    assert path.states[1].tip["angle"] == pytest.approx(
        solve_shooting(ShootingParams(h=3.0, fy=p), 0.3).tip_angle, abs=1e-9)
    assert path.hysteresis["width"] == 0 and path.hysteresis["area"] == 0


def test_symmetric_pitchfork_is_a_continuous_bifurcation_not_a_snap():
    """φ = π/2, p = 0, h ramped through h_crit: the straight rod loses stability at the pitchfork
    (closed form h_crit = π/(2√2)); the rod buckles continuously (supercritical), no jump."""
    path = follow_path(default_scene(h=0.0, phi=HALF_PI, p=0.0), None, ramp("h", 0.0, 2.0))
    assert path.success and path.snap_free and len(path.bifurcations) == 1
    assert path.bifurcations[0].param == pytest.approx(critical_field_transverse(1), rel=1e-8)
    mode = transverse_mode(2.0)
    assert path.final.tip["y"] == pytest.approx(mode.v1, abs=1e-9)  # the + branch (positive tip)
    assert path.final.tip["x"] == pytest.approx(1 + mode.u1, abs=1e-9)


def test_lowering_the_field_through_the_pitchfork_returns_to_the_straight_rod():
    """φ = π/2, h lowered from 2 to 0 on the buckled branch: the bent branch ends at the pitchfork
    h_crit = π/(2√2) (closed form) on the straight rod, which is the stable state below it; the
    path follows it continuously (no jump, nothing to choose) to the straight rod at h = 0."""
    path = follow_path(default_scene(h=2.0, phi=HALF_PI, p=0.0), None, ramp("h", 2.0, 0.0))
    assert path.success and path.snap_free, path.message
    assert len(path.bifurcations) == 1 and path.bifurcations[0].sign == 0
    assert path.bifurcations[0].param == pytest.approx(critical_field_transverse(1), rel=1e-6)
    assert all(p.stable for p in path.points if p.kind != "critical")  # μ ≈ 0 at the pitchfork
    assert path.final.tip["x"] == pytest.approx(1.0, abs=1e-12)
    assert path.final.tip["y"] == pytest.approx(0.0, abs=1e-12)
    # below h_crit every state is the straight rod; above it the buckled mode (closed form)
    h = path.column("param")
    y = path.column("y")
    assert np.all(np.abs(y[h < critical_field_transverse(1) - 1e-3]) < 1e-9)
    mode = transverse_mode(2.0)
    assert path.states[0].tip["y"] == pytest.approx(mode.v1, abs=1e-9)


def test_follow_path_api_final_and_reaches():
    """The design engineer's use: from zero field to a designed state without a snap."""
    from actuator_design.equilibrium.pipeline import solve

    target = solve(default_scene(h=1.2, phi=1.0, p=0.1))
    path = follow_path(default_scene(h=0.0, phi=1.0, p=0.1), None,
                       [{"h": 0.0, "phi": 1.0}, {"h": 1.2, "phi": 1.0}])
    assert path.snap_free and path.reaches(target, tol=1e-8)
    assert path.final.scene.h == pytest.approx(1.2)
    d = path.to_dict()
    for key in ("points", "jumps", "snap_free", "hysteresis"):
        assert key in d
    assert set(d["points"][0]) >= {"param", "tip", "energy", "stable", "min_eigenvalue"}


@pytest.mark.parametrize("schedule, match", [
    ([{"h": 0.0}], "at least 2"),
    ([{"h": 0.0}, {"q": 1.0}], "q"),
    ([{"bogus": 0.0}, {"bogus": 1.0}], "unknown path parameter 'bogus'"),
    ([{"h": 0.0}, {"h": -1.0}], r"schedule\[1\]\.h: must be >= 0"),
    ({"h": [0.0, 1.0], "phi": [0.0]}, "same length"),
    ([{"h": 0.0}, {"h": float("nan")}], "finite"),
])
def test_bad_schedules_name_the_problem(schedule, match):
    with pytest.raises(ValueError, match=match):
        follow_path(default_scene(), None, schedule)


def test_apply_values_maps_names_to_scene_fields():
    sc = default_scene(h=1.0, phi=0.2, p=0.0)
    out = apply_values(sc, {"h2": 4.0, "p": -1.5, "m_tip": 0.3, "alpha": 0.1, "fx": 0.25})
    assert out.h == 2.0 and out.tip_force == (0.25, -1.5) and out.tip_moment == 0.3
    assert out.fibres.value == 0.1 and out.phi == 0.2
    names, vals = normalise_schedule({"h": [0, 1], "phi": [0.1, 0.2]})
    assert names == ["h", "phi"] and vals.shape == (2, 2)


def test_field_ramp_in_a_dipole_field_scales_both_magnetic_groups():
    """h and h_pos are both ∝ H (THEORY §5): ramping h keeps h_pos/h, and h = 0 keeps the NLP
    structure (the positional term stays built, with a value whose square is 0)."""
    from dataclasses import replace as dc_replace

    from actuator_design.model.scene import DipoleField

    sc = dc_replace(default_scene(h=0.4), field=DipoleField(x0=1.2, y0=-0.3), h_pos=0.2)
    half = apply_values(sc, {"h": 0.2})
    assert half.h_pos == pytest.approx(0.1) and half.h == 0.2
    zero = apply_values(sc, {"h": 0.0})
    assert zero.h_pos > 0 and zero.h_pos ** 2 == 0.0
    assert apply_values(sc, {"h": 0.2, "h_pos": 0.3}).h_pos == 0.3
    from actuator_design.equilibrium.options import SolverOptions

    coarse = SolverOptions(elements=2, degree=6)  # the dipole NLP is slow to build: keep it small
    path = follow_path(sc, coarse, ramp("h", 0.0, 0.1))
    assert path.success and path.final.scene.h_pos == pytest.approx(0.05)


def test_a_path_starting_under_a_large_load_starts_from_rest():
    """p from −300 to −200: the first state is the one reached from rest (the rod hanging along the
    load, tip angle ≈ −π/2, stable; independent shooting reference), not the straight rod's Newton
    landing on a coiled branch (tip angle −7.8 rad, refused as crossing itself, exit 3)."""
    from actuator_design.benchmarks.bvp import bvp_from_scene, solve_bvp_peer

    path = follow_path(default_scene(h=0.0, p=-300.0), schedule={"p": [-300.0, -200.0]})
    assert path.success, path.message
    first = path.states[0]
    assert first.stable and abs(first.tip["angle"] + 0.5 * math.pi) < 1e-3
    ref = solve_bvp_peer(bvp_from_scene(default_scene(h=0.0, p=-200.0)), 1e-10,
                         guess_theta=lambda s: -0.5 * math.pi * (1.0 - np.exp(-math.sqrt(200.0) * s)))
    assert ref.success
    assert np.max(np.abs(np.array([path.final.tip["x"], path.final.tip["y"], path.final.tip["angle"]])
                        - ref.tip)) < 1e-8


@pytest.mark.parametrize("schedule,max_step", [({"h": [0.0, 300.0]}, None), ({"h": [0.0, 3.0, 0.0]}, None),
                                               ({"h": [0.0, 3.0, 0.0]}, 0.25), ({"h": [0.0, 3.0, 0.0]}, 0.05)])
def test_the_transverse_pitchfork_is_continuous_both_ways_at_its_closed_form_field(schedule, max_step):
    """φ = 90°: the first pitchfork h_crit = π/(2√2) (THEORY §6) is supercritical. Up to h = 300 the
    path stepped 0.03 in h past it (1e-4 of the segment) and reported a snap releasing 1.8e-3; down
    through it from the bent side it placed it 1.2e-3 off (the engine's step jumped branches); the
    branch merged onto is now continued back to its own branch point."""
    path = follow_path(default_scene(h=0.0, phi=0.5 * math.pi), schedule=schedule, max_step=max_step)
    assert path.success and path.snap_free and not path.jumps, path.message
    hc = critical_field_transverse(1)
    assert len(path.bifurcations) == len(schedule["h"]) - 1
    for b in path.bifurcations:
        assert b.located and b.param == pytest.approx(hc, abs=1e-9)
