"""Calibration of a hard-magnetic rod (THEORY §9): the remanence M_r as a fitted parameter.

The SYNTHETIC data set problems/data/synthetic_hard_magnetic.csv (problems/make_synthetic_data.py)
was generated with the independent shooting solver of actuator_design.reference (its remanent
torque h_r sin(θ + β − φ)) at h_r = μ0 M_r H A ℓ²/B, plus Gaussian noise with a fixed seed. The
tests check that

* the fit recovers the known M_r (and a zero clamp angle) inside its 95 % interval, with a residual
  scatter equal to the noise that was added, and that the fitted model is the shooting solution at
  the fitted h_r (a second method);
* M_r and E from field data alone are reported as not identifiable, with the combination M_r/E
  recovered (h_r ∝ M_r/E, as h² ∝ χ̄/E for the soft rod);
* the fit map sets h_r by THEORY §9 written out here — linear in M_r, in H (also through the field's
  measurement model) and in 1/B; χ̄ does not touch it — and its exact derivatives have the lens
  exponents; the sensitivities agree with central finite differences of re-solved equilibria;
* what cannot be fitted is refused with one line naming the field.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design.physics import parameters as lens
from actuator_design.calibration import FitSpec, fit_config, prepare_fit
from actuator_design.config import ConfigError
from actuator_design.reference.shooting import ShootingParams, solve_shooting
from actuator_design.config.studies.validation import validate_spec

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "problems" / "data" / "synthetic_hard_magnetic.csv"
CONFIGS = ROOT / "configs"
MU0 = 4e-7 * math.pi

# The known values the synthetic file was generated with (problems/make_synthetic_data.py).
M_R, E = 0.1 / MU0, 1.0e6
L, W, T = 20e-3, 5e-3, 1e-3
NOISE_DEG = 0.5


def remanent_coefficient(m_r, e):
    """h_r/H = μ0 M_r A ℓ²/(E I) (THEORY §9), m/A."""
    return MU0 * m_r * W * T * L**2 / (e * W * T**3 / 12.0)


def inside(ci, true):
    return ci[0] <= true <= ci[1]


@pytest.fixture(scope="module")
def remanence_fit():
    return fit_config(CONFIGS / "fit_hard_magnetic.yaml", DATA)


@pytest.fixture(scope="module")
def field_only_fit():
    return fit_config(CONFIGS / "fit_hard_magnetic_unidentifiable.yaml", DATA)


def test_fit_recovers_the_remanence_inside_its_interval(remanence_fit):
    res = remanence_fit
    assert res.success, res.message
    assert res.identifiable and not res.warnings
    p = res.parameters
    assert inside(p["remanence"]["ci"], M_R), p["remanence"]
    assert inside(p["clamp_angle"]["ci"], 0.0), p["clamp_angle"]
    lo, hi = p["remanence"]["ci"]
    assert (hi - lo) / M_R < 0.05  # informative, not vacuous
    assert p["remanence"]["unit"] == "A/m" and p["remanence"]["scale"] == "log"
    # the residual scatter is the noise that was added (0.5 deg), to sampling accuracy (21 points)
    assert 0.3 < res.rms["tip_angle"] < 0.7  # in the unit of the data column (deg)
    assert all(pt["stable"] and pt["converged"] for pt in res.points)
    # derived: the coefficient h_r/H contains the true one; no soft-magnetic coefficient
    assert inside(res.derived["h_r_per_field"]["ci"], remanent_coefficient(M_R, E))
    assert "h_per_field" not in res.derived and "transverse_critical_field" not in res.derived


def test_fitted_model_is_the_shooting_solution_at_the_fitted_h_r(remanence_fit):
    """A second method: the independent shooting solver at h_r = c_r H, θ0 as fitted."""
    res = remanence_fit
    p = res.parameters
    c_r = remanent_coefficient(p["remanence"]["value"], E)
    assert res.derived["h_r_per_field"]["value"] == pytest.approx(c_r, rel=1e-12)
    theta0 = p["clamp_angle"]["value"]
    gamma = 0.0
    for H, model in zip(res.data.columns["field"], res.model[:, 0]):
        ref = solve_shooting(ShootingParams(phi=math.pi / 2, h_r=c_r * H, theta0=theta0),
                             gamma_guess=gamma)
        assert ref.converged
        gamma = ref.gamma
        assert model == pytest.approx(ref.tip_angle, abs=1e-7)


def test_remanence_and_modulus_are_not_identifiable_from_field_data(field_only_fit):
    res = field_only_fit
    assert res.success, res.message
    assert not res.identifiable
    (w,) = res.warnings
    assert "remanence" in w and "youngs_modulus" in w and "not identifiable" in w
    assert "h_r ∝ M_r H/B" in w  # the group they share (THEORY §9)
    assert res.parameters["youngs_modulus"]["fitted"] is False
    assert res.parameters["youngs_modulus"]["value"] == 1e6  # held at its initial value
    (combo,) = res.combinations
    assert combo["name"] == "remanence * youngs_modulus^-1"  # h_r ∝ M_r/E: exponent −1, not −½
    assert inside(combo["ci"], M_R / E)
    assert inside(res.parameters["remanence"]["ci"], M_R)


# -- the fit map: THEORY §9 and the lens exponents ------------------------------------------------
def _combined_problem(tmp_path, kind="physical"):
    """A soft + hard rod with every rod and field parameter fitted (field and angle columns)."""
    data = tmp_path / "d.csv"
    data.write_text("field [kA/m], field_angle [deg], tip_angle [deg]\n" +
                    "".join(f"{H}, {a}, {0.1 * H + 0.01 * a}\n" for H in (2, 5, 8) for a in (30, 80)))
    config = {"scene": {"type": "physical",
                        "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                                "youngs_modulus": "1 MPa"},
                        "magnetics": {"chi_bar": 0.4, "remanence": "60 kA/m"},
                        "magnetization": "10 deg",
                        "field": {"type": "uniform", "magnitude": "5 kA/m", "angle": "30 deg"},
                        "fibres": "0 deg"},
              "study": {"type": "fit", "parameters": {
                  "chi_bar": {"bounds": [0.01, 5]}, "remanence": {"bounds": ["1 kA/m", "1 MA/m"]},
                  "youngs_modulus": {"bounds": ["0.1 MPa", "10 MPa"]},
                  "field_scale": {"bounds": [0.5, 2]},
                  "field_offset": {"bounds": ["-1 kA/m", "1 kA/m"]}}}}
    return prepare_fit(config, data)


def test_fit_map_sets_h_r_by_theory_9_with_the_lens_exponents(tmp_path):
    prob = _combined_problem(tmp_path)
    assert prob.names == ["chi_bar", "remanence", "youngs_modulus", "field_scale", "field_offset"]
    th = np.array([0.7, 9e4, 2.5e6, 1.3, 200.0])
    H = 6e3
    q, dq = (np.asarray(v, float) for v in prob.f_map(th, np.array([H, 0.5, 0.0, 0.0])))
    q = q.ravel()
    slot = {s: i for i, s in enumerate(prob.slots)}
    B = th[2] * W * T**3 / 12.0
    H_eff = th[3] * H + th[4]
    h_r = MU0 * th[1] * H_eff * W * T * L**2 / B
    assert q[slot["h_r"]] == pytest.approx(h_r, rel=1e-12)
    assert q[slot["h"]] == pytest.approx(math.sqrt(MU0 * th[0] * H_eff**2 * W * T * L**2 / (2 * B)),
                                         rel=1e-12)
    j = slot["h_r"]
    # d ln h_r / d ln p: M_r 1, E −1, field_scale (through H) s H/H_eff; χ̄ 0
    expected = {"chi_bar": 0.0, "remanence": 1.0, "youngs_modulus": -1.0,
                "field_scale": th[3] * H / H_eff}
    for i, name in enumerate(prob.names[:4]):
        assert th[i] * dq[j, i] / q[j] == pytest.approx(expected[name], abs=1e-12), name
        if name != "field_scale":  # the lens says the same (field_scale: exact for zero offset)
            assert lens.physical_parameter(name).exponent("h_r") == expected[name]
    assert dq[j, 4] == pytest.approx(q[j] / H_eff, rel=1e-12)  # linear in the field offset
    # doubling the field doubles h_r and h (both ∝ H): h² quadruples, h_r only doubles
    q2 = np.asarray(prob.f_map(th, np.array([2 * H + th[4] / th[3], 0.5, 0, 0]))[0]).ravel()
    assert q2[j] == pytest.approx(2 * q[j], rel=1e-12)
    assert q2[slot["h"]] ** 2 == pytest.approx(4 * q[slot["h"]] ** 2, rel=1e-12)


def test_fit_map_from_a_scene_with_zero_material_numbers(tmp_path):
    """χ̄ = 0 and M_r = 0 in the scene, both fitted from given starting values, with B0 fitted too:
    the map's h and h_r are THEORY §5 and §9 written out here at the fitted values (the material's
    coefficients come at unit values, not as ratios to the scene's zeros)."""
    data = tmp_path / "d.csv"
    data.write_text("field [kA/m], tip_angle [deg]\n" + "".join(f"{H}, {0.1 * H}\n" for H in (2, 4, 6, 8)))
    B0 = 1e6 * W * T**3 / 12.0
    config = {"scene": {"type": "physical",
                        "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                                "bending_stiffness": f"{B0} N m^2"},
                        "magnetics": {"chi_bar": 0.0, "remanence": "0 A/m"}, "magnetization": "0 deg",
                        "field": {"type": "uniform", "magnitude": "5 kA/m", "angle": "90 deg"}},
              "study": {"type": "fit", "parameters": {
                  "chi_bar": {"initial": 0.3, "bounds": [0.01, 5]},
                  "remanence": {"initial": "20 kA/m", "bounds": ["1 kA/m", "1 MA/m"]},
                  "bending_stiffness": {"bounds": [B0 / 10, B0 * 10]}}}}
    prob = prepare_fit(config, data)
    th, H = np.array([0.7, 9e4, 2.5 * B0]), 6e3
    q = np.asarray(prob.f_map(th, np.array([H, 0.0, 0.0, 0.0]))[0], float).ravel()
    slot = {s: i for i, s in enumerate(prob.slots)}
    assert q[slot["h_r"]] == pytest.approx(MU0 * th[1] * H * W * T * L**2 / th[2], rel=1e-12)
    assert q[slot["h"]] == pytest.approx(math.sqrt(MU0 * th[0] * H**2 * W * T * L**2 / (2 * th[2])), rel=1e-12)


