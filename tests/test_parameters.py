"""The parameter lens and the kinematics the terms read."""
import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from actuator_design.physics import parameters as lens
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.physics.kinematics import PlanarKinematics
from actuator_design.physics.registry import build_terms
from actuator_design.model.scene import DipoleField, Scene, default_scene
from actuator_design.equilibrium.solver import get_solver


def test_every_parameter_round_trips_and_adds_its_term():
    bare = Scene(field=None, tip_force=None)
    for name, p in lens.parameters().items():
        if name == "phi" or p.per_point:
            sc = lens.set_value(default_scene(), name, 0.3)
        elif name == "h_pos":
            sc = lens.set_value(replace(default_scene(h=1.0), field=DipoleField()), name, 0.3)
        else:
            sc = lens.set_value(bare, name, 0.3)
        assert lens.get_value(sc, name) == pytest.approx(0.3)
        if p.term is not None:  # the term the parameter needs is now built
            assert p.term in [t.name for t in build_terms(sc)]


def test_unknown_names_list_the_allowed_ones_and_ranges_are_named():
    with pytest.raises(ValueError, match=r"unknown parameter 'bogus' \(allowed: h, h2, phi"):
        lens.parameter("bogus")
    with pytest.raises(ValueError, match=r"^h_pos: must be >= 0, got -1$"):
        lens.set_value(default_scene(), "h_pos", -1)
    with pytest.raises(ValueError, match=r"^qx: must be finite"):
        lens.set_value(default_scene(), "qx", math.nan)


def test_slot_transform_h2_is_the_square_of_h():
    p = lens.parameter("h2")
    assert p.slot == "h" and p.to_slot(2.25) == pytest.approx(1.5)
    lam = ca.SX.sym("lam")
    assert float(ca.Function("f", [lam], [p.slot_expr(lam) ** 2])(3.7)) == pytest.approx(3.7, abs=1e-15)


def test_field_ramp_keeps_h_pos_over_h_because_both_scale_with_H():
    """THEORY §5: h ∝ H and h_pos ∝ H, so h_pos/h (a material ratio) is invariant on a field ramp,
    whichever name (h or h2 ∝ H²) sets the magnitude."""
    sc = replace(default_scene(h=0.8), field=DipoleField(), h_pos=0.2)
    for name, v, h_new in (("h", 0.4, 0.4), ("h2", 0.16, 0.4), ("h", 1.6, 1.6)):
        out = lens.apply_values(sc, {name: v})
        assert out.h == pytest.approx(h_new) and out.h_pos / out.h == pytest.approx(0.25)
    with pytest.raises(ValueError, match="give either h or h2, not both"):
        lens.apply_values(sc, {"h": 1.0, "h2": 1.0})


def test_residual_scale_is_derived_from_the_terms():
    sc = default_scene(h=3.0, p=-20.0)
    sv = get_solver(sc, SolverOptions(elements=1, degree=6))
    assert sv.residual_scale(sv.parameter_vector(sc)) == pytest.approx(20.0)  # |p| > h² = 9
    sc2 = default_scene(h=5.0, p=-20.0)
    assert sv.residual_scale(sv.parameter_vector(sc2)) == pytest.approx(25.0)


def test_positions_are_built_only_when_a_term_reads_them():
    opts = SolverOptions(elements=1, degree=6)
    uniform = get_solver(default_scene(h=1.0, p=1.0), opts)
    loaded = get_solver(replace(default_scene(h=1.0), distributed_load=(0.0, -1.0)), opts)
    assert not uniform.discrete.uses_positions and loaded.discrete.uses_positions


def test_directors_are_orthonormal_and_rotate_by_a_quarter_turn():
    th = ca.SX.sym("th")
    kin = PlanarKinematics(th, ca.SX.sym("k"), {})
    (t1, t2), (n1, n2) = kin.tangent, kin.normal
    f = ca.Function("f", [th], [t1 * n1 + t2 * n2, t1**2 + t2**2, t1 * n2 - t2 * n1])
    for v in np.linspace(-3, 3, 7):
        dot, norm, cross = (float(x) for x in f(v))
        assert abs(dot) < 1e-15 and norm == pytest.approx(1.0) and cross == pytest.approx(1.0)
    with pytest.raises(RuntimeError, match="no positions"):
        kin.position


