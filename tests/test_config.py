"""Configuration layer: YAML/dict → validated models → dimensionless Scene (THEORY §5)."""
import copy
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from actuator_design.config import ConfigError, load_config, load_scene
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import DipoleField, ExpressionField, Scene, UniformField
from actuator_design.model.units import QuantityError, parse_quantity

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.yaml"))
MU0 = 4e-7 * math.pi  # written out here on purpose (independent of actuator_design.model.units)


def physical(**overrides):
    """A simple physical config; ``overrides`` are dotted paths below ``scene``."""
    scene = {
        "type": "physical",
        "rod": {"length": "0.1 m", "width": "10 mm", "thickness": "1 mm", "youngs_modulus": "1 MPa"},
        "magnetics": {"chi_bar": 0.5, "chi_hat": 0.2},
        "field": {"type": "uniform", "magnitude": "10 kA/m", "angle": "90 deg"},
        "loads": {"tip_force": {"x": 0, "y": "1 mN"}},
    }
    for path, value in overrides.items():
        node = scene
        *parents, last = path.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        if value is None:
            del node[last]
        else:
            node[last] = value
    return {"scene": scene}


def dimensionless(**keys):
    return {"scene": {"type": "dimensionless", **keys}}


def error_of(config) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(config)
    message = str(info.value)
    assert "\n" not in message
    return message


# -- every invalid field is named ---------------------------------------------------------------
@pytest.mark.parametrize("config, field", [
    (physical(**{"rod.length": "-1 mm"}), "scene.rod.length: must be > 0, got -1 mm"),
    (physical(**{"rod.length": -1}), "scene.rod.length: must be > 0"),
    (physical(**{"rod.width": 0}), "scene.rod.width: must be > 0"),
    (physical(**{"rod.youngs_modulus": "-2 MPa"}), "scene.rod.youngs_modulus: must be > 0"),
    (physical(**{"field.magnitude": "-5 kA/m"}), "scene.field.magnitude: must be >= 0"),
])
def test_out_of_range_values_are_named(config, field):
    assert error_of(config).startswith(field)


@pytest.mark.parametrize("config, field", [
    (physical(**{"rod.length": float("nan")}), "scene.rod.length"),
    (physical(**{"rod.length": "nan mm"}), "scene.rod.length"),
    (physical(**{"field.magnitude": float("inf")}), "scene.field.magnitude"),
    (physical(**{"loads.tip_force.y": "inf N"}), "scene.loads.tip_force.y"),
    (dimensionless(h=float("nan")), "scene.h"),
    (dimensionless(fibres={"type": "table", "s": [0, 0.5, 1], "values": [0, float("nan"), 0]}),
     "scene.fibres.values[1]"),
    ({"scene": {"type": "dimensionless"}, "solver": {"tol": float("nan")}}, "solver.tol"),
])
def test_nan_and_inf_are_named(config, field):
    message = error_of(config)
    assert message.startswith(field + ":")
    assert "finite" in message


@pytest.mark.parametrize("config, field", [
    ({**physical(), "scenery": 1}, "scenery"),
    (physical(**{"rod.lenght": "1 mm"}), "scene.rod.lenght"),
    (physical(**{"magnetics.particles_": {}}), "scene.magnetics.particles_"),
    (physical(**{"field.strength": "1 kA/m"}), "scene.field.strength"),
    (dimensionless(fibres={"type": "expression", "expr": "s"}), "scene.fibres.expr"),
    ({**dimensionless(), "solver": {"degre": 4}}, "solver.degre"),
])
def test_unknown_keys_are_named_with_the_allowed_ones(config, field):
    message = error_of(config)
    assert message.startswith(f"{field}: unknown key (allowed: ")


def test_unknown_key_message_lists_allowed_keys():
    message = error_of(physical(**{"rod.lenght": "1 mm"}))
    assert "length, width, thickness" in message and "did you mean 'length'" in message