@pytest.mark.parametrize("axis_ratio", [1.0, 3.0])
def test_fit_map_at_the_starting_values_is_the_scenes_own_groups(tmp_path, axis_ratio):
    """A rod given by its particles, whose χ̄ includes the body's demagnetisation (THEORY §10; for
    spheres χ̄ comes from the body alone): at the starting values and the scene's field the fit map
    gives the h the scene itself has (before, it took the particles' χ̄ and gave spheres no h)."""
    data = tmp_path / "d.csv"
    data.write_text("field [kA/m], tip_angle [deg]\n" + "".join(f"{H}, {0.1 * H}\n" for H in (2, 4, 6, 8)))
    config = {"scene": {"type": "physical", "fibres": "0 deg",
                        "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm", "youngs_modulus": "1 MPa"},
                        "magnetics": {"particles": {"material": "carbonyl_iron", "axis_ratio": axis_ratio,
                                                    "volume_fraction": 0.1}},
                        "field": {"type": "uniform", "magnitude": "5 kA/m", "angle": "90 deg"}},
              "study": {"type": "fit", "parameters": {"chi_bar": {"bounds": [1e-4, 5]},
                                                      "youngs_modulus": {"bounds": ["0.1 MPa", "10 MPa"]}}}}
    prob = prepare_fit(config, data)
    th = np.array([prob.initial[n] for n in prob.names])
    q = np.asarray(prob.f_map(th, np.array([5e3, 0.0, 0.0, 0.0]))[0], float).ravel()
    assert prob.scene.h > 0
    assert q[prob.slots.index("h")] == pytest.approx(prob.scene.h, rel=1e-12)


