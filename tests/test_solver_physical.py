"""Issue 10, items 1-2: convergence is a promise and ``solve`` returns the physical branch.

References (never the code's own output):
* strong uniform field, no load: the clamp boundary layer in closed form (THEORY §6, the pendulum
  first integral ½ψ'² = h² sin²ψ with ψ = θ − φ → 0 away from the clamp):
  tan(ψ/2) = tan(−φ/2) e^{−√2 h s}; the semi-infinite layer misses the free end condition by
  ~e^{−√2 h} (< 1e-180 here); tip = ∫(cos θ, sin θ) by adaptive quadrature;
* the load p reached from rest: scipy ``solve_bvp`` continued in p from 0 (an independent
  collocation method, tolerance 1e-10).
"""
import math
import subprocess
import sys

import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import default_scene
from actuator_design.transcription.lgl import LGL, graded_breakpoints
from physical_references import bvp_from_rest, layer_tip


@pytest.mark.parametrize("h,phi_deg", [(300.0, 45.0), (300.0, 90.0), (1000.0, 45.0), (1000.0, 90.0)])
def test_strong_field_gives_the_aligned_rod_of_the_closed_form(h, phi_deg):
    r = solve(default_scene(h=h, phi=math.radians(phi_deg)))
    assert r.success and r.stable and not r.self_intersecting, r.message
    x, y = layer_tip(h, math.radians(phi_deg))
    assert abs(r.tip["x"] - x) < 1e-8 and abs(r.tip["y"] - y) < 1e-8, (r.tip, x, y)
    assert abs(r.tip["angle"] - math.radians(phi_deg)) < 1e-8


@pytest.mark.parametrize("phi", [0.0, math.pi / 4])
def test_large_load_from_rest_matches_bvp_continuation_and_straight_start_is_refused(phi):
    """``solve --p=1000`` (h = 1, φ = 45°) and the same load in an axial field."""
    sc = default_scene(phi=phi, p=1000.0)
    r = solve(sc)
    assert r.success and r.stable and not r.self_intersecting, r.message
    x, y = bvp_from_rest(1.0, phi, 1000.0)
    assert abs(r.tip["x"] - x) < 1e-8 and abs(r.tip["y"] - y) < 1e-8
    if phi == 0.0:
        return
    # from the straight rod IPOPT descends into a double loop: not a physical equilibrium
    # on the default uniform mesh (the case) IPOPT descends into a double loop
    s = solve(sc, SolverOptions(start="straight", adapt=False))
    assert s.self_intersecting and not s.success and s.status == "self_intersecting", s.message
    kept = solve(sc, SolverOptions(start="straight", adapt=False, keep_self_intersecting=True))
    assert kept.status != "self_intersecting" and kept.self_intersecting


def test_under_resolved_layer_is_refused_without_adaptation():
    """h = 300, φ = π/2 on the default uniform mesh: the layer (width 1/(√2 h) ≈ 2.4e-3) is under
    elements of length 0.25: the tip misses the closed form, and the result says so."""
    r = solve(default_scene(h=300.0, phi=math.pi / 2), SolverOptions(adapt=False))
    x, _ = layer_tip(300.0, math.pi / 2)
    assert not r.success and r.status in ("inaccurate", "self_intersecting"), r.message
    assert abs(r.tip["x"] - x) > 1e-6 or r.self_intersecting


def test_every_ipopt_failure_status_is_a_failure():
    r = solve(default_scene(h=3.0, phi=1.0), SolverOptions(max_iter=2, start="straight"))
    assert not r.success and r.status != "converged"
    assert "IPOPT" in r.message


def test_graded_lgl_mesh_is_exact_for_polynomials():
    """Grading changes only where the elements are: the weights integrate s^k exactly
    (degree 2d − 1 LGL rule on every element) and θ' of a polynomial of degree ≤ d is exact."""
    bp = graded_breakpoints(4, 5, 2)
    assert np.all(np.diff(bp) > 0) and bp[0] == 0 and bp[-1] == 1 and bp[1] == pytest.approx(2.0 ** -5 / 4)
    tr = LGL(4, 6, 5, 2)
    for k in range(11):
        assert abs(np.dot(tr.quadrature_weights, tr.quadrature_points ** k) - 1.0 / (k + 1)) < 1e-14
    z = 3 * tr.nodes ** 5 - tr.nodes
    s = np.linspace(0, 1, 37)
    th, dth = tr.theta_dense(z, s)
    assert np.max(np.abs(th - (3 * s ** 5 - s))) < 1e-12
    assert np.max(np.abs(dth - (15 * s ** 4 - 1))) < 1e-10


def _cli(*args):
    import os
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "actuator_design.cli", "solve", *args],
                          capture_output=True, text=True, env=env, timeout=300)


def test_cli_exit_codes_for_refused_answers():
    ok = _cli("--h", "300", "--phi-deg", "45", "--json")
    assert ok.returncode == 0, ok.stderr
    loop = _cli("--p=1000", "--start", "straight", "--no-adapt")
    assert loop.returncode == 3 and "intersects itself" in loop.stderr
    coarse = _cli("--h", "300", "--phi-deg", "90", "--no-adapt")
    assert coarse.returncode == 3


def test_other_stable_state_at_the_same_scene_is_reported():
    """h = 2.5, φ = 100°, p = 1: ramped from rest the near-straight rod loses stability on the way
    (a BVP continuation would stay on that branch, which the independent Jacobi test finds
    unstable, Morse index 1) and the rod ends up bent up; from the straight rod IPOPT finds it bent
    down. Both are equilibria of the shooting reference and stable by the Jacobi conjugate-point
    test (THEORY §7); solve returns the first and names the second."""
    from actuator_design.benchmarks.problems import shooting_params_from_scene
    from actuator_design.reference.shooting import jacobi_morse_index, solve_shooting

    h, phi, p = 2.5, math.radians(100.0), 1.0
    sc = default_scene(h=h, phi=phi, p=p)
    r = solve(sc)
    assert r.success and r.stable, r.message
    assert "another stable state" in r.message
    other = r.stats["other_stable_states"][0]
    straight = solve(sc, SolverOptions(start="straight"))
    assert straight.success and straight.stable
    assert other["tip"]["y"] == pytest.approx(straight.tip["y"], abs=1e-12) and straight.tip["y"] < 0 < r.tip["y"]
    prm = shooting_params_from_scene(sc)
    for res in (r, straight):
        ref = solve_shooting(prm, gamma_guess=res.gamma)
        assert ref.converged
        assert np.max(np.abs(np.array(ref.tip[:2]) - (res.tip["x"], res.tip["y"]))) < 1e-8
        assert jacobi_morse_index(ref, prm).index == 0
    near_straight = solve_shooting(prm, gamma_guess=0.0)
    assert near_straight.converged and jacobi_morse_index(near_straight, prm).index == 1


def test_yaml_solver_section_takes_the_new_keys(tmp_path):
    from actuator_design.config import load_config

    f = tmp_path / "c.yaml"
    f.write_text("scene:\n  type: dimensionless\n  h: 1.0\n  phi: 45 deg\n  p: 1000\n"
                 "solver:\n  start: straight\n  adapt: false\n  residual_tol: 1e-3\n"
                 "  keep_self_intersecting: true\n")
    opts = load_config(f).solver.to_options()
    assert (opts.start, opts.adapt, opts.residual_tol, opts.keep_self_intersecting) == ("straight", False, 1e-3, True)