# -- one registry: every name an analysis accepts is a lens entry ---------------------------------
def _scene_flag_names():
    """Destinations of the CLI's scene-value flags (the 'scene' argument group)."""
    import argparse

    from actuator_design.cli.scene_args import SCENE_KEYS, add_scene_args

    parser = argparse.ArgumentParser()
    add_scene_args(parser, dict.fromkeys(SCENE_KEYS, 0.0))
    group = next(g for g in parser._action_groups if g.title.startswith("scene"))
    dests = {a.dest for a in group._group_actions}
    assert {"h", "phi_deg", "p", "alpha_deg"} <= dests
    return dests | set(SCENE_KEYS)


def test_every_name_the_analyses_accept_is_a_lens_entry():
    from actuator_design.analysis import stiffness
    from actuator_design.inverse import design
    from actuator_design.robust import design_robust
    from actuator_design.robust import tolerances
    from actuator_design.inverse.nlp import DESIGN_VARIABLES
    from actuator_design.calibration import PARAMETERS as FIT_PARAMETERS
    from actuator_design.cli import continue_, path
    from actuator_design.cli import design as cli_design

    known = set(lens.entry_names())
    accepted = {
        "fit parameters": set(FIT_PARAMETERS),
        "design variables": set(DESIGN_VARIABLES) | set(cli_design._VARIABLES)
        | {v for s in design.AUTO_VARIABLE_SETS for v in s},
        "continue/critical/map --param": set(continue_.PARAM_NAMES),
        "path --param and schedule rows": set(path._DEGREE_NAMES) | set(path._DEGREE_NAMES.values()),
        "stiffness loads": set(stiffness.LOAD_NAMES),
        "robust design: per-pose variables and the slots a tolerance scales": set(design_robust._PER_POSE)
        | set(design_robust._SCALED),
        "tolerance box: physical axes": set(tolerances._SPEC) & set(lens.physical_parameters()),
        "scene flags (--h, --phi-deg, ...)": _scene_flag_names(),
    }
    assert {"youngs_modulus", "chi_bar", "clamp_angle"} <= accepted["tolerance box: physical axes"]
    for what, got in accepted.items():
        assert got <= known, f"{what}: not lens entries: {sorted(got - known)}"
    assert {"h", "phi"} <= set(lens.designable())  # the field schedule designs h and phi


def test_the_accepted_lists_are_the_lens_lists_themselves():
    """No second list: what design, the CLI and the fit accept is read from the lens."""
    from actuator_design.inverse.nlp import DESIGN_VARIABLES, _LENS_VARIABLES
    from actuator_design.calibration import PARAMETERS as FIT_PARAMETERS
    from actuator_design.cli import path
    from actuator_design.cli import design as cli_design

    designable = lens.designable()
    assert list(DESIGN_VARIABLES) == list(cli_design._VARIABLES) == list(designable) \
        == ["h", "phi", "alpha", "p", "magnetization"]  # issue 12: β(s) designable too
    assert _LENS_VARIABLES == ("h", "phi", "p") and designable["alpha"].per_point  # α: a profile
    assert FIT_PARAMETERS is lens.physical_parameters()
    assert path._DEGREE_NAMES == {f"{n}_deg": n for n, p in lens.parameters().items() if p.unit == "rad"}
    for name, p in lens.physical_parameters().items():  # links to scene parameters resolve
        assert p.same_as is None or lens.parameter(p.same_as).name == p.same_as
        assert all(slot in {q.slot for q in lens.parameters().values()} for slot, _ in p.groups)
        assert p.unit == {"dimensionless": "", "angle": "rad", "pressure": "Pa",
                          "bending_stiffness": "N m^2", "magnetic_field": "A/m"}[p.dimension]
    with pytest.raises(ValueError, match=r"unknown fit parameter 'E' \(allowed: chi_bar, youngs_modulus"):
        lens.physical_parameter("E", "fit parameter")


def test_fit_spec_and_design_reject_non_lens_names_listing_the_lens():
    from actuator_design.inverse.design import design
    from actuator_design.calibration import FitSpec
    from actuator_design.config import ConfigError
    from actuator_design.config.studies.validation import validate_spec

    allowed = ", ".join(lens.physical_parameters())
    with pytest.raises(ConfigError, match=rf"study\.parameters\.h2: unknown parameter \(allowed: {allowed}\)"):
        validate_spec(FitSpec, {"type": "fit", "parameters": {"h2": {}}})
    with pytest.raises(ValueError, match=rf"allowed: {', '.join(lens.designable())}"):
        design((0.3, 0.5), vary=("h", "theta0"))