def test_dimensionless_hard_scene_scales_h_r_with_the_measured_field(tmp_path):
    """A dimensionless scene's h_r is the group at reference_field: h_r(H) = h_r · H/H_ref."""
    data = tmp_path / "d.csv"
    data.write_text("field [kA/m], tip_angle [deg]\n" + "".join(f"{H}, {H}\n" for H in (2, 5, 8)))
    config = {"scene": {"type": "dimensionless", "h": 0.5, "h_r": 1.5, "phi": "90 deg"},
              "study": {"type": "fit", "reference_field": "10 kA/m",
                        "parameters": {"h": {"bounds": [0.01, 5]}}}}
    prob = prepare_fit(config, data)
    q = np.asarray(prob.f_map(np.array([0.8]), np.array([4e3, 0, 0, 0]))[0]).ravel()
    slot = {s: i for i, s in enumerate(prob.slots)}
    assert q[slot["h_r"]] == pytest.approx(1.5 * 0.4, rel=1e-14)
    assert q[slot["h"]] == pytest.approx(0.8 * 0.4, rel=1e-14)


def test_sensitivities_agree_with_finite_differences():
    problem = prepare_fit(CONFIGS / "fit_hard_magnetic.yaml", DATA)
    theta = np.array([7e4, 0.01])  # remanence, clamp angle
    _, jac = problem.evaluate(theta, select=True)
    for k in range(theta.size):
        step = 1e-5 * max(abs(theta[k]), 1e-2)
        tp, tm = theta.copy(), theta.copy()
        tp[k] += step
        tm[k] -= step
        yp, _ = problem.evaluate(tp, jacobian=False)
        ym, _ = problem.evaluate(tm, jacobian=False)
        fd = (yp - ym) / (2 * step)
        scale = np.max(np.abs(jac[:, :, k]))
        assert scale > 0
        np.testing.assert_allclose(jac[:, :, k], fd, rtol=1e-5, atol=1e-7 * scale)


