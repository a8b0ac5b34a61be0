"""Input consistency: studies checked before any work, physical units on dimensionless scenes,
plausible magnetic material values, rejected angles echoed in the unit they were given in.

Every refusal is checked the same way (README "Valid ranges"): exit 2, nothing on stdout, one line
on stderr naming the field and its allowed range, nothing written. The ranges are independent
references: [0, 1e4] for h (THEORY §5), 3e6 A/m = 1.5 × the saturation of Fe65Co35
(μ0 M_s ≈ 2.45 T) for magnetisations, ±1e6 deg for angles.
"""
import contextlib
import copy
import io
import json
import math

import pytest
import yaml

from actuator_design.cli.main import main
from cli_checks import assert_rejected
from actuator_design.config import ConfigError, load_config
from actuator_design.physics.magnetic_composite import MATERIALS

PHYSICAL = {
    "name": "checks",
    "scene": {"type": "physical",
              "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm",
                      "youngs_modulus": "1 MPa"},
              "magnetics": {"chi_bar": 0.5},
              "field": {"type": "uniform", "magnitude": "10 kA/m", "angle": "90 deg"}},
    "solver": {"elements": 4, "degree": 6},
    "study": {"type": "sweep", "sweep": {}, "analyses": ["solve"]},
}
DIMENSIONLESS = {
    "name": "checks",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg"},
    "solver": {"elements": 4, "degree": 6},
    "study": {"type": "sweep", "sweep": {}, "analyses": ["solve"]},
}
HARD = {"scene": {"type": "physical",
                  "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                          "youngs_modulus": "1 MPa"},
                  "magnetics": {"remanence": "50 kA/m"}, "magnetization": "0 deg",
                  "field": {"type": "uniform", "magnitude": "10 mT", "angle": "90 deg"}}}


def run(tmp_path, *argv, config=None, out=True):
    """``main([...])`` in-process: (exit code, stdout, stderr); CONFIG written from ``config``."""
    args = [str(a) for a in argv]
    if config is not None:
        path = tmp_path / "config.yaml"
        path.write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")
        args.insert(1, str(path))
    if out:
        args += ["--out", str(tmp_path / "out")]
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        code = main(args)
    return code, o.getvalue(), e.getvalue()


refused = assert_rejected


