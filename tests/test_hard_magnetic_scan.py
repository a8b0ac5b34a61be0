"""The shooting-based analyses with the hard-magnetic term (issue 12, THEORY §9).

References, each independent of the shooting scan under test:

* the closed forms of the anti-parallel field on an axial magnetisation (β = 0, φ = π): the
  equation θ'' + h_r sin θ = 0 is Euler's elastica under a dead compressive end load h_r, whose
  k-th mode branches off the straight rod at h_r = ((2k − 1)π/2)² (π²/4 first, THEORY §9), so for
  ((2k − 1)π/2)² < h_r < ((2k + 1)π/2)² there are 2k + 1 equilibria, of which the straight rod
  (index k) and the higher modes are unstable and only the first mode's pair is stable;
* the reference shooting solver of :mod:`actuator_design.reference.shooting` (scipy DOP853, its own
  right-hand side with the remanent torque): sign changes of its free-end residual on a fine γ grid
  over a window twice the hand-derived bound h² + h_r + |p| (so the a-priori window is tested too),
  each refined by brentq; Morse indices by Sturm's count of the Jacobi equation with the reference
  coefficient Q of :func:`~actuator_design.reference.shooting.jacobi_coefficient`;
* the NLP of the deflated-Newton multistart (Method B), which shares no code with the scan;
* the first integral H of the autonomous equation, conserved along each trajectory.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from actuator_design.analysis.equilibria import (find_equilibria, find_equilibria_deflation,
                                                 gamma_bound)
from actuator_design.model.profiles import constant_profile, expression_profile
from actuator_design.reference.shooting import (ShootingParams, jacobi_coefficient, shoot,
                                                solve_shooting, sturm_morse_index)
from actuator_design.model.scene import Scene, UniformField

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def hard_scene(h_r, phi, beta=0.0, h=0.0, alpha=0.0, p=None):
    beta_p = beta if hasattr(beta, "kind") else constant_profile(beta)
    return Scene(field=UniformField(phi=phi), h=h, fibres=constant_profile(alpha),
                 tip_force=None if p is None else (0.0, p), h_r=h_r, magnetization=beta_p)


def euler_counts(h_r):
    """(equilibria, stable) of θ'' + h_r sin θ = 0, θ(0) = 0, θ'(1) = 0 (module docstring)."""
    k = sum(((2 * j - 1) * math.pi / 2) ** 2 < h_r for j in range(1, 20))
    return 2 * k + 1, (1 if k == 0 else 2)


def reference_equilibria(P: ShootingParams, n: int = 801):
    """Every root of the reference free-end residual in |γ| ≤ 2(h² + h_r + |f| + |m|) + 1, with
    its Sturm Morse index (the reference Q contains h_r cos(θ + β − φ))."""
    W = 2 * (P.h ** 2 + P.h_r + math.hypot(P.fx, P.fy) + abs(P.m)) + 1
    g = np.linspace(-W, W, n)
    r = np.array([shoot(x, P).residual for x in g])
    out = []
    for i in np.flatnonzero(r[:-1] * r[1:] < 0):
        sol = solve_shooting(P, bracket=(g[i], g[i + 1]))
        assert sol.converged
        Q = lambda s, sol=sol: float(jacobi_coefficient(sol.theta(s), s, P))
        out.append((sol, sturm_morse_index(Q, P.b).index))
    assert not np.any(r == 0.0)  # no root sits exactly on the grid (it would be missed above)
    return out


