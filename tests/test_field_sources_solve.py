"""Equilibria in the fields of real magnets and coils (issue 19): ``solve`` on the shipped configs
against an independent shooting solver that calls magpylib for the field at every step
(:mod:`actuator_design.reference.shooting_field`, magpylib objects built here by hand); the region
where a fit holds is enforced; bad source configs are one clear line."""
import math
from dataclasses import replace
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from actuator_design.equilibrium.acceptance import check_physical
from actuator_design.cli.main import main
from actuator_design.config.errors import ConfigError
from actuator_design.config.model import load_config
from actuator_design.equilibrium.pipeline import solve
from field_references import shooting_tip

MU0 = 4e-7 * math.pi
CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def _scene(name):
    return load_config(CONFIGS / name).to_scene()


def test_hard_magnetic_strip_beside_a_cylinder_magnet_against_shooting():
    scene = _scene("magnet_cylinder_hard_strip.yaml")
    assert scene.h_r > 0 and scene.h == 0
    res = solve(scene)
    assert res.success and res.stable
    up = Rotation.from_rotvec([-0.5 * math.pi, 0, 0])  # the cylinder's axis (local z) to +y
    magnet = magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                   position=(25e-3, -15e-3, 0), orientation=up)
    ref = shooting_tip(scene, [magnet], res)
    ours = np.array([res.tip["x"], res.tip["y"], res.tip["angle"]])
    assert np.max(np.abs(ours - ref)) <= 1e-6, ours - ref
    assert abs(ours[1]) > 0.05  # the field does bend the rod


def test_hard_magnetic_strip_beside_a_block_magnet_against_shooting():
    """The shipped cuboid scene: its field (tesseral harmonics) is not axisymmetric; the reference
    calls magpylib's cuboid, built unrotated (x wide, y along the magnetisation, z thick)."""
    scene = _scene("magnet_cuboid_hard_strip.yaml")
    assert scene.field.terms[0].order > 1 and scene.field.fit_error <= 1e-6
    res = solve(scene)
    assert res.success and res.stable
    block = magpy.magnet.Cuboid(dimension=(10e-3, 5e-3, 10e-3), magnetization=(0, 1.2 / MU0, 0),
                                position=(25e-3, -15e-3, 0))
    ref = shooting_tip(scene, [block], res)
    ours = np.array([res.tip["x"], res.tip["y"], res.tip["angle"]])
    assert np.max(np.abs(ours - ref)) <= 1e-6, ours - ref
    assert ours[1] > 0.1  # the field does bend the rod


def test_soft_strip_between_helmholtz_coils_against_shooting():
    scene = _scene("helmholtz_soft_strip.yaml")
    res = solve(scene)
    assert res.success and res.stable
    a = math.radians(70)
    axis = Rotation.from_euler("z", a) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])
    coils = [magpy.current.Circle(diameter=0.1, current=200 * 5.0, orientation=axis,
                                  position=(10e-3 + z * math.cos(a), z * math.sin(a), 0)) for z in (-25e-3, 25e-3)]
    ref = shooting_tip(scene, coils, res)
    ours = np.array([res.tip["x"], res.tip["y"], res.tip["angle"]])
    assert np.max(np.abs(ours - ref)) <= 1e-6, ours - ref
    assert ours[1] > 0.3


def test_a_state_outside_the_fitted_region_is_not_a_success():
    """The fit's region shrunk by hand to exclude the rod's tip: the same state is refused."""
    scene = _scene("magnet_cylinder_hard_strip.yaml")
    res = solve(scene)
    t = scene.field.terms[0]
    tip_distance = math.hypot(res.tip["x"] - t.centre[0], res.tip["y"] - t.centre[1])
    narrowed = replace(scene.field, terms=(replace(t, valid_radius=tip_distance + 0.01),))
    res.scene = replace(scene, field=narrowed)
    check_physical(res)
    assert not res.success and res.status == "outside_field_region"
    assert "closer to source 1's centre" in res.message