def study(base, sweep, grid="cartesian"):
    cfg = copy.deepcopy(base)
    cfg["study"]["sweep"] = sweep
    cfg["study"]["grid"] = grid
    return cfg


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a study starts running (a refusal must come before any work)."""
    import actuator_design.study.runner as runner

    def forbidden(*args, **kwargs):
        raise AssertionError("the study ran although its input is invalid")
    monkeypatch.setattr(runner, "run_study", forbidden)


# -- 1: a study value out of range is exit 2 before the folder exists ------------------------------
@pytest.mark.parametrize("base, sweep, names", [
    (PHYSICAL, {"rod.length": ["20 mm", "-5 mm"]},
     ["study.sweep.rod.length", "scene.rod.length: must be > 0", "-5.0 mm"]),
    (PHYSICAL, {"field.magnitude": {"from": "-10 kA/m", "to": "10 kA/m", "n": 3}},
     ["study.sweep.field.magnitude", "scene.field.magnitude: must be >= 0"]),
    (PHYSICAL, {"rod.youngs_modulus": ["1 MPa", "0 MPa"]},
     ["study.sweep.rod.youngs_modulus", "scene.rod.youngs_modulus: must be > 0"]),
    (PHYSICAL, {"fibres": ["0 deg", "2e6 deg"]},
     ["study.sweep.fibres", "[-1e+06, 1e+06] deg", "got 2e+06 deg"]),
    (DIMENSIONLESS, {"h": [1.0, 2e4]}, ["study.sweep.h", "scene.h", "[0, 10000]", "20000"]),
    (DIMENSIONLESS, {"phi": ["30 deg", "-3e6 deg"]}, ["study.sweep.phi", "[-1e+06, 1e+06] deg"]),
])
def test_out_of_range_study_values_are_refused_before_any_work(tmp_path, no_work, base, sweep,
                                                               names):
    refused(run(tmp_path, "study", config=study(base, sweep)), tmp_path, *names)


def test_a_combination_out_of_range_is_refused_naming_the_point(tmp_path, no_work):
    """Each value alone is valid; only ℓ = 10 m with H = 1 MA/m gives h ∝ ℓ H out of [0, 1e4]:
    h = 0.7767 at (20 mm, 10 kA/m) (THEORY §5), so 0.7767 × 500 × 100 ≈ 3.9e4."""
    cfg = study(PHYSICAL, {"rod.length": ["20 mm", "10 m"], "field.magnitude": ["1 A/m", "1 MA/m"]})
    line = refused(run(tmp_path, "study", config=cfg), tmp_path, "study.sweep:", "grid point 4 of 4",
                   "scene.h: derived h", "[0, 10000]")
    h = 0.7766503650222797 * (10 / 0.02) * (1e6 / 1e4)
    assert f"derived h = {h:g}" in line


def test_zipped_points_are_checked_as_zipped(tmp_path, no_work):
    cfg = study(PHYSICAL, {"rod.length": ["20 mm", "30 mm"], "field.angle": ["0 deg", "2e6 deg"]},
                grid="zip")
    refused(run(tmp_path, "study", config=cfg), tmp_path, "study.sweep.field.angle",
            "grid point 2 of 2", "[-1e+06, 1e+06] deg")


def test_a_large_grid_is_checked_at_its_corners_and_values(tmp_path, monkeypatch):
    """README: a grid above the full-check size is checked at its corners and at a point through
    each value; an invalid point between them (a dipole on the rod, 0 <= x <= 1 at y = 0) is then
    recorded as ``invalid`` while the others are solved."""
    import actuator_design.study.check as check
    from actuator_design.study.runner import run_study

    cfg = study(DIMENSIONLESS, {"field.position.x": [-1.0, 0.5, 2.0]})
    cfg["scene"] = {"type": "dimensionless", "h": 0.5,
                    "field": {"type": "dipole", "position": {"x": -1.0, "y": 0.0}}}
    with pytest.raises(ConfigError, match="dipole lies on the undeformed rod"):
        run_study(cfg, tmp_path / "full", workers=1, progress=False)
    assert not (tmp_path / "full").exists()
    monkeypatch.setattr(check, "FULL_CHECK_POINTS", 2)
    report = run_study(cfg, tmp_path / "large", workers=1, progress=False)
    assert report.counts["invalid"] == 1 and report.counts["ok"] == 2
    points = json.loads((tmp_path / "large" / "manifest.json").read_text())["points"]
    assert points[1]["status"] == "invalid" and "dipole" in points[1]["message"]


def test_a_valid_study_still_runs(tmp_path):
    cfg = study(DIMENSIONLESS, {"h": [0.5, 1.0]})
    code, out, err = run(tmp_path, "study", "--workers", 1, "--no-progress", config=cfg)
    assert code == 0, err
    assert (tmp_path / "out" / "results.csv").is_file()


# -- 2: physical units need a physical scene ------------------------------------------------------
def test_a_field_in_ka_per_m_on_a_dimensionless_study_is_refused(tmp_path, no_work):
    cfg = study(DIMENSIONLESS, {"h": ["1 kA/m", "2 kA/m"]})
    refused(run(tmp_path, "study", config=cfg), tmp_path, "study.sweep.h", "kA/m",
            "physical units need a physical scene", "plain number")


@pytest.mark.parametrize("scene, field", [
    ({"h": "1 kA/m"}, "scene.h"),
    ({"h": 1.0, "tip_force": {"x": 0, "y": "2 mN"}}, "scene.tip_force.y"),
    ({"h": 1.0, "field": {"type": "dipole", "position": {"x": "30 mm", "y": 0.5}}},
     "scene.field.position.x"),
])
def test_physical_units_in_a_dimensionless_scene_are_refused(tmp_path, scene, field):
    cfg = {"scene": {"type": "dimensionless", **scene}}
    refused(run(tmp_path, "solve", config=cfg), tmp_path, field,
            "physical units need a physical scene")


def test_angles_keep_their_units_on_a_dimensionless_scene():
    cfg = {"scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "fibres": "10 deg"}}
    assert load_config(cfg).to_scene().phi == pytest.approx(math.pi / 2)


# -- 3: magnetic material values within physical plausibility ------------------------------------
@pytest.mark.parametrize("magnetics, field, interval", [
    ({"remanence": "1e12 A/m"}, "scene.magnetics.remanence", "[0, 3e+06] A/m"),
    ({"remanent_flux_density": "10 T"}, "scene.magnetics.remanent_flux_density", "[0, 3.77] T"),
    ({"remanent_flux_density": 5}, "scene.magnetics.remanent_flux_density", "[0, 3.77] T"),
])
def test_implausible_remanence_is_exit_2_not_a_solver_failure(tmp_path, magnetics, field, interval):
    cfg = copy.deepcopy(HARD)
    cfg["scene"]["magnetics"] = magnetics
    refused(run(tmp_path, "solve", config=cfg), tmp_path, field, interval)


@pytest.mark.parametrize("magnetics, field, interval", [
    ({"chi_bar": 1e7}, "scene.magnetics.chi_bar", "[0, 1e+06]"),
    ({"chi_bar": 0.5, "chi_hat": 2e6}, "scene.magnetics.chi_hat", "[0, 1e+06]"),
    ({"particles": {"chi_par": 1e9, "chi_perp": 1, "volume_fraction": 0.1}},
     "scene.magnetics.particles.chi_par", "(0, 1e+06]"),
    ({"particles": {"material": "carbonyl_iron", "volume_fraction": 0.1,
                    "saturation_magnetization": "1e9 A/m"}},
     "scene.magnetics.particles.saturation_magnetization", "(0, 3e+06] A/m"),
    ({"particles": {"material": "carbonyl_iron", "volume_fraction": 0.1,
                    "saturation_field": "5 MA/m"}},
     "scene.magnetics.particles.saturation_field", "(0, 3e+06] A/m"),
])
def test_implausible_soft_magnetic_values_are_refused(tmp_path, magnetics, field, interval):
    cfg = copy.deepcopy(PHYSICAL)
    del cfg["study"]
    cfg["scene"]["magnetics"] = magnetics
    refused(run(tmp_path, "solve", config=cfg), tmp_path, field, interval)


def test_a_swept_remanence_is_checked_too(tmp_path, no_work):
    cfg = {**copy.deepcopy(HARD),
           "study": {"type": "sweep", "sweep": {"magnetics.remanence": ["50 kA/m", "1e12 A/m"]},
                     "analyses": ["solve"]}}
    refused(run(tmp_path, "study", config=cfg), tmp_path, "study.sweep.magnetics.remanence",
            "[0, 3e+06] A/m")


def test_real_magnets_and_the_presets_are_accepted():
    """The strongest permanent magnet (NdFeB, B_r ≈ 1.4 T) and every preset pass."""
    cfg = copy.deepcopy(HARD)
    cfg["scene"]["magnetics"] = {"remanent_flux_density": "1.4 T"}
    assert load_config(cfg).scene.magnetics.remanent_magnetization == pytest.approx(
        1.4 / (4e-7 * math.pi))
    del cfg["scene"]["magnetization"]
    for name, m in MATERIALS.items():
        assert 0 < m.saturation_magnetization <= 3e6 and m.susceptibility <= 1e6, name
        assert m.remanence is None or 0 < m.remanence <= 3e6, name
        cfg["scene"]["magnetics"] = {"particles": {"material": name, "volume_fraction": 0.1}}
        load_config(cfg)


# -- 4: a rejected angle is echoed in the unit it was given in -------------------------------------
@pytest.mark.parametrize("argv, names", [
    (["solve", "--phi-deg", "1e7"], ["--phi-deg", "[-1e+06, 1e+06] deg", "got 1e+07 deg"]),
    (["equilibria", "--alpha-deg", "-2e6"], ["--alpha-deg", "[-1e+06, 1e+06] deg"]),
    (["path", "--param", "phi_deg", "--from", "0", "--to", "1e8"],
     ["--to", "[-1e+06, 1e+06] deg", "got 1e+08 deg"]),
    (["path", "--param", "phi", "--from", "0", "--to", "1e8 deg"],
     ["--to", "[-1e+06, 1e+06] deg", "got 1e+08 deg"]),
    (["critical", "--param", "alpha", "--window", "0 deg,1e9 deg"],
     ["--window", "[-1e+06, 1e+06] deg", "got 1e+09 deg"]),
    (["continue", "--param", "phi", "--from", "10 deg", "--to", "10 deg"],
     ["--from and --to must differ", "10 deg"]),
])
def test_angles_given_in_degrees_are_echoed_in_degrees(tmp_path, argv, names):
    refused(run(tmp_path, *argv), tmp_path, *names, absent=["rad", "0.174533", "17453"])


def test_angles_given_in_radians_are_echoed_in_radians(tmp_path):
    line = refused(run(tmp_path, "path", "--param", "phi", "--from", "0", "--to", "1e5"), tmp_path,
                   "--to", "rad", "got 100000 rad")
    assert f"{math.radians(1e6):g}" in line  # the same bound, 1e6 deg, in rad


@pytest.mark.parametrize("scene, names", [
    ({"h": 1.0, "phi": "1e9 deg"}, ["scene.phi", "[-1e+06, 1e+06] deg", "got 1e+09 deg"]),
    ({"h": 1.0, "fibres": {"type": "table", "s": [0, 1], "values_deg": [10, 2e6]}},
     ["scene.fibres.values_deg[1]", "[-1e+06, 1e+06] deg", "got 2e+06 deg"]),
])
def test_yaml_angles_in_degrees_are_echoed_in_degrees(tmp_path, scene, names):
    cfg = {"scene": {"type": "dimensionless", **scene}}
    refused(run(tmp_path, "validate", config=cfg, out=False), tmp_path, *names, absent=["rad"])


@pytest.mark.parametrize("section, names", [
    ({"type": "equilibria", "phi_deg": 2e6}, ["study.phi_deg", "[-1e+06, 1e+06] deg"]),
    ({"type": "path", "schedule": [{"h": 0, "phi_deg": 60}, {"h": 1.5, "phi_deg": 2e6}]},
     ["study.schedule[1].phi_deg", "[-1e+06, 1e+06] deg"]),
])
def test_study_section_angles_in_degrees_are_echoed_in_degrees(tmp_path, section, names):
    cfg = {"scene": {"type": "dimensionless", "h": 1.0, "phi": "0 deg"}, "study": section}
    command = section["type"]
    refused(run(tmp_path, command, config=cfg), tmp_path, *names, absent=["rad"])