BETA_GRADED = "0.8*sin(pi*s)"
CASES = {  # id: (scene keywords, reference parameters)
    "oblique": (dict(h_r=4.0, phi=2.5), dict(h_r=4.0, phi=2.5)),
    "antiparallel_h_r_30": (dict(h_r=30.0, phi=math.pi), dict(h_r=30.0, phi=math.pi)),
    "imperfect": (dict(h_r=8.0, phi=math.pi - 0.05), dict(h_r=8.0, phi=math.pi - 0.05)),
    "soft_plus_hard_loaded": (dict(h_r=3.0, phi=1.9, beta=0.3, h=0.8, alpha=0.3, p=-0.4),
                              dict(h_r=3.0, phi=1.9, beta=0.3, h=0.8, alpha=0.3, fy=-0.4)),
    "graded_beta": (dict(h_r=6.0, phi=2.8, beta=expression_profile(BETA_GRADED), h=0.8, p=-0.4),
                    dict(h_r=6.0, phi=2.8, beta=lambda s: 0.8 * np.sin(np.pi * s), h=0.8, fy=-0.4)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_equilibria_match_the_reference_shooting(case):
    kw, pk = CASES[case]
    res = find_equilibria(hard_scene(**kw))
    ref = reference_equilibria(ShootingParams(**pk))
    assert res.complete and not res.failures
    assert res.count == len(ref) >= 1
    for eq, (sol, index) in zip(res.equilibria, ref):
        assert abs(sol.gamma) <= res.window[1]  # the a-priori window holds every root
        assert eq.gamma_shooting == pytest.approx(sol.gamma, abs=1e-7)
        for k, v in zip(("x", "y", "angle"), sol.tip):
            assert eq.tip[k] == pytest.approx(v, abs=1e-8)
        assert eq.energy == pytest.approx(sol.energy, abs=1e-8)
        assert eq.morse_index == index


@pytest.mark.parametrize("case", ["antiparallel_h_r_30", "imperfect"])
def test_the_nlp_multistart_finds_the_same_equilibria(case):
    """Method B (deflated Newton on the NLP, no shooting) finds the same set as the scan."""
    kw, _ = CASES[case]
    a, b = find_equilibria(hard_scene(**kw)), find_equilibria_deflation(hard_scene(**kw))
    assert a.count == b.count
    for ea, eb in zip(a.equilibria, b.equilibria):
        assert ea.tip["angle"] == pytest.approx(eb.tip["angle"], abs=1e-8)
        assert ea.morse_index == eb.morse_index


@pytest.mark.parametrize("h_r", [1.0, 5.0, 30.0, 70.0])
def test_antiparallel_counts_follow_euler_buckling(h_r):
    res = find_equilibria(hard_scene(h_r, math.pi))
    assert res.complete
    assert (res.count, res.stable_count) == euler_counts(h_r)


def test_gamma_bounds_gain_h_r():
    """Integral bound h² + |p| + h_r (THEORY §5 scene plus §9); for φ = π, β = 0 the first
    integral ½θ'² − h_r cos θ gives |θ'(0)| ≤ 2√h_r, reached by the shot that ends at θ = π."""
    gb = gamma_bound(hard_scene(2.5, 0.7, h=1.3, p=0.8))
    assert gb["integral"] == pytest.approx(1.3 ** 2 + 0.8 + 2.5, rel=1e-14)
    gb = gamma_bound(hard_scene(9.0, math.pi))
    assert gb["first_integral"] == pytest.approx(2 * math.sqrt(9.0), rel=1e-14)
    assert gb["bound"] == gb["first_integral"]


def _cli(*argv):
    env = {**os.environ, "PYTHONPATH": ROOT, "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "actuator_design.cli.main", *argv],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)


def test_critical_cli_finds_the_buckling_of_the_antiparallel_field_at_pi_squared_over_4():
    p = _cli("critical", "--h", "0", "--phi-deg", "180", "--h-r", "0", "--param", "h_r",
             "--window", "0,5", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] and d["folds"] == []
    (bp,) = d["branch_points"]
    assert bp["value"] == pytest.approx(math.pi ** 2 / 4, abs=1e-6)
    assert bp["tip_angle"] == pytest.approx(0.0, abs=1e-6)
    assert (bp["equilibria_below"], bp["equilibria_above"]) == (euler_counts(2.0)[0], euler_counts(3.0)[0])


def test_equilibria_cli_on_a_hard_magnetic_scene(tmp_path):
    """Flags add the term (--h-r, --magnetization-deg); the count is the reference's."""
    p = _cli("equilibria", "--h", "0.8", "--phi-deg", "160", "--alpha-deg", "0", "--h-r", "8",
             "--magnetization-deg", "-10", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    ref = reference_equilibria(ShootingParams(h=0.8, phi=math.radians(160), h_r=8.0,
                                              beta=math.radians(-10)))
    assert d["complete"] and d["count"] == len(ref) >= 2
    assert [e["morse_index"] for e in d["equilibria"]] == [i for _, i in ref]
    assert d["groups"]["h_r"] == 8.0


def test_map_cli_counts_match_closed_form_and_reference():
    """Row φ = π against Euler's counts, row φ = 2.5 against the reference shooting."""
    p = _cli("map", "--h", "0", "--h-r", "1", "--x-param", "h_r", "--x-range", "1,30",
             "--y-param", "phi", "--y-range", f"2.5,{math.pi!r}", "--n", "3,2", "--workers", "1",
             "--no-curves", "--quiet", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    xs = d["x"]
    assert xs[0] == 1.0 and xs[-1] == 30.0 and d["y"][-1] == math.pi
    hrs = xs
    assert d["complete"]
    for j, h_r in enumerate(hrs):
        assert (d["counts"][1][j], d["stable"][1][j]) == euler_counts(h_r)
        ref = reference_equilibria(ShootingParams(h_r=h_r, phi=2.5), n=401)
        assert d["counts"][0][j] == len(ref)
        assert d["stable"][0][j] == sum(i == 0 for _, i in ref)


def test_phase_portrait_finds_the_equilibria_itself():
    """Without given equilibria the portrait runs the scan; each trajectory conserves
    H = ½θ'² + h_r cos(θ + β − φ) (hand-derived first integral) and their number is Euler's."""
    from actuator_design.analysis.phase import phase_portrait

    pp = phase_portrait(hard_scene(5.0, math.pi), n_grid=41)
    assert len(pp.trajectories) == euler_counts(5.0)[0]
    assert max(t.spread for t in pp.trajectories) < 1e-8
    assert sum(t.stable for t in pp.trajectories) == euler_counts(5.0)[1]