@pytest.mark.parametrize("field, where, words", [
    ({"type": "magnet", "diameter": "10 mm", "position": {"x": "25 mm", "y": "0 mm"}, "remanence": "1 T"},
     "scene.field.height", "needs its height"),
    ({"type": "magnet", "shape": "cylinder", "diameter": "10 mm", "height": "10 mm",
      "position": {"x": "3 mm", "y": "0 mm"}, "remanence": "1 T"}, "scene.field", "the clamp lies within"),
    ({"type": "magnet", "diameter": "10 mm", "height": "1 A", "position": {"x": "25 mm"}, "remanence": "1 T"},
     "scene.field.height", "length"),
    ({"type": "magnet", "shape": "cuboid", "height": "5 mm", "width": "10 mm", "position": {"x": "25 mm"},
      "remanence": "1 T"}, "scene.field.thickness", "needs its thickness"),
    ({"type": "magnet", "shape": "diametric_cylinder", "diameter": "5 mm", "position": {"x": "25 mm"},
      "remanence": "1 T"}, "scene.field.height", "a diametric_cylinder magnet needs its height"),
    ({"type": "magnets", "magnets": [{"diameter": "5 mm", "height": "5 mm", "position": {"x": f"{x} mm"},
                                      "remanence": "1 T", "travel": {"x": ["20 mm", "50 mm"]}} for x in (25, 40)]},
     "scene.field.magnets[1].travel", "both have a travel"),
    ({"type": "magnet", "shape": "sphere", "diameter": "5 mm", "width": "10 mm", "position": {"x": "25 mm"},
      "remanence": "1 T"}, "scene.field.width", "has no width; give its diameter"),
    ({"type": "coils", "coils": [{"kind": "solenoid", "radius": "5 mm", "current": "1 A",
                                  "position": {"x": "30 mm"}}]}, "scene.field.coils[0].length", "needs its length"),
    ({"type": "coils", "coils": [{"radius": "5 mm", "current": "0 A", "position": {"x": "30 mm"}}]},
     "scene.field.coils", "zero"),
    ({"type": "coils", "coils": [{"radius": "5 mm", "current": "1 A", "position": {"x": "30 mm"}, "turns": 10 ** 6}]},
     "scene.field.coils[0].turns", "2000"),
    ({"type": "coils", "coils": [{"radius": "5 mm", "current": "1 A", "position": {"x": "30 mm"}, "colour": 1}]},
     "scene.field.coils[0].colour", ""),
])
def test_bad_source_configs_name_the_field(field, where, words):
    cfg = {"scene": {"type": "physical", "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                                                  "youngs_modulus": "1 MPa"},
                     "magnetics": {"remanent_flux_density": "0.01 T"}, "magnetization": "0 deg", "field": field}}
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    assert err.value.field == where and words in err.value.detail, str(err.value)


def test_solve_prints_the_fit(capsys):
    assert main(["solve", str(CONFIGS / "helmholtz_soft_strip.yaml")]) == 0
    out = capsys.readouterr().out
    assert "field       : helmholtz coil" in out and "fit error" in out and "h_pos = " in out


def test_design_in_a_non_uniform_field_designs_its_strength_not_an_angle():
    """A dipole field has no angle: the automatic sets drop φ (they asked for it and failed with
    '--vary phi: needs a uniform field' before) and say so."""
    from actuator_design.inverse.design import design_problem

    scene = _scene("permanent_magnet_dipole.yaml")
    prob = design_problem((0.9, -0.2), replace(scene, fibres_given=False), None, None, None, None, 0.0)
    assert prob.variable_sets == (("h",), ("h", "alpha"))
    assert any("its angle is not a design variable" in n for n in prob.notes)