@pytest.mark.parametrize("config, field, got", [
    (physical(**{"rod.length": "5 kA/m"}), "scene.rod.length", "'5 kA/m' [ampere / meter]"),
    (physical(**{"field.magnitude": "3 mm"}), "scene.field.magnitude", "'3 mm' [meter]"),
    (physical(**{"rod.youngs_modulus": "2 N"}), "scene.rod.youngs_modulus", "'2 N'"),
    (physical(**{"field.angle": "2 mm"}), "scene.field.angle", "'2 mm'"),
])
def test_wrong_dimension_is_named(config, field, got):
    message = error_of(config)
    assert message.startswith(f"{field}: expected ")
    assert got in message


def test_wrong_dimension_message_format():
    with pytest.raises(QuantityError) as info:
        parse_quantity("5 kA/m", "length", "rod.length")
    assert str(info.value) == "rod.length: expected a length (e.g. '27.5 mm'), got '5 kA/m' [ampere / meter]"


@pytest.mark.parametrize("config, field", [
    (dimensionless(phi=90), "scene.phi"),
    (physical(**{"field.angle": 90}), "scene.field.angle"),
    (dimensionless(fibres=45), "scene.fibres.value"),
    (dimensionless(clamp_angle=-30), "scene.clamp_angle"),
])
def test_angle_as_plain_degrees_is_rejected(config, field):
    message = error_of(config)
    assert message.startswith(field + ":")
    assert "looks like degrees" in message and "deg'" in message


def test_angle_message_suggests_the_unit():
    assert error_of(dimensionless(phi=90)) == (
        "scene.phi: phi = 90 looks like degrees: write '90 deg' or radians within [-2π, 2π]")


@pytest.mark.parametrize("table, field", [
    ({"s": [0, 0.6, 0.5, 1], "values": [0, 0, 0, 0]}, "scene.fibres.s"),
    ({"s": [0, 0.5, 0.5, 1], "values": [0, 0, 0, 0]}, "scene.fibres.s"),
    ({"s": [0.1, 1], "values": [0, 0]}, "scene.fibres.s"),
    ({"s": [0, 0.9], "values": [0, 0]}, "scene.fibres.s"),
    ({"s": [0], "values": [0]}, "scene.fibres.s"),
    ({"s": [0, 0.5, 1], "values": [0, 0]}, "scene.fibres.values"),
    ({"s": [0, 1], "values_deg": [0, 10, 20]}, "scene.fibres.values_deg"),
    ({"s": [0, 1]}, "scene.fibres.values"),
])
def test_bad_tables_are_named(table, field):
    assert error_of(dimensionless(fibres={"type": "table", **table})).startswith(field + ":")


def test_non_positive_stiffness_table_is_named():
    config = dimensionless(stiffness={"type": "table", "s": [0, 1], "values": [1, -0.5]})
    assert error_of(config).startswith("scene.stiffness.values[1]: must be > 0")


@pytest.mark.parametrize("expression", ["__import__('os')", "s.__class__", "open('x')", "s +", "q*s",
                                        "lambda: 1", "log(s)"])
def test_bad_profile_expressions_are_named(expression):
    config = dimensionless(fibres={"type": "expression", "expression": expression})
    assert error_of(config).startswith("scene.fibres.expression: ")


def test_bad_field_expression_is_named():
    config = physical(field={"type": "expression", "hx": "1", "hy": "__import__('os')", "scale": "1 kA/m"})
    assert error_of(config).startswith("scene.field.hy: ")


def test_stiffness_expression_must_stay_positive():
    config = physical(**{"rod.stiffness_profile": {"type": "expression", "expression": "1 - 2*s"}})
    assert error_of(config).startswith("scene.rod.stiffness_profile.expression: ")


def test_physical_stiffness_profile_must_start_at_one():
    config = physical(**{"rod.stiffness_profile": {"type": "table", "s": [0, 1], "values": [2, 1]}})
    assert error_of(config).startswith("scene.rod.stiffness_profile: must equal 1 at s = 0")