# -- physical parameters: the groups of THEORY §5 -------------------------------------------------
MU0 = 4e-7 * math.pi
_ROD = {"length": 0.02, "width": 5e-3, "thickness": 0.5e-3}


def _fit_problem(tmp_path):
    from actuator_design.calibration import prepare_fit

    data = tmp_path / "d.csv"
    data.write_text("field [kA/m], field_angle [deg], load [mN], tip_deflection [mm]\n" +
                    "".join(f"{H}, {a}, {P}, {d}\n" for H in (0, 5, 10, 15) for a, P, d in
                            ((0, 0.1, 1.0), (30, 0.2, 1.5))))
    config = {"scene": {"type": "physical",
                        "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm",
                                "youngs_modulus": "1 MPa"},
                        "magnetics": {"chi_bar": 0.4},
                        "field": {"type": "uniform", "magnitude": "10 kA/m", "angle": "30 deg"},
                        "loads": {"tip_force": {"x": "0.05 mN", "y": "0.1 mN"},
                                  "tip_moment": "0.002 mN m",
                                  "distributed": {"x": "0.01 N/m", "y": "-0.02 N/m"}},
                        "fibres": "0 deg"},
              "study": {"type": "fit", "parameters": {
                  "chi_bar": {"bounds": [0.01, 5]}, "youngs_modulus": {"bounds": ["0.1 MPa", "10 MPa"]},
                  "field_scale": {"bounds": [0.5, 2]}, "field_offset": {"bounds": ["-1 kA/m", "1 kA/m"]},
                  "field_angle_offset": {"bounds": ["-5 deg", "5 deg"]},
                  "clamp_angle": {"initial": "2 deg", "bounds": ["-5 deg", "5 deg"]}}}}
    return prepare_fit(config, data)


def test_fit_map_is_theory_5_and_its_log_derivatives_are_the_lens_exponents(tmp_path):
    """The fit's map θ → NLP slots against THEORY §5 written out here (h² = μ0 χ̄ H² A ℓ²/(2B),
    loads ∝ 1/B), and its exact derivatives against what the lens says of each parameter:
    d ln(slot)/d ln(value) = the lens exponent for log-scale parameters, a unit shift for offsets."""
    prob = _fit_problem(tmp_path)
    names = prob.names
    th = np.array([0.7, 2.5e6, 1.3, 0.0, 0.01, 0.02])  # chi, E, scale, offset, dphi, theta0
    H, phi, P = 8e3, 0.4, 1e-4
    u = np.array([H, phi, 0.0, P])
    q, dq = (np.asarray(v, float) for v in prob.f_map(th, u))
    q = q.ravel()
    slot = {s: i for i, s in enumerate(prob.slots)}
    assert {"h", "phi", "fx", "fy", "qx", "qy", "m_tip", "theta0"} <= set(slot)

    L, w, t = _ROD["length"], _ROD["width"], _ROD["thickness"]
    B = th[1] * w * t**3 / 12.0
    H_eff = th[2] * H + th[3]
    assert q[slot["h"]] == pytest.approx(math.sqrt(MU0 * th[0] * H_eff**2 * w * t * L**2 / (2 * B)),
                                         rel=1e-12)
    assert q[slot["fy"]] == pytest.approx(P * L**2 / B, rel=1e-12)
    assert q[slot["m_tip"]] == pytest.approx(2e-6 * L / B, rel=1e-12)
    assert q[slot["qy"]] == pytest.approx(-0.02 * L**3 / B, rel=1e-12)
    assert q[slot["phi"]] == pytest.approx(phi + th[4], abs=1e-15)
    assert q[slot["theta0"]] == pytest.approx(th[5], abs=1e-15)

    for i, name in enumerate(names):
        p = lens.physical_parameter(name)
        for s, j in slot.items():
            if p.log:
                if q[j] == 0.0:
                    assert dq[j, i] == 0.0
                    continue
                assert th[i] * dq[j, i] / q[j] == pytest.approx(p.exponent(s), abs=1e-12), (name, s)
            elif p.shifts == "field":  # h = c·(H + offset): dh/d offset = h / H_eff
                assert dq[j, i] == pytest.approx(q[j] / H_eff if s == "h" else 0.0, abs=1e-15)
            else:  # an angle that is, or shifts, one slot
                target = p.same_as or p.shifts
                assert dq[j, i] == (1.0 if s == lens.parameter(target).slot else 0.0), (name, s)