def test_design_in_a_field_of_coils_without_current_limits_is_refused_in_one_line(capsys):
    """A coil scene's design varies its currents, which needs each driver's limit (issue 19 item 2;
    tests/test_current_design.py)."""
    assert main(["design", str(CONFIGS / "helmholtz_soft_strip.yaml"), "--target-tip", "0.8,0.5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no max_current" in err[0]


def test_a_rod_pulled_onto_a_magnet_says_it_left_the_fitted_region():
    """A magnet the rod can reach, pulling hard: the path from rest snaps towards it and the solve
    fails there; the result names the cause (the field is not known there), not a solver code."""
    from actuator_design.model.field_sources import MagnetSource, source_field
    from actuator_design.model.profiles import constant_profile
    from actuator_design.model.scene import Scene

    magnet = MagnetSource("cylinder", 10e-3, 10e-3, (15e-3, -12e-3), 0.5 * math.pi, 1.2 / MU0)
    field, _ = source_field((magnet,), 20e-3)
    assert field.terms[0].valid_radius > math.hypot(*field.terms[0].centre) - 1.0  # the rod can get there
    gentle = solve(Scene(field=field, h_r=0.5, magnetization=constant_profile(math.pi)))
    assert gentle.success
    r = solve(Scene(field=field, h_r=5.0, magnetization=constant_profile(math.pi)))
    assert not r.success and r.status == "outside_field_region"
    assert "closer to source 1's centre than its field representation holds" in r.message


def test_several_magnets_in_a_config_add_their_fields():
    """``type: magnets``: a cylinder below the rod and a block above it, each fitted on its own; the
    scene's field at random points of the reach where both fits hold against magpylib's sum of the
    two (built here by hand), relative to H0, and the bending it causes is solved."""
    from actuator_design.physics.fields import field_model

    magnets = [{"shape": "cylinder", "diameter": "10 mm", "height": "10 mm",
                "position": {"x": "25 mm", "y": "-15 mm"}, "axis_angle": "90 deg", "remanence": "1.2 T"},
               {"shape": "cuboid", "height": "4 mm", "width": "8 mm", "thickness": "6 mm",
                "position": {"x": "10 mm", "y": "22 mm"}, "axis_angle": "0 deg", "remanence": "1 T"}]
    cfg = {"scene": {"type": "physical", "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                                                  "youngs_modulus": "1 MPa"},
                     "magnetics": {"remanent_flux_density": "0.01 T"}, "magnetization": "0 deg",
                     "field": {"type": "magnets", "magnets": magnets}}}
    scene = load_config(cfg).to_scene()
    field, h0 = scene.field, scene.scales.field
    assert len(field.terms) == 2 and field.fit_error <= 1e-6
    objs = [magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                  position=(25e-3, -15e-3, 0),
                                  orientation=Rotation.from_rotvec([-0.5 * math.pi, 0, 0])),
            magpy.magnet.Cuboid(dimension=(4e-3, 8e-3, 6e-3), magnetization=(1.0 / MU0, 0, 0),
                                position=(10e-3, 22e-3, 0))]
    rng = np.random.default_rng(4)
    pts = rng.uniform(-1, 1, (2000, 2))
    inside = np.all([t.contains(pts[:, 0], pts[:, 1]) for t in field.terms], 0)
    pts = pts[(np.hypot(pts[:, 0], pts[:, 1]) <= 1) & inside]
    H = np.asarray(magpy.getH(objs, np.column_stack([pts * 20e-3, np.zeros(len(pts))]), sumup=True))[:, :2] / h0
    h = field_model(field).evaluate(pts[:, 0], pts[:, 1], {}).T
    assert len(pts) >= 100 and np.max(np.linalg.norm(h - H, axis=1)) <= 2 * field.fit_error + 1e-12
    with pytest.raises(ConfigError) as err:
        broken = [magnets[0], {**magnets[1], "width": None}]
        load_config({"scene": {**cfg["scene"], "field": {"type": "magnets", "magnets": broken}}})
    assert err.value.field == "scene.field.magnets[1].width" and "needs its width" in err.value.detail


def test_magnets_whose_bodies_intersect_are_refused_and_touching_ones_are_not():
    """Two discs overlap exactly when their centres are closer than the sum of their radii; two
    blocks stacked face to face touch and are accepted, pushed 0.1 mm into each other they are not."""
    from actuator_design.model.sources import MagnetSource, plane_section, sections_overlap

    disc = MagnetSource("diametric_cylinder", 4e-3, 2e-3, (0.0, 0.0), 0.0, 1.0)
    for gap, overlapping in ((-1e-4, True), (1e-7, False), (1e-3, False)):
        other = MagnetSource("sphere", 6e-3, 0.0, (math.sqrt(0.5) * (5e-3 + gap),) * 2, 0.0, 1.0)  # at 45°
        distance = math.hypot(*other.position)
        assert (distance < 5e-3) == overlapping
        assert sections_overlap(plane_section(disc), plane_section(other), 1e-9) == overlapping

    def block(y):
        return {"shape": "cuboid", "height": "4 mm", "width": "8 mm", "thickness": "6 mm",
                "position": {"x": "25 mm", "y": f"{y} mm"}, "axis_angle": "90 deg", "remanence": "1 T"}

    def scene(magnets):
        return {"scene": {"type": "physical", "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm",
                                                      "youngs_modulus": "1 MPa"},
                          "magnetics": {"remanent_flux_density": "0.01 T"}, "magnetization": "0 deg",
                          "field": {"type": "magnets", "magnets": magnets}}}
    assert len(load_config(scene([block(-14), block(-18)])).to_scene().field.terms) == 2  # stacked
    with pytest.raises(ConfigError) as err:
        load_config(scene([block(-14), block(-17.9)]))
    assert err.value.field == "scene.field.magnets[1].position" and "overlap" in err.value.detail