PARTICLES = {"axis_ratio": 3, "chi_par": 10, "chi_perp": 10, "volume_fraction": 0.05}


@pytest.mark.parametrize("key, value, field", [
    ("volume_fraction", 1.5, "volume_fraction: must be < 1"),
    ("volume_fraction", 0, "volume_fraction: must be > 0"),
    ("axis_ratio", 0.5, "axis_ratio: must be >= 1"),
    ("chi_par", -1, "chi_par: must be in (0, 1e+06]"),
    ("saturation_field", "2 mm", "saturation_field: expected a magnetic field"),
])
def test_bad_particles_are_named(key, value, field):
    config = physical(magnetics={"particles": {**PARTICLES, key: value}})
    assert error_of(config).startswith("scene.magnetics.particles." + field)


@pytest.mark.parametrize("config, message", [
    (physical(**{"type": "phys"}), "scene.type: unknown type 'phys' (allowed: dimensionless, physical)"),
    (physical(**{"type": None}), "scene.type: missing (allowed: dimensionless, physical)"),
    (physical(**{"field.type": "uniformm"}), "scene.field.type: unknown type 'uniformm'"),
    (dimensionless(fibres={"type": "spline"}), "scene.fibres.type: unknown type 'spline'"),
    (dimensionless(field={"type": "dipole", "position": {"x": 1, "y": 0.5}, "angle": 0}),
     "scene.field.angle: unknown key"),
])
def test_wrong_type_tags_are_named(config, message):
    assert error_of(config).startswith(message)


@pytest.mark.parametrize("config, field", [
    ({"solver": {}}, "scene: required"),
    (physical(**{"rod.length": None}), "scene.rod.length: required"),
    (physical(**{"rod.youngs_modulus": None}), "scene.rod.youngs_modulus: required"),
    (physical(**{"rod.bending_stiffness": "1 N m^2"}), "scene.rod.bending_stiffness: give either"),
    (physical(**{"rod.thickness": None}), "scene.rod.thickness: required"),
    (physical(magnetics=None), "scene.magnetics: required when a field is given"),
    (physical(magnetics={"chi_bar": 1, "particles": PARTICLES}), "scene.magnetics.particles: give either"),
    (physical(**{"loads.weight": {"density": 1000}, "loads.distributed": {"y": -1}}),
     "scene.loads.weight: give either"),
    (physical(field={"type": "dipole", "moment": "0.05 A m^2", "position": {"x": "50 mm", "y": 0}}),
     "scene.field.position: the dipole lies on the undeformed rod"),
    (dimensionless(phi="30 deg", field={"type": "uniform"}), "scene.phi: give either"),
    (dimensionless(p=1, tip_force={"y": 1}), "scene.p: give either"),
    (dimensionless(h=-1), "scene.h: must be >= 0"),
    ({**dimensionless(), "solver": {"degree": 61}}, "solver.degree: "),
    ({**dimensionless(), "solver": {"elements": 0}}, "solver.elements: "),
    ({**dimensionless(), "solver": {"method": "bfgs"}}, "solver.method: "),
    ({**dimensionless(), "solver": {"tol": 2}}, "solver.tol: must be < 1"),
    ({**dimensionless(), "solver": {"ensure_stable": "yes"}}, "solver.ensure_stable: "),
    ({**dimensionless(), "name": 3}, "name: "),
])
def test_structural_errors_are_named(config, field):
    assert error_of(config).startswith(field)


def test_files_and_yaml_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"^config: file not found"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("scene:\n  type: [physical\n")
    with pytest.raises(ConfigError, match=r"^config: invalid YAML .*line"):
        load_config(bad)
    listed = tmp_path / "list.yaml"
    listed.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match=r"^config: expected a mapping"):
        load_config(listed)


def test_config_error_is_a_value_error():
    assert issubclass(ConfigError, ValueError)


