"""A published experiment, shipped (issue 21 item 7): the hard-magnetic cantilever of Zhao et al.,
"Mechanics of hard-magnetic soft materials", JMPS 124 (2019), in an anti-parallel field.

configs/fit_zhao2019.yaml fits Young's modulus E to the digitised maximum deflections δ/L of
problems/data/zhao2019_cantilever.csv (L = 17.2 mm, t = 0.84 mm, B_r = 0.143 T). The tests check

* the shipped config and data load and validate, and the width the config assumes cancels in h_r
  (h_r = 12 μ0 M_r H ℓ²/(E t²), written out here);
* the fit converges, its 95 % interval contains the best fit and the rms residual is stated;
* the fitted model is what an independent computation gives at the fitted E: the forward
  ``solve`` and the shooting reference re-solve data points, and the maximum of |y(s)| over the
  dense shape is the tip's (so the fitted tip deflection is the measured maximum deflection);
* the model's buckling field — the tool's ``critical_points`` along h_r and a bisection of the
  shooting reference's Jacobi test on the straight rod — is π²/4 in h_r and lies below 5 mT.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design import load_scene, solve
from actuator_design.calibration import fit_config, prepare_fit, read_data
from actuator_design.reference.shooting import (ShootingParams, jacobi_morse_index, shoot,
                                                solve_shooting)

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "fit_zhao2019.yaml"
DATA = ROOT / "problems" / "data" / "zhao2019_cantilever.csv"
MU0 = 4e-7 * math.pi  # written out (independent of actuator_design.model.units)
L, T, BR = 17.2e-3, 0.84e-3, 0.143
B_MT = np.array([5, 7, 10, 15, 25, 40], float)
DELTA = np.array([0.550, 0.760, 0.779, 0.681, 0.530, 0.421])


def remanent_group(E, B_mT, width):
    """h_r = μ0 M_r H A ℓ²/(E I) with A = w t, I = w t³/12, μ0 M_r = B_r, H = B/μ0 (THEORY §9)."""
    A, I = width * T, width * T**3 / 12.0
    return BR * (B_mT * 1e-3 / MU0) * A * L**2 / (E * I)


def scene_at(E, B_mT, width="5 mm", angle="180 deg"):
    import yaml
    cfg = {"scene": yaml.safe_load(CONFIG.read_text())["scene"]}
    cfg["scene"]["rod"].update(youngs_modulus=f"{float(E)!r} Pa", width=width)
    cfg["scene"]["field"].update(magnitude=f"{float(B_mT)!r} mT", angle=angle)
    return load_scene(cfg)


@pytest.fixture(scope="module")
def result():
    return fit_config(CONFIG, DATA, interruptible=False)


# -- fast: the shipped files ----------------------------------------------------------------------
def test_the_shipped_config_and_data_load_and_validate():
    problem = prepare_fit(CONFIG, DATA)  # every check of a fit, before fitting
    assert problem.names == ["youngs_modulus"]
    data = read_data(DATA, ignore_columns=["delta_over_L", "delta_over_L_uncertainty"])
    assert data.n == 6 and data.outputs == ["tip_deflection"]
    assert np.allclose(data.columns["field"], B_MT * 1e-3 / MU0)  # mT of B = μ0 H
    assert np.allclose(data.columns["tip_deflection"], DELTA * L, atol=1e-9)  # δ/L · 17.2 mm
    text = DATA.read_text()
    assert "Zhao" in text and "244-263" in text and "0.01" in text
    # the digitised δ/L and its ±0.01 are kept in the file (ignored columns)
    rows = [ln.split(",") for ln in text.splitlines() if ln and ln[0].isdigit()]
    assert np.allclose([float(r[2]) for r in rows], DELTA)
    assert all(float(r[3]) == 0.01 for r in rows)
    assert problem.sigma[0] == pytest.approx(0.01 * L)
    # the example says where a small imperfection matters
    assert "just above the buckling field" in CONFIG.read_text()


def test_the_assumed_width_cancels_in_h_r():
    """The config assumes w = 5 mm; h_r = 12 B_r H ℓ²/(E t²) does not depend on it."""
    for width in ("5 mm", "2 mm", "20 mm"):
        scene, _, _ = scene_at(1.0e6, 10.0, width=width)
        assert scene.h_r == pytest.approx(12 * BR * (10e-3 / MU0) * L**2 / (1.0e6 * T**2), rel=1e-12)
        assert scene.h == 0.0 and scene.phi == pytest.approx(math.pi)
        w = float(width.split()[0]) * 1e-3
        assert scene.h_r == pytest.approx(remanent_group(1.0e6, 10.0, w), rel=1e-12)


# -- the fit ----------------------------------------------------------------------------------------
def test_the_fit_converges_with_an_interval_around_the_best_fit(result):
    assert result.success, result.message
    assert result.status == "converged"
    p = result.parameters["youngs_modulus"]
    lo, hi = p["ci"]
    assert lo < p["value"] < hi and p["unit"] == "Pa"
    assert 0.5e6 < p["value"] < 2e6  # a silicone–NdFeB composite, ~1 MPa
    assert (hi - lo) / p["value"] < 0.2
    assert all(pt["stable"] and pt["converged"] for pt in result.points)
    # the rms residual is stated (in the summary, in the data's unit) and is a few σ = 0.01 L at most
    rms = result.rms["tip_deflection"]
    assert f"rms tip_deflection {rms:.4g} mm" in result.summary()
    assert 0.0 < rms * 1e-3 / L < 0.03
    assert result.goodness_of_fit["tested"] and result.goodness_of_fit["passed"]


def test_the_fitted_model_is_the_forward_solve_and_the_shooting_solution(result):
    """Re-solve data points at the fitted E with two other methods and compare δ/L."""
    E = result.parameters["youngs_modulus"]["value"]
    s = np.linspace(0.0, 1.0, 2001)
    for i in (0, 3):  # 5 mT (just above buckling) and 15 mT (curled back past the clamp)
        predicted = result.model[i, 0] / L
        scene, options, _ = scene_at(E, B_MT[i])
        assert scene.h_r == pytest.approx(remanent_group(E, B_MT[i], 5e-3), rel=1e-10)
        r = solve(scene, options)
        assert r.success and r.stable
        y = r.evaluate(s)["y"]
        assert abs(r.tip["y"]) == pytest.approx(predicted, abs=1e-6)
        # the maximum deflection of the dense shape is the tip's (θ rises monotonically to < π)
        assert np.max(np.abs(y)) == pytest.approx(abs(r.tip["y"]), abs=1e-9)
        # shooting reference (numpy/scipy only), on the up-buckled branch
        params = ShootingParams(h_r=remanent_group(E, B_MT[i], 5e-3), phi=math.pi)
        sol = solve_shooting(params, gamma_guess=abs(r.gamma))
        assert sol.converged and sol.gamma > 0
        assert jacobi_morse_index(sol).stable
        y_ref = sol.ode(s)[3]
        assert np.all(np.diff(y_ref) >= -1e-12)  # monotone: max |y| at the tip
        assert y_ref[-1] == pytest.approx(predicted, abs=1e-6)
        if B_MT[i] > 11:
            assert r.tip["x"] < 0  # the rod has curled back past the clamp, yet y is monotone


def test_the_buckling_field_of_the_model_lies_below_5_mT(result):
    from actuator_design import critical_points
    E = result.parameters["youngs_modulus"]["value"]
    c_r = result.derived["h_r_per_field"]["value"]  # h_r per A/m
    assert c_r == pytest.approx(remanent_group(E, 1.0, 5e-3) / (1e-3 / MU0), rel=1e-6)
    scene, options, _ = scene_at(E, 5.0)
    crit = critical_points(scene, "h_r", (1.5, 3.5), options=options)
    values = [bp["value"] for bp in crit.branch_points]
    assert len(values) == 1 and values[0] == pytest.approx(math.pi**2 / 4, rel=1e-6)
    # the same from the shooting reference: the straight rod's Morse index jumps 0 → 1
    lo, hi = 1.0, 4.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        straight = shoot(0.0, ShootingParams(h_r=mid, phi=math.pi))
        if jacobi_morse_index(straight).index == 0:
            lo = mid
        else:
            hi = mid
    assert 0.5 * (lo + hi) == pytest.approx(math.pi**2 / 4, rel=1e-6)
    B_c_mT = 1e3 * MU0 * values[0] / c_r
    assert 4.0 < B_c_mT < 5.0  # the 5 mT point sits just above the buckling field
    assert B_c_mT == pytest.approx(1e3 * MU0 * (math.pi**2 / 4) * E * T**2 / (12 * BR * L**2), rel=1e-6)


def test_the_example_script_prints_the_fit_the_sensitivity_and_writes_its_figure(tmp_path, capsys):
    import importlib.util
    spec = importlib.util.spec_from_file_location("zhao2019_refit", ROOT / "problems" / "zhao2019_refit.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.main([str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "95 % interval" in out and "rms residual" in out and "buckling field" in out
    assert (tmp_path / "out" / "zhao2019_fit.png").stat().st_size > 10_000
    assert script.main([str(ROOT / "problems")]) == 2  # never into the repository
    # near the buckling field a 1° imperfection moves δ/L at 5 mT by more than 2σ = 0.02
    res = script.fitted()
    s = script.sensitivity_at_5mT(res)
    assert abs(s["towards"][1.0] - s["perfect"]) > 0.02
    assert abs(s["against"][1.0] - s["perfect"]) > 0.02
    assert s["E_low"] > s["perfect"] > s["E_high"]