def test_h_per_field_interval_uses_the_lens_exponents():
    """d ln c / d ln χ̄ = ½, d ln c / d ln E = −½ (c = √(μ0 χ̄ A ℓ²/(2B)), THEORY §5); the field's
    measurement model does not change c."""
    from actuator_design.calibration.parameters import field_coefficient_exponent as e

    c = lambda chi, E: math.sqrt(MU0 * chi * 1.0 / (2.0 * E))  # noqa: E731
    for name, f in (("chi_bar", lambda x: c(x, 3.0)), ("youngs_modulus", lambda x: c(0.3, x)),
                    ("bending_stiffness", lambda x: c(0.3, x))):
        x0, r = 0.7, 1e-4  # central difference of ln c in ln x
        ref = (math.log(f(x0 * math.exp(r))) - math.log(f(x0 * math.exp(-r)))) / (2 * r)
        assert e(name) == pytest.approx(ref, abs=1e-9)
    for name in ("field_scale", "field_offset", "field_angle_offset", "clamp_angle"):
        assert e(name) == 0.0


@pytest.mark.parametrize("values", [{"h": 2.5}, {"phi": 0.7}, {"p": -1.5}, {"alpha": 0.3},
                                    {"h": 1.2, "phi": 2.0, "p": 3.0, "alpha": -0.4}])
@pytest.mark.parametrize("base", ["none", "uniform", "loaded"])
def test_scene_with_values_writes_what_the_lens_writes(values, base):
    """Scene.with_values (the model's own writes) and the lens' h, phi, p, alpha writes, in that
    order, give the same scene."""
    from dataclasses import replace as _replace

    from actuator_design.model.scene import Scene, UniformField
    from actuator_design.physics.parameters import parameter

    scene = {"none": Scene(field=None, tip_force=None), "uniform": Scene(field=UniformField(phi=0.2), h=0.8),
             "loaded": _replace(Scene(field=None), tip_force=(0.4, 0.1))}[base]
    by_lens = scene
    for name in ("h", "phi", "p", "alpha"):
        if name in values:
            by_lens = parameter(name).write(by_lens, float(values[name]))
    assert scene.with_values(**values) == by_lens


def test_scene_with_values_in_a_dipole_field_writes_what_the_lens_writes():
    from actuator_design.model.scene import DipoleField, Scene
    from actuator_design.physics.parameters import parameter

    scene = Scene(field=DipoleField(), h=0.7, tip_force=None)
    by_lens = scene
    for name, value in (("h", 2.0), ("p", 1.0), ("alpha", 0.3)):
        by_lens = parameter(name).write(by_lens, value)
    assert scene.with_values(h=2.0, p=1.0, alpha=0.3) == by_lens
    with pytest.raises(ValueError, match="phi can only be set for a uniform field"):
        scene.with_values(phi=0.5)


def test_scaling_the_field_scales_every_group_it_drives_and_adds_no_term():
    """h, h_pos and h_r are each ∝ H (THEORY §5, §9): the same rod in a field k times stronger has
    each of them k times larger; h² would be k² (its slot is h's). A rod without a magnetisation
    keeps none, whatever its stored h_r."""
    from actuator_design.model.profiles import constant_profile

    hard = replace(Scene(field=DipoleField(), h=0.7, h_pos=0.3, fibres=constant_profile(0.0),
                         stiffness=constant_profile(1.0)), h_r=1.1, magnetization=constant_profile(0.2))
    twice = lens.scale_field(hard, 2.0)
    assert (twice.h, twice.h_pos, twice.h_r) == (1.4, 0.6, 2.2)
    assert lens.remanent_group(twice) == 2.2 and lens.remanent_group(hard) == 1.1
    others = lens.scale_field(replace(hard, h=5.0), 3.0, source=hard, magnitude=False)
    assert (others.h, others.h_pos, others.h_r) == (5.0, pytest.approx(0.9), pytest.approx(3.3))
    soft = replace(hard, magnetization=None)
    assert lens.remanent_group(soft) == 0.0 and lens.scale_field(soft, 2.0).magnetization is None
    assert [p.name for p, f in lens.field_groups()] == ["h", "h_pos", "h_r"]


def test_a_tip_moment_and_a_tip_force_are_what_the_terms_apply_at_the_end():
    from actuator_design.physics.registry import end_force, end_moment

    assert end_moment(default_scene()) == 0.0
    assert end_moment(replace(default_scene(), tip_moment=-2.5)) == 2.5
    assert end_force(default_scene(p=0.25)) == (0.0, 0.25)
    assert end_force(replace(default_scene(), tip_force=None)) is None