# -- quantities ---------------------------------------------------------------------------------
def test_millitesla_is_converted_with_mu0():
    assert parse_quantity("10 mT", "magnetic_field") == pytest.approx(10e-3 / MU0, rel=1e-14)
    config = physical(**{"field.magnitude": "10 mT"})
    assert load_config(config).to_scene().scales.field == pytest.approx(10e-3 / MU0, rel=1e-14)


@pytest.mark.parametrize("text, dimension, si", [
    ("27.5 mm", "length", 27.5e-3), ("10 um", "length", 1e-5), ("2.25 MPa", "pressure", 2.25e6),
    ("5 kA/m", "magnetic_field", 5e3), ("30 deg", "angle", math.pi / 6), ("1 rad", "angle", 1.0),
    ("0.05 A m^2", "magnetic_moment", 0.05), ("1100 kg/m^3", "density", 1100.0),
    ("2 mN", "force", 2e-3), ("3 mN m", "moment", 3e-3), ("0.5 N/m", "force_per_length", 0.5),
    ("4e-6 N m^2", "bending_stiffness", 4e-6), ("1e-4", "dimensionless", 1e-4), (27.5, "length", 27.5),
    (-6.0, "angle", -6.0),
])
def test_parse_quantity(text, dimension, si):
    assert parse_quantity(text, dimension) == pytest.approx(si, rel=1e-14)


# -- conversion ---------------------------------------------------------------------------------
def test_h_squared_by_hand():
    config = physical(**{"loads.tip_moment": "0.2 mN m", "loads.tip_force": {"x": "-1 mN", "y": "3 mN"}})
    scene = load_config(config).to_scene()
    # independent arithmetic: ℓ = 0.1 m, w = 0.01 m, t = 0.001 m, E = 1e6 Pa, χ̄ = 0.5, χ̂ = 0.2
    area = 0.01 * 0.001  # 1e-5 m²
    second_moment = 0.01 * 0.001**3 / 12.0  # 8.333e-13 m⁴
    bending = 1e6 * second_moment  # 8.333e-7 N m²
    h_squared = MU0 * 0.5 * (1e4) ** 2 * area * 0.1**2 / (2.0 * bending)
    # rectangle: h² = 6 μ0 χ̄ H² ℓ² / (E t²) = 6 · 4π·1e-7 · 0.5 · 1e8 · 0.01 / (1e6 · 1e-6) = 1.2π
    assert h_squared == pytest.approx(1.2 * math.pi, rel=1e-12)
    assert scene.h**2 == pytest.approx(h_squared, rel=1e-12)
    assert scene.h_pos**2 == pytest.approx(h_squared * 0.2 / 0.5, rel=1e-12)
    assert scene.tip_force == pytest.approx((-1e-3 * 0.01 / bending, 3e-3 * 0.01 / bending), rel=1e-12)
    assert scene.tip_moment == pytest.approx(0.2e-3 * 0.1 / bending, rel=1e-12)
    assert isinstance(scene.field, UniformField) and scene.phi == pytest.approx(math.pi / 2)
    assert scene.scales.length == 0.1 and scene.scales.field == 1e4
    assert scene.scales.bending_stiffness == pytest.approx(bending, rel=1e-14)


def test_bending_stiffness_and_area_instead_of_modulus():
    config = physical(**{"rod.youngs_modulus": None, "rod.width": None, "rod.thickness": None,
                         "rod.bending_stiffness": "8e-7 N m^2", "rod.area": "1e-5 m^2"})
    scene = load_config(config).to_scene()
    assert scene.scales.bending_stiffness == pytest.approx(8e-7)
    assert scene.h**2 == pytest.approx(MU0 * 0.5 * 1e8 * 1e-5 * 0.01 / (2 * 8e-7), rel=1e-12)