# -- what cannot be fitted --------------------------------------------------------------------------
def test_remanence_needs_a_remanent_scene():
    cfg = {"scene": {"type": "physical",
                     "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                             "youngs_modulus": "1 MPa"},
                     "magnetics": {"chi_bar": 0.3},
                     "field": {"type": "uniform", "magnitude": "10 kA/m", "angle": "90 deg"}},
           "study": {"type": "fit", "parameters": {"remanence": {"initial": "50 kA/m"}}}}
    with pytest.raises(ConfigError, match=r"study\.parameters\.remanence: the scene has no remanent "
                                          r"magnetisation"):
        prepare_fit(cfg, DATA)
    dimless = {"scene": {"type": "dimensionless", "h_r": 1.0, "phi": "90 deg"},
               "study": {"type": "fit", "parameters": {"remanence": {"initial": "50 kA/m"}}}}
    with pytest.raises(ConfigError, match=r"study\.parameters\.remanence: cannot be fitted in a "
                                          r"dimensionless scene"):
        prepare_fit(dimless, ROOT / "problems" / "data" / "synthetic_transverse_buckling.csv")


def test_remanence_spec_is_checked_with_its_unit():
    with pytest.raises(ConfigError, match=r"study\.parameters\.remanence\.bounds: remanence is "
                                          r"positive: its lower bound must be > 0"):
        validate_spec(FitSpec, {"type": "fit", "parameters": {"remanence": {"bounds": [0, "1 MA/m"]}}})
    spec = validate_spec(FitSpec, {"type": "fit", "parameters": {
        "remanence": {"initial": "0.1 T", "bounds": ["10 mT", "1 T"]}}})
    lo, hi = spec.bounds_of("remanence")  # a flux density is read as μ0 M_r
    assert lo == pytest.approx(0.01 / MU0, rel=1e-12) and hi == pytest.approx(1.0 / MU0, rel=1e-12)


