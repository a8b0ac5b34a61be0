"""``actuator-design bench`` (smoke, no timing assertions) and the benchmark's references.

The references are checked against a second, independent method: the Bisshopp–Drucker elliptic
elastica against its quadrature form and the shooting solver; the dipole shooting reference
against scipy's solve_bvp; the fold load against THEORY §6's ≈ 10.3.
"""
import json

import numpy as np
import pytest

from actuator_design.benchmarks.bvp import (RodBVP, bvp_from_scene, dipole_field, dipole_field_jacobian,
                                            solve_bvp_peer)
from actuator_design.benchmarks.problems import (PROBLEMS, elastica_tip, elastica_tip_quadrature,
                                                 shooting_params_from_scene)
from actuator_design.cli.main import main
from actuator_design.reference.shooting import solve_shooting


def test_bench_quick_json_contract(capsys, tmp_path):
    code = main(["bench", "--quick", "--problems", "paper_axial", "--repeats", "1", "--json",
                 "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    assert code == 0
    payload = json.loads(out)  # exactly one JSON object on stdout
    rows = payload["rows"]
    assert rows and {"problem", "method", "n", "error", "time_s", "peer"} <= set(rows[0])
    assert {r["problem"] for r in rows} == {"paper_axial"}
    assert all(r["peer"] == (r["method"] == "solve_bvp") for r in rows)
    methods = {r["method"] for r in rows}
    assert {"lgl-fast", "midpoint-fast", "lgl-ipopt", "numpy-floor", "solve_bvp"} <= methods
    # every converged project row meets the reference to within its discretisation error: the
    # high-order rows far below the low-order ones, all finite
    fast = {r["label"]: r for r in rows if r["method"] == "lgl-fast"}
    assert fast["E=1 d=12"]["converged"] and fast["E=1 d=12"]["error"] < 1e-9
    assert all(np.isfinite(r["time_s"]) and r["time_s"] > 0 for r in rows if r["converged"])
    for name in ("bench.json", "bench.csv", "bench_pareto.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert payload["targets"][0]["problem"] == "paper_axial"


def test_bench_rejects_unknown_problem(capsys):
    assert main(["bench", "--problems", "nope"]) == 2
    assert "--problems" in capsys.readouterr().err


def test_bench_lists_problems(capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in PROBLEMS)


# -- the references themselves ----------------------------------------------------------------------
@pytest.mark.parametrize("p", [0.5, 3.0, 9.0])
def test_elastica_closed_forms_agree_with_each_other_and_shooting(p):
    a = np.array(elastica_tip(p))
    b = np.array(elastica_tip_quadrature(p))
    np.testing.assert_allclose(a, b, atol=1e-12)
    sc = PROBLEMS["elastica"].scene
    from dataclasses import replace
    sh = solve_shooting(shooting_params_from_scene(replace(sc, tip_force=(0.0, p))), gamma_guess=np.sqrt(p))
    np.testing.assert_allclose(a, sh.tip, atol=1e-10)


def test_elastica_large_load_limit():
    """p → ∞: x(1) → √(2/p), y(1) → 1 − (2 − √2)/√p, θ(1) → π/2 (exponentially small corrections)."""
    p = 1e4
    x, y, th = elastica_tip(p)
    assert x == pytest.approx(np.sqrt(2 / p), rel=1e-12)
    assert y == pytest.approx(1 - (2 - np.sqrt(2)) / np.sqrt(p), abs=1e-12)
    assert th == pytest.approx(np.pi / 2, abs=1e-12)


def test_dipole_field_jacobian_is_the_derivative():
    rx, ry = np.array([0.3, -0.7]), np.array([0.2, 0.9])
    (jxx, jxy), (jyx, jyy) = dipole_field_jacobian(rx, ry, 0.5, 0.8, 1.2)
    eps = 1e-6
    hxp, hyp = dipole_field(rx + eps, ry, 0.5, 0.8, 1.2)
    hxm, hym = dipole_field(rx - eps, ry, 0.5, 0.8, 1.2)
    np.testing.assert_allclose(jxx, (hxp - hxm) / (2 * eps), rtol=1e-7)
    np.testing.assert_allclose(jyx, (hyp - hym) / (2 * eps), rtol=1e-7)
    hxp, hyp = dipole_field(rx, ry + eps, 0.5, 0.8, 1.2)
    hxm, hym = dipole_field(rx, ry - eps, 0.5, 0.8, 1.2)
    np.testing.assert_allclose(jxy, (hxp - hxm) / (2 * eps), rtol=1e-7)
    np.testing.assert_allclose(jyy, (hyp - hym) / (2 * eps), rtol=1e-7)
    # (∂hx/∂y = ∂hy/∂x is checked by the two difference quotients above: the field is curl-free;
    # the in-plane divergence of a 3-D dipole is −∂hz/∂z, not 0)


def test_dipole_reference_agrees_with_solve_bvp():
    prob = PROBLEMS["dipole"]
    ref = np.array(prob.reference_tip())
    peer = solve_bvp_peer(bvp_from_scene(prob.scene), 1e-10, guess_theta=prob.guess)
    assert peer.success
    np.testing.assert_allclose(ref, peer.tip, atol=1e-9)


def test_uniform_bvp_matches_shooting_reference():
    """The peer's first-order system (with a distributed load) is the shooting solver's EL equation."""
    bvp = RodBVP(h=0.9, field=("uniform", 2.0), fx=0.3, fy=-0.8, m=0.4, qx=-0.2, qy=-1.5, theta0=0.25,
                 alpha=lambda s: 0.6 * np.sin(np.pi * s), b=lambda s: 1 + 0.5 * s**2)
    sol = solve_bvp_peer(bvp, 1e-10)
    from actuator_design.reference.shooting import ShootingParams
    sh = solve_shooting(ShootingParams(h=0.9, phi=2.0, fx=0.3, fy=-0.8, m=0.4, qx=-0.2, qy=-1.5, theta0=0.25,
                                       alpha=lambda s: 0.6 * np.sin(np.pi * s), b=lambda s: 1 + 0.5 * s**2),
                        gamma_guess=float(sol.Y[1, 0]))
    assert sol.success and sh.converged
    np.testing.assert_allclose(sol.tip, sh.tip, atol=1e-9)


def _square(x):
    return x * x


def test_map_parallel_keeps_order_on_several_processes():
    from actuator_design.parallel import map_parallel
    assert map_parallel(_square, range(7), workers=2, progress=False) == [x * x for x in range(7)]
    assert map_parallel(_square, [], workers=2) == []


def test_bench_study_section_runs_both_commands_and_the_tips_agree(capsys):
    """``bench --study`` on a tiny grid (no timing assertion): the study's tips agree with the
    independent solve_bvp walk of the same grid where both follow one branch (φ ≠ 90°)."""
    code = main(["bench", "--study", "--points", "40", "--map-n", "4", "--repeats", "1", "--json"])
    out, _ = capsys.readouterr()
    assert code == 0
    res = json.loads(out)
    assert res["sweep"]["points"] == 40 and res["map"]["points"] == 16
    for part in ("sweep", "map"):
        r = res[part]
        assert r["median_s"] > 0 and r["peer_median_s"] > 0
        assert r["speedup_per_point"] == pytest.approx(
            (r["points"] / r["median_s"]) / (r["peer_points"] / r["peer_median_s"]))
    assert res["sweep"]["max_tip_difference"] < 1e-7


def test_bench_study_rejects_bad_sizes(capsys):
    assert main(["bench", "--study", "--points", "3"]) == 2
    assert "--points" in capsys.readouterr().err