def test_invariance_under_rescaling():
    """ℓ, w, t → λℓ, λw, λt and E → μE leave h and p unchanged when H → √μ H and P → μλ² P."""
    lam, mu = 2.0, 3.0
    a = physical(**{"rod.length": 0.05, "rod.width": 0.004, "rod.thickness": 0.0008,
                    "rod.youngs_modulus": 1.5e6, "field.magnitude": 2e4, "field.angle": 0.3,
                    "loads.tip_force": {"x": 2e-4, "y": -1e-3}})
    b = physical(**{"rod.length": 0.05 * lam, "rod.width": 0.004 * lam, "rod.thickness": 0.0008 * lam,
                    "rod.youngs_modulus": 1.5e6 * mu, "field.magnitude": 2e4 * math.sqrt(mu),
                    "field.angle": 0.3, "loads.tip_force": {"x": 2e-4 * mu * lam**2,
                                                            "y": -1e-3 * mu * lam**2}})
    sa, sb = load_config(a).to_scene(), load_config(b).to_scene()
    assert sa.h > 0.1 and sa.p != 0
    assert sb.h == pytest.approx(sa.h, rel=1e-12)
    assert sb.h_pos == pytest.approx(sa.h_pos, rel=1e-12)
    assert sb.tip_force == pytest.approx(sa.tip_force, rel=1e-12)
    assert sb.phi == sa.phi
    assert sb.scales.length == pytest.approx(lam * sa.scales.length)


def test_dipole_field_scale_and_position():
    config = physical(field={"type": "dipole", "moment": "0.05 A m^2",
                             "position": {"x": "120 mm", "y": "-30 mm"}, "moment_angle": "0 deg"})
    scene = load_config(config).to_scene()
    assert isinstance(scene.field, DipoleField)
    assert (scene.field.x0, scene.field.y0) == pytest.approx((1.2, -0.3))
    assert scene.field.moment_angle == 0.0
    assert scene.scales.field == pytest.approx(0.05 / (4 * math.pi * 0.1**3), rel=1e-14)


def test_expression_field_uses_scale():
    config = physical(field={"type": "expression", "hx": "1 + x", "hy": "-y", "scale": "2 kA/m"})
    scene = load_config(config).to_scene()
    assert scene.field == ExpressionField(hx="1 + x", hy="-y")
    assert scene.scales.field == 2000.0


def test_weight_is_a_distributed_load():
    config = physical(loads={"weight": {"density": "1000 kg/m^3"}})
    scene = load_config(config).to_scene()
    bending = 1e6 * 0.01 * 0.001**3 / 12.0
    q = 1000 * 9.81 * 1e-5  # ρ g A, N/m, straight down
    assert scene.distributed_load == pytest.approx((0.0, -q * 0.1**3 / bending), rel=1e-12)
    assert scene.distributed_load[0] == 0.0
    assert scene.tip_force is None and scene.tip_moment is None