def test_a_term_the_fit_map_does_not_know_is_refused(monkeypatch):
    """A plug-in term's values would be held fixed while the field and E change: refused."""
    from actuator_design.calibration import solve as fit_solve
    from actuator_design.physics.parameters import plugin_parameter
    from actuator_design.physics.registry import register_term, unregister_term
    from actuator_design.physics.terms import EnergyTerm

    name = "toy_fit_spring"

    @register_term(replace=True)
    class Spring(EnergyTerm):
        name = "toy_fit_spring"
        scalar_params = ("k_fit",)
        parameters = (plugin_parameter("toy_fit_spring", "k_fit", "spring", "B0/l^2"),)

        def density(self, kin, P):
            return 0.5 * P["k_fit"] * kin.theta ** 2

    try:
        real = fit_solve.load_config

        def with_spring(source):
            config = real(source)
            scene = config.to_scene().with_term(name, k_fit=1.0)
            monkeypatch.setattr(type(config), "to_scene", lambda self, *a, **k: scene)
            return config

        monkeypatch.setattr(fit_solve, "load_config", with_spring)
        with pytest.raises(ValueError, match=r"fit: the scene contains the energy term "
                                             r"'toy_fit_spring', which this analysis does not support"):
            prepare_fit(CONFIGS / "fit_hard_magnetic.yaml", DATA)
    finally:
        unregister_term(name)


def test_cli_fit_of_the_remanence_writes_its_output_set(tmp_path, capsys):
    import json

    from actuator_design.cli.main import main

    out = tmp_path / "out"
    code = main(["fit", str(CONFIGS / "fit_hard_magnetic.yaml"), "--data", str(DATA), "--json",
                 "--out", str(out)])
    res = json.loads(capsys.readouterr().out)
    assert code == 0 and res["success"]
    assert inside(res["parameters"]["remanence"]["ci"], M_R)
    for name in ("fit.json", "fit_points.csv", "fit_data_vs_model.png", "fit_residuals.png"):
        assert (out / name).stat().st_size > 0


def test_soft_and_hard_coupling_are_separated_by_field_angle_data(tmp_path):
    """A combined rod: h² sin 2(θ−φ) and h_r sin(θ−φ) differ in their dependence on H and on φ, so
    χ̄ and M_r are both identifiable from tip angles at several fields and angles. Noise-free data
    from the shooting solver (an independent method) are recovered to solver accuracy."""
    chi, m_r = 0.4, 3.0e4
    c = math.sqrt(MU0 * chi * W * T * L**2 / (2.0 * E * W * T**3 / 12.0))
    c_r = remanent_coefficient(m_r, E)
    rows = []
    for phi_deg in (45.0, 120.0):
        gamma = 0.0
        for H in np.linspace(2e3, 8e3, 5):
            ref = solve_shooting(ShootingParams(h=c * H, h_r=c_r * H, phi=math.radians(phi_deg)),
                                 gamma_guess=gamma)
            assert ref.converged
            gamma = ref.gamma
            rows.append(f"{H:.6f}, {phi_deg}, {ref.tip_angle:.15e}")
    data = tmp_path / "combined.csv"
    data.write_text("field [A/m], field_angle [deg], tip_angle [rad]\n" + "\n".join(rows) + "\n")
    config = {"scene": {"type": "physical",
                        "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                                "youngs_modulus": "1 MPa"},
                        "magnetics": {"chi_bar": 0.2, "remanence": "50 kA/m"},
                        "magnetization": "0 deg", "fibres": "0 deg",
                        "field": {"type": "uniform", "magnitude": "5 kA/m", "angle": "45 deg"}},
              "study": {"type": "fit", "parameters": {
                  "chi_bar": {"bounds": [0.01, 5]}, "remanence": {"bounds": ["1 kA/m", "1 MA/m"]}}}}
    cfg = tmp_path / "combined.yaml"
    import yaml
    cfg.write_text(yaml.safe_dump(config))
    res = fit_config(cfg, data)
    assert res.success and res.identifiable and not res.combinations, res.message
    assert res.parameters["chi_bar"]["value"] == pytest.approx(chi, rel=1e-6)
    assert res.parameters["remanence"]["value"] == pytest.approx(m_r, rel=1e-6)
