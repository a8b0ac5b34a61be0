"""Calibration against the SYNTHETIC data sets of problems/data (problems/make_synthetic_data.py).

Those files were generated from known parameters with independent references — THEORY §6's closed
form for the transverse field, the shooting solver of actuator_design.reference otherwise — plus
Gaussian noise with a fixed seed. The tests check that

* each fit recovers the known parameters inside its own confidence intervals, with a residual
  scatter equal to the noise that was added;
* the fitted model of the transverse data is THEORY §6's closed form θ(1) = −β, K(sin²β) = √2 h, on
  the branch the data were measured on, and mirrored data (θ → −θ, a symmetry of the model) give
  the same parameter on the mirrored branch;
* χ̄ and E from field data alone are reported as not identifiable, and the combination χ̄/E is
  recovered;
* the exact sensitivities (implicit function theorem) agree with central finite differences of
  re-solved equilibria.
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design.cli.main import main
from actuator_design.calibration import fit, fit_config, prepare_fit
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "problems" / "data"
CONFIGS = ROOT / "configs"
MU0 = 4e-7 * math.pi

# The known values the synthetic files were generated with (problems/make_synthetic_data.py).
CHI, E = 0.5, 1.0e6
L, W, T = 20e-3, 5e-3, 0.5e-3
NOISE_DEG, NOISE_MM = 0.5, 0.05


def field_coefficient(chi, e):
    """h/H = √(μ0 χ̄ A ℓ²/(2 E I)) (THEORY §5), m/A."""
    return math.sqrt(MU0 * chi * W * T * L**2 / (2.0 * e * W * T**3 / 12.0))


def inside(p, true):
    lo, hi = p["ci"]
    return lo <= true <= hi


@pytest.fixture(scope="module")
def transverse_cli(tmp_path_factory):
    out = tmp_path_factory.mktemp("fit") / "out"
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["fit", str(CONFIGS / "fit_transverse_buckling.yaml"), "--data",
                     str(DATA / "synthetic_transverse_buckling.csv"), "--json", "--out", str(out)])
    return code, json.loads(buf.getvalue()), out


def test_transverse_fit_recovers_chi_bar_and_clamp_angle(transverse_cli):
    code, res, out = transverse_cli
    assert code == 0 and res["success"], res["message"]
    p = res["parameters"]
    assert inside(p["chi_bar"], CHI), p["chi_bar"]
    assert inside(p["clamp_angle"], 0.0), p["clamp_angle"]
    assert p["chi_bar"]["ci"][1] - p["chi_bar"]["ci"][0] < 0.05  # informative, not vacuous
    assert res["identifiable"] and not res["warnings"]
    # the residual scatter is the noise that was added (0.5 deg), to sampling accuracy
    assert 0.35 < res["rms"]["tip_angle"] < 0.65
    assert all(pt["stable"] and pt["converged"] for pt in res["points"])
    # derived: the buckling field H_crit = h_crit / c contains the true one
    hc_true = critical_field_transverse() / field_coefficient(CHI, E)
    assert inside(res["derived"]["transverse_critical_field"], hc_true)
    for name in ("fit.json", "fit_points.csv", "fit_data_vs_model.png", "fit_residuals.png"):
        assert (out / name).stat().st_size > 0
    assert json.loads((out / "fit.json").read_text())["parameters"]["chi_bar"]["value"] == \
        p["chi_bar"]["value"]


@pytest.fixture(scope="module")
def field_only_fits(tmp_path_factory):
    """χ̄ and E from the transverse data, and from the same data mirrored (θ → −θ)."""
    cfg = CONFIGS / "fit_transverse_buckling_unidentifiable.yaml"
    src = DATA / "synthetic_transverse_buckling.csv"
    lines = src.read_text().splitlines()
    mirrored = [ln if (ln.startswith("#") or "[" in ln) else
                f"{ln.split(',')[0]}, {-float(ln.split(',')[1]):.3f}" for ln in lines]
    path = tmp_path_factory.mktemp("mirror") / "mirrored.csv"
    path.write_text("\n".join(mirrored) + "\n")
    return fit_config(cfg, src), fit_config(cfg, path)


def test_chi_bar_and_modulus_are_not_identifiable_from_field_data(field_only_fits):
    res, _ = field_only_fits
    assert res.success, res.message
    assert not res.identifiable
    assert len(res.warnings) == 1
    w = res.warnings[0]
    assert "chi_bar" in w and "youngs_modulus" in w and "not identifiable" in w
    assert res.parameters["youngs_modulus"]["fitted"] is False
    assert res.parameters["youngs_modulus"]["value"] == 1e6  # held at its initial value
    (combo,) = res.combinations
    assert combo["name"] == "chi_bar * youngs_modulus^-1"
    assert combo["ci"][0] <= CHI / E <= combo["ci"][1]
    assert res.parameters["chi_bar"]["ci"][0] <= CHI <= res.parameters["chi_bar"]["ci"][1]


def test_fitted_model_is_the_closed_form_on_the_measured_branch(field_only_fits):
    res, mirrored = field_only_fits
    c = res.derived["h_per_field"]["value"]
    H = res.data.columns["field"]
    model = res.model[:, 0]
    hc = critical_field_transverse()
    for Hi, m in zip(H, model):
        h = c * Hi
        if h < 0.995 * hc:
            assert abs(m) < 1e-8  # only the straight rod exists (THEORY §6)
        elif h > 1.005 * hc:
            assert m == pytest.approx(-transverse_mode(h).beta, abs=1e-7)  # the downward branch
    # mirrored data: the same χ̄ (a symmetry of the model), the upward branch
    assert mirrored.parameters["chi_bar"]["value"] == pytest.approx(res.parameters["chi_bar"]["value"],
                                                                    rel=1e-6)
    np.testing.assert_allclose(mirrored.model[:, 0], -model, atol=1e-7)


def test_load_deflection_at_several_fields_identifies_chi_bar_and_modulus():
    res = fit_config(CONFIGS / "fit_load_deflection.yaml", DATA / "synthetic_load_deflection.csv")
    assert res.success, res.message
    assert res.identifiable
    assert res.fitted_names == ["chi_bar", "youngs_modulus"]
    assert res.parameters["chi_bar"]["ci"][0] <= CHI <= res.parameters["chi_bar"]["ci"][1]
    assert res.parameters["youngs_modulus"]["ci"][0] <= E <= res.parameters["youngs_modulus"]["ci"][1]
    assert 0.7 * NOISE_MM < res.rms["tip_deflection"] < 1.3 * NOISE_MM
    assert res.correlation.shape == (2, 2) and abs(res.correlation[0, 1]) < 1.0
    # the model curves pass through the fitted points (the figures draw them)
    groups = res.curves["groups"]
    assert res.curves["x"] == "load" and len(groups) == 3


def test_tip_positions_at_several_field_angles():
    res = fit_config(CONFIGS / "fit_tip_position.yaml", DATA / "synthetic_tip_position.csv")
    assert res.success, res.message
    assert res.parameters["chi_bar"]["ci"][0] <= CHI <= res.parameters["chi_bar"]["ci"][1]
    assert res.parameters["clamp_angle"]["ci"][0] <= math.radians(2.0) <= \
        res.parameters["clamp_angle"]["ci"][1]
    # two columns without given uncertainties: each is weighted by its own scatter (≈ the noise)
    for col in ("tip_x", "tip_y"):
        assert 0.6 * NOISE_MM < res.rms[col] < 1.4 * NOISE_MM


def test_dimensionless_scene_fits_h_at_a_reference_field(tmp_path):
    cfg = {"name": "h from field data",
           "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
           "study": {"type": "fit", "parameters": {"h": {"initial": 0.7, "bounds": [0.01, 10]}},
                     "reference_field": "10 kA/m"}}
    res = fit_config(cfg, DATA / "synthetic_transverse_buckling.csv")
    assert res.success, res.message
    h_true = field_coefficient(CHI, E) * 1e4
    assert res.parameters["h"]["ci"][0] <= h_true <= res.parameters["h"]["ci"][1]


def test_sensitivities_agree_with_finite_differences():
    problem = prepare_fit(CONFIGS / "fit_load_deflection.yaml", DATA / "synthetic_load_deflection.csv")
    theta = np.array([0.45, 1.2e6])
    _, jac = problem.evaluate(theta, select=True)
    for k in range(theta.size):
        step = 1e-5 * theta[k]
        tp, tm = theta.copy(), theta.copy()
        tp[k] += step
        tm[k] -= step
        yp, _ = problem.evaluate(tp, jacobian=False)
        ym, _ = problem.evaluate(tm, jacobian=False)
        fd = (yp - ym) / (2 * step)
        scale = np.max(np.abs(jac[:, :, k]))
        assert scale > 0
        np.testing.assert_allclose(jac[:, :, k], fd, rtol=1e-5, atol=1e-7 * scale)


# -- fits that are not a clean success, and repeated conditions (issue 10 item 5) -----------------
def _identical_rows(tmp_path, n=40, field_kam=10.0, angle_deg=30.0):
    path = tmp_path / "identical.csv"
    path.write_text("field [kA/m], tip_angle [deg]\n" + f"{field_kam}, {angle_deg}\n" * n)
    return path


def test_identical_rows_cannot_determine_two_parameters(tmp_path, capsys):
    """40 copies of one condition and one measured value: J has one distinct row, so its rank is
    at most 1 and χ̄ and θ0 cannot both be determined — whatever the optimiser reaches."""
    data = _identical_rows(tmp_path)
    code = main(["fit", str(CONFIGS / "fit_transverse_buckling.yaml"), "--data", str(data),
                 "--json", "--progress"])
    out, err = capsys.readouterr()
    res = json.loads(out)  # exactly one JSON object on stdout, progress on stderr only
    assert code == 3
    assert not res["success"] and res["status"] == "not_identifiable", res["message"]
    assert "not identifiable" in res["message"] and "1 distinct measured condition" in res["message"]
    assert res["optimizer"]["conditions"] == 1
    assert "fit: evaluation" in err


def test_zero_sensitivity_fit_did_not_move_and_is_not_identifiable(tmp_path):
    """Below the transverse buckling field the straight rod is the only equilibrium for every χ̄
    (THEORY §6): the tip angle does not depend on χ̄ or E, so the fit cannot leave its start.
    At the initial χ̄ = 0.3, h = c·H with H = 10 kA/m is below h_crit (the check is the closed
    form, not the code)."""
    h = field_coefficient(0.3, E) * 1e4
    assert h < critical_field_transverse()
    res = fit_config(CONFIGS / "fit_transverse_buckling_unidentifiable.yaml",
                     _identical_rows(tmp_path))
    assert not res.success
    assert res.status == "not_identifiable"
    assert "did not move" in res.message and "do not determine" in res.message
    assert res.parameters["chi_bar"]["value"] == 0.3  # never left its initial value
    assert np.all(np.abs(res.model) < 1e-8)  # the straight rod


def _repeated_load_deflection(rng):
    """The load-deflection data with each condition repeated 1–4 times, the repeats scattered."""
    base = np.loadtxt(DATA / "synthetic_load_deflection.csv", delimiter=",", comments="#",
                      skiprows=5)
    counts = rng.integers(1, 5, size=len(base))
    rows = [(H, P, y + rng.normal(0.0, NOISE_MM)) for (H, P, y), c in zip(base, counts)
            for _ in range(c)]
    rows = [rows[i] for i in rng.permutation(len(rows))]  # repeats not adjacent
    return np.array(rows)


def test_repeated_conditions_solve_once_and_equal_the_weighted_mean_fit(tmp_path, monkeypatch):
    """Rows sharing a condition share one forward solve per evaluation; and since
    Σ_r (m − y_r)² = n (m − ȳ)² + Σ_r (y_r − ȳ)², the fit equals the fit of the condition means
    ȳ weighted by their counts n (the check builds those means itself)."""
    import yaml

    from actuator_design.calibration import FitProblem, MeasuredData, parse_data
    rows = _repeated_load_deflection(np.random.default_rng(7))
    cfg = yaml.safe_load((CONFIGS / "fit_load_deflection.yaml").read_text())
    # the repeats scatter about the file's already noisy values: a row is off the model by the
    # file's noise and its own (σ√2 = 0.071 mm), a mean of n rows by σ√(1 + 1/n) (n ≥ 1), so the
    # stated uncertainty covers both and each fit passes the χ² test (which is not what is tested)
    cfg["study"]["uncertainty"] = {"tip_deflection": "0.1 mm"}
    text = "field [kA/m], load [mN], tip_deflection [mm]\n" + "".join(
        f"{float(H)!r}, {float(P)!r}, {float(y)!r}\n" for H, P, y in rows)
    path = tmp_path / "repeated.csv"
    path.write_text(text)

    keys = {(H, P) for H, P, _ in rows}
    calls = {"evaluations": 0, "solves": 0}
    evaluate_conditions, solve_condition = FitProblem.evaluate_conditions, FitProblem.solve_condition

    def counting_evaluate(self, *args, **kwargs):
        calls["evaluations"] += 1
        return evaluate_conditions(self, *args, **kwargs)

    def counting_solve(self, *args, **kwargs):
        calls["solves"] += 1
        return solve_condition(self, *args, **kwargs)

    monkeypatch.setattr(FitProblem, "evaluate_conditions", counting_evaluate)
    monkeypatch.setattr(FitProblem, "solve_condition", counting_solve)
    repeated = fit_config(cfg, path)
    assert repeated.success, repeated.message
    assert len(rows) > len(keys)
    assert calls["solves"] == calls["evaluations"] * len(keys)
    assert repeated.optimizer["conditions"] == len(keys)

    # the condition means, weighted by their counts
    uniq = sorted(keys)
    means = [np.mean([y for H, P, y in rows if (H, P) == k]) for k in uniq]
    counts = [sum(1 for H, P, _ in rows if (H, P) == k) for k in uniq]
    d = parse_data("field [kA/m], load [mN], tip_deflection [mm]\n" + "".join(
        f"{float(H)!r}, {float(P)!r}, {float(y)!r}\n" for (H, P), y in zip(uniq, means)),
        source="means.csv")
    weighted = MeasuredData(d.columns, d.units, d.factors, d.lines, source=d.source,
                            weights=np.array(counts, float))
    mean_fit = fit_config(cfg, weighted)
    assert mean_fit.success, mean_fit.message
    for name in ("chi_bar", "youngs_modulus"):
        assert repeated.parameters[name]["value"] == pytest.approx(
            mean_fit.parameters[name]["value"], rel=1e-6)


def test_a_start_that_is_already_the_optimum_is_a_success(tmp_path):
    """The model is odd under the mirror θ → −θ (φ = 90°, THEORY §6): data symmetric about the
    straight rod are fitted best by θ0 = 0 exactly, the start; needing no step is not a failure."""
    import yaml
    cfg = yaml.safe_load((CONFIGS / "fit_transverse_buckling.yaml").read_text())
    cfg["study"]["parameters"] = {"clamp_angle": {"initial": "0 deg", "bounds": ["-5 deg", "5 deg"]}}
    # ±1° and ±1.5° at one field each: a scatter of 1.3° rms, which the stated σ must cover for
    # the fit to explain the data (at the config's 0.5° the χ² test rightly fails)
    cfg["study"]["uncertainty"] = {"tip_angle": "1.5 deg"}
    data = tmp_path / "symmetric.csv"
    data.write_text("field [kA/m], tip_angle [deg]\n5, 1\n5, -1\n8, 1.5\n8, -1.5\n")
    res = fit_config(cfg, data)
    assert res.success and res.status == "converged", res.message
    assert res.parameters["clamp_angle"]["value"] == pytest.approx(0.0, abs=1e-12)
    assert res.identifiable and 0 < res.parameters["clamp_angle"]["std"] < math.inf


# -- the branch of every row near the buckling threshold (seed 13) --------------------------------
def _transverse_data(tmp_path, seed):
    """A transverse-buckling data set as problems/make_synthetic_data.py makes it (THEORY §6's
    closed form on the downward branch, 41 fields 0–25 kA/m, σ = 0.5°), with its own noise seed."""
    rng = np.random.default_rng(seed)
    c, hc = field_coefficient(CHI, E), critical_field_transverse()
    H = np.linspace(0.0, 25e3, 41)
    angle = np.array([0.0 if c * h <= hc else -transverse_mode(c * h).beta for h in H])
    noisy = np.degrees(angle) + rng.normal(0.0, NOISE_DEG, H.size)
    path = tmp_path / f"transverse_seed{seed}.csv"
    path.write_text("field [kA/m], tip_angle [deg]\n" +
                    "".join(f"{h / 1e3:.3f}, {a:.3f}\n" for h, a in zip(H, noisy)))
    return path


@pytest.mark.parametrize("config", ["fit_transverse_buckling.yaml",
                                    "fit_transverse_buckling_unidentifiable.yaml"])
def test_every_row_is_on_the_measured_branch_by_shooting(tmp_path, config):
    """With noise seed 13 the row at 14.375 kA/m, just past the buckling field, ended on the
    upward branch (+6°, measured −7.4°; with χ̄ and E, the row at 16.875 kA/m at +18° with χ̄ =
    0.378 far from the true 0.5): a trial step of the optimiser that it rejected had moved that
    row's tracked equilibrium across, and the fit went on from there.

    The reference is the independent shooting solver of actuator_design.reference at the fitted
    parameters (h = c·H, θ0 as fitted), started on the downward branch the sample buckled onto
    (THEORY §6's closed form gives the start) or, below h_crit, from the straight rod; the Jacobi
    test (THEORY §7) confirms each reference equilibrium stable."""
    from actuator_design.reference.shooting import (ShootingParams, jacobi_morse_index,
                                                    solve_shooting)
    res = fit_config(CONFIGS / config, _transverse_data(tmp_path, 13))
    p = res.parameters
    theta0 = p["clamp_angle"]["value"] if "clamp_angle" in p else 0.0
    c = field_coefficient(p["chi_bar"]["value"], p["youngs_modulus"]["value"]
                          if "youngs_modulus" in p else E)
    hc = critical_field_transverse()
    buckled = 0
    for H, model in zip(res.data.columns["field"], res.model[:, 0]):
        h = c * H
        down = h > hc
        start = -math.sqrt(2.0) * h * math.sin(transverse_mode(h).beta) if down else 0.0
        ref = solve_shooting(ShootingParams(h=h, phi=math.pi / 2, theta0=theta0),
                             gamma_guess=start)
        assert ref.converged and jacobi_morse_index(ref).stable, H
        if down:
            assert ref.tip_angle < -0.1, H  # the reference is on the downward branch
            buckled += 1
        assert model == pytest.approx(ref.tip_angle, abs=1e-6), (H, model, ref.tip_angle)
    assert buckled >= 15
    assert res.success, res.message
    assert inside(p["chi_bar"], CHI), p["chi_bar"]