def test_particles_give_susceptibilities_and_warnings():
    from actuator_design.physics.magnetic_composite import ModelAssumptionWarning, effective_susceptibilities

    particles = {**PARTICLES, "volume_fraction": 0.3, "saturation_field": "1 kA/m"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the particle-only values of THEORY §2: the body's own demagnetisation (§10, on by
        # default since issue 12) is switched off here; tests/test_materials.py covers it
        scene = load_config(physical(magnetics={"particles": particles,
                                                "body_demagnetization": False})).to_scene()
    kinds = [w for w in caught if issubclass(w.category, ModelAssumptionWarning)]
    assert len(kinds) == 2  # dense particles, field above saturation
    chi_bar, chi_hat = effective_susceptibilities(10, 10, 3, 0.3)
    ref = physical(magnetics={"chi_bar": float(chi_bar), "chi_hat": float(chi_hat)})
    assert scene.h == pytest.approx(load_config(ref).to_scene().h, rel=1e-14)


def test_dimensionless_defaults_and_shorthands():
    bare = load_config(dimensionless()).to_scene()
    assert bare.field is None and bare.tip_force is None and bare.h == 0.0
    scene = load_config(dimensionless(h=1, phi="90 deg", p=2, fibres="30 deg", stiffness=2)).to_scene()
    assert scene.field == UniformField(phi=math.pi / 2)
    assert scene.tip_force == (0.0, 2.0) and scene.p == 2.0
    assert scene.fibres.kind == "constant" and scene.fibres.value == pytest.approx(math.pi / 6)
    assert scene.stiffness.value == 2.0
    table = load_config(dimensionless(fibres={"type": "table", "s": [0, 1], "values_deg": [0, 90]}))
    assert table.to_scene().fibres(1.0) == pytest.approx(math.pi / 2)


def test_solver_options_and_raw():
    config = {**dimensionless(h=1), "name": "demo",
              "solver": {"transcription": "midpoint", "elements": 64, "method": "newton", "tol": "1e-9"}}
    loaded = load_config(config)
    assert loaded.solver_options() == SolverOptions(transcription="midpoint", elements=64,
                                                    method="newton", tol=1e-9)
    assert load_config(dimensionless()).solver_options() == SolverOptions()
    assert loaded.raw == config and loaded.raw is not config
    assert loaded.to_scene().name == "demo"


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_every_config_file_loads(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped examples stay within the model's assumptions
        scene, options, raw = load_scene(path)
    assert isinstance(scene, Scene) and isinstance(options, SolverOptions)
    assert raw["scene"]["type"] in ("dimensionless", "physical")
    assert math.isfinite(scene.h)


def test_expected_config_files_exist():
    names = {p.name for p in CONFIGS}
    assert {"paper_case1_axial_field_tip_load.yaml", "paper_case2_transverse_buckling.yaml",
            "paper_actuator_physical.yaml", "varying_fibres.yaml", "permanent_magnet_dipole.yaml",
            "micro_rod.yaml", "weighted_strip.yaml"} <= names


def test_paper_configs_values():
    case1, _, _ = load_scene(CONFIGS[0].parent / "paper_case1_axial_field_tip_load.yaml")
    assert (case1.h, case1.phi, case1.p) == (1.0, 0.0, 2.0)
    case2, _, _ = load_scene(CONFIGS[0].parent / "paper_case2_transverse_buckling.yaml")
    assert (case2.h, case2.p) == (1.5, 0.0) and case2.phi == pytest.approx(math.pi / 2)
    actuator, _, _ = load_scene(CONFIGS[0].parent / "paper_actuator_physical.yaml")
    area, bending = 7e-3 * 3e-3, 2.25e6 * 7e-3 * (3e-3) ** 3 / 12
    assert actuator.h**2 == pytest.approx(MU0 * 1.32e-4 * 5e3**2 * area * 0.0275**2 / (2 * bending))
    assert actuator.h**2 == pytest.approx(9.29e-7, rel=1e-3)


# -- hostile input is bounded (issue 10 item 4) ---------------------------------------------------
def test_group_ranges_on_dimensionless_scenes():
    assert error_of(dimensionless(h=1e4 + 1)).startswith("scene.h: must be a finite number in [0, 10000]")
    assert error_of(dimensionless(p=-1e5 * 1.5)).startswith("scene.p: ")
    load_config(dimensionless(h=1e4, p=-1e5, tip_moment=1e5))  # the bounds themselves are valid


def test_the_valid_ranges_are_the_terms_own_and_every_scene_is_checked_against_them():
    """Issue 18: a term declares the range of its groups (``Parameter.valid_range``); the config's
    ranges are read from the registered terms, and a scene built in Python is checked against them
    whether or not it has the term (a remanent group of 2e8 is out of range even before a
    magnetisation is given)."""
    from actuator_design.config.checks import check_scene_groups
    from actuator_design.config.limits import GROUP_RANGES

    for names, (lo, hi) in ((("h", "h_pos"), (0.0, 1e4)), (("h_r",), (0.0, 1e8)),
                            (("p", "fy", "fx", "m_tip", "qx", "qy"), (-1e5, 1e5))):
        for name in names:
            assert (GROUP_RANGES[name].lo, GROUP_RANGES[name].hi) == (lo, hi), name
    for field, value, named in (("h_r", 2e8, "h_r"), ("tip_moment", -2e5, "m_tip"), ("h_pos", 1e5, "h_pos")):
        with pytest.raises(ConfigError, match=rf"^scene\.{named}: must be a finite number in"):
            check_scene_groups(Scene(**{field: value}), "scene.")
    check_scene_groups(Scene(h_r=1e8, tip_moment=-1e5, h_pos=1e4), "scene.")  # the bounds are valid


def test_derived_group_overflow_names_its_sources():
    message = error_of(physical(**{"rod.length": "1e308 m"}))
    assert message.startswith("scene.h: derived h = inf") and "rod.length = 1e+308 m" in message


def test_derived_tip_load_is_checked():
    # p = F ℓ² / (E w t³/12): 1 kN on a 0.1 m, 10 mm × 1 mm, 1 MPa strip is 1e3 · 1e-2 / 8.33e-7 = 1.2e7
    b0 = 1e6 * 1e-2 * 1e-3**3 / 12
    assert 1e3 * 0.1**2 / b0 > 1e5
    message = error_of(physical(**{"loads.tip_force": {"x": 0, "y": "1 kN"}}))
    assert message.startswith("scene.p: derived p = ") and "loads.tip_force" in message


def test_mesh_budget_in_solver_section_and_options():
    """The cap is the largest mesh that meets both bounds of config.limits (memory model, rounding
    floor K ε/Δ² ≤ 10³ tol), derived here from the bounds, not from the code's messages."""
    eps = float(np.finfo(float).eps)
    mem = lambda n, band: 18_200 * n + 1_930 * band * n <= 0.85e9  # noqa: E731
    # midpoint: Δ = 1/N; rounding N ≤ sqrt(1e3 tol / (0.5 ε)); memory N (18.2k + 3·1.93k) ≤ 0.85e9
    n_round = math.floor(math.sqrt(1e3 * 1e-10 / (0.5 * eps)))
    n_mem = math.floor(0.85e9 / (18_200 + 3 * 1_930))
    cap = min(n_round, n_mem)
    assert mem(cap, 3)
    mid = {**dimensionless(h=1), "solver": {"transcription": "midpoint"}}
    assert load_config({**mid, "solver": {"transcription": "midpoint", "elements": cap}})
    assert error_of({**mid, "solver": {"transcription": "midpoint", "elements": cap + 1}}).startswith(
        f"solver.elements: must be <= {cap} for midpoint (at tol 1e-10")
    # a larger tol lifts the rounding bound up to the memory bound
    loose = {"transcription": "midpoint", "elements": n_mem + 1, "tol": 1e-6}
    assert error_of({**mid, "solver": loose}).startswith(f"solver.elements: must be <= {n_mem} for midpoint (peak memory")
    # lgl degree 10: smallest spacing (1 + τ_1)/2 / E, τ_1 the first interior LGL node
    tau1 = np.sort(np.real(np.polynomial.legendre.legroots(np.polynomial.legendre.legder([0] * 10 + [1]))))[0]
    e_round = math.floor((1 + tau1) / 2 / math.sqrt(3.5 * eps / (1e3 * 1e-10)))
    assert load_config({**dimensionless(h=1), "solver": {"elements": e_round}})
    assert error_of({**dimensionless(h=1), "solver": {"elements": e_round + 1}}).startswith(
        f"solver.elements: must be <= {e_round} for lgl of degree 10")
    # meshes the tool picks (SolverOptions from Python) are held to memory only
    SolverOptions(elements=e_round + 100)
    with pytest.raises(ValueError, match=r"^elements must be <= .*peak memory"):
        SolverOptions(transcription="midpoint", elements=n_mem + 1, tol=1e-6)
    # over the memory budget at the default tol: the message names the binding (rounding) cap
    with pytest.raises(ValueError, match=rf"^elements must be <= {cap} for midpoint \(at tol 1e-10"):
        SolverOptions(transcription="midpoint", elements=133_333)


def test_dense_mesh_budget_needs_a_non_uniform_field():
    dipole = {"type": "dipole", "position": {"x": 0.5, "y": 0.5}}
    assert error_of({**dimensionless(h=1, field=dipole), "solver": {"elements": 21}}).startswith(
        "solver.elements: must be <= 20")
    load_config({**dimensionless(h=1, field=dipole), "solver": {"elements": 20}})
    load_config({**dimensionless(h=1), "solver": {"elements": 21}})


def test_shared_reference_bomb_in_a_dict_is_stopped():
    bomb = [1.0] * 10
    for _ in range(12):  # 10^13 values once expanded
        bomb = [bomb] * 10
    with pytest.raises(ConfigError, match=r"^config: .* expands to more than 100000 values"):
        load_config({**dimensionless(h=1), "study": {"type": "sweep", "values": bomb}})


def test_yaml_duplicate_keys_and_encoding(tmp_path):
    dup = tmp_path / "dup.yaml"
    dup.write_text("scene:\n  type: dimensionless\n  p: 1\n  h: 1\n  p: 2\n")
    with pytest.raises(ConfigError, match=r"^config: duplicate key 'p' at line 5 of .*dup.yaml "
                                          r"\(first given at line 3\)"):
        load_config(dup)
    latin = tmp_path / "latin.yaml"
    latin.write_bytes("name: \xe9t\xe9\nscene: {type: dimensionless}\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"^config: .*latin.yaml is not UTF-8"):
        load_config(latin)
    merged = tmp_path / "merge.yaml"  # a merge key is not a duplicate: explicit keys override it
    merged.write_text("scene:\n  <<: {type: dimensionless, h: 2}\n  h: 1\n")
    assert load_scene(merged)[0].h == 1.0


def test_expression_bounds():
    from actuator_design.model.expressions import Expression, ExpressionError

    with pytest.raises(ExpressionError, match="too long"):
        Expression("+".join(["s"] * 6000), ("s",))
    with pytest.raises(ExpressionError, match="nested deeper"):
        Expression("-" * 300 + "s", ("s",))
    for text in ("1/0", "10**10**10", "2**(-1e6)*0 + log(0)", "sqrt(-1)"):
        with pytest.raises(ExpressionError, match="not a finite number"):
            Expression(text, ("s",))
    for text in ("1" + "0" * 400 + "*s", "1e400*s"):  # literals beyond float64 (max ≈ 1.8e308)
        with pytest.raises(ExpressionError, match="not a finite float64 number"):
            Expression(text, ("s",))
    with pytest.raises(ExpressionError, match="sin takes 1 argument, got 2"):
        Expression("sin(1, s)", ("s",))
    # a constant part is folded in float64 only to check it; the value stays exact
    assert Expression("1/3 + s", ("s",)).evaluate({"s": 0.0}) == 1.0 / 3.0
    # 101-term sums are fine (depth 101 < 200)
    assert Expression("+".join(["s"] * 101), ("s",)).evaluate({"s": 2.0}) == 202.0


@pytest.mark.parametrize("value", [0, -3, 100_001, 10**12, 2.5, True])
def test_the_iteration_limit_is_bounded_in_python_and_in_yaml(value):
    """max_iter bounds the work of one solve: an integer in [1, 100000] (IPOPT's default is 3000),
    refused with the field's name from Python and from a configuration."""
    with pytest.raises(ValueError, match=r"^max_iter must be an integer in \[1, 100000\]"):
        SolverOptions(max_iter=value)
    assert error_of({**dimensionless(h=1), "solver": {"max_iter": value}}).startswith("solver.max_iter: ")
