"""Coil currents for a tip stiffness (issue 19 item 2: a stiffness target in real fields): the tip and
stiffness of a rod loaded from rest at known currents are designed back, and the stiffness checked by
shooting in magpylib's own field with the tip load moved either way; the exact derivative of the
stiffness in the currents against central differences of states from rest; the least power of a
stiffness alone against its Lagrange condition, by independent solves."""
import json
import math
from dataclasses import replace
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from actuator_design.cli.main import main
from actuator_design.config import load_config, load_scene
from actuator_design.equilibrium.pipeline import solve
from actuator_design.hardware.current_design import current_map, scene_at_currents
from actuator_design.hardware.current_map import at_weights
from actuator_design.hardware.current_stiffness import design_current_stiffness
from actuator_design.hardware.stiffness_map import StiffnessMap
from actuator_design.inverse.verify import stiffness_by_differences
from actuator_design.physics import parameters as lens
from actuator_design.robust.tolerances import apply_deltas
from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "coils_two_pairs_design.yaml"
GIVEN = np.array([3.0, 4.0])  # A, within the config's 8 A and 200 W
FIXED_MAGNET = Path(__file__).resolve().parents[1] / "configs" / "magnet_cylinder_hard_strip.yaml"


def _pair(radius, axis_deg, current, turns=200, centre=(10e-3, 0.0)):
    """A Helmholtz pair by hand: two loops of ``turns`` turns, ``radius`` apart along the axis."""
    a = math.radians(axis_deg)
    axis = Rotation.from_euler("z", a) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])
    return [magpy.current.Circle(diameter=2 * radius, current=turns * current, orientation=axis,
                                 position=(centre[0] + z * math.cos(a), centre[1] + z * math.sin(a), 0))
            for z in (-0.5 * radius, 0.5 * radius)]


def _reference(scene, currents):
    """The tip and stiffness at ``currents`` (None: the scene as it is): a solve from rest on the
    refitted field and central differences of two more solves."""
    sc = lens.parameter("p").require(scene if currents is None else scene_at_currents(scene, currents))
    r = solve(sc)
    assert r.success and r.stable, r.message
    return r, stiffness_by_differences(sc, r.options, r)


@pytest.fixture(scope="module")
def round_trip(tmp_path_factory):
    """The CLI designs back the tip and the stiffness (in N/m) of the rod at the currents GIVEN."""
    scene = load_scene(CONFIG)[0]
    r, k = _reference(scene, GIVEN)
    out = tmp_path_factory.mktemp("stiff")
    rc = main(["design", str(CONFIG), "--target-tip", f"{r.tip['x']!r},{r.tip['y']!r}",
               "--target-stiffness", f"{k * scene.scales.stiffness!r} N/m", "--json", "--out", str(out / "d")])
    return scene, r, k, rc, json.loads((out / "d" / "design.json").read_text())


def test_the_tip_and_stiffness_of_given_currents_are_designed_back_and_shooting_in_magpylibs_field_agrees(
        round_trip):
    scene, r, k, rc, d = round_trip
    assert rc == 0 and d["success"] and d["status"] == "success" and d["verified"] and d["holds_over_box"], d["message"]
    # two coils, three equations (x, y, K): the target fixes the currents
    assert np.allclose(d["currents_A"], GIVEN, rtol=1e-7)
    st = d["stiffness"]
    assert st["target"] == pytest.approx(k, rel=1e-12) and st["achieved"] == pytest.approx(k, rel=1e-8)
    assert st["verified"] == pytest.approx(k, rel=1e-6) and st["units"] == "B0/l^3"
    assert d["physical"]["achieved_stiffness_N_per_m"] == pytest.approx(k * scene.scales.stiffness, rel=1e-8)
    # every corner reports its stiffness: one of them against solves from rest on magpylib's field
    # refitted at its currents, with the mount turned
    assert len(d["box"]) == 8 and st["worst_error_over_box"] > 0
    corner = d["box"][-1]
    moved = replace(scene_at_currents(scene, corner["currents_A"]),
                    theta0=scene.theta0 + math.radians(corner["mount_deg"]))
    assert corner["stiffness"] == pytest.approx(_reference(moved, None)[1], rel=1e-6)
    # the stiffness by shooting in magpylib's field itself (no fit, no weights) at the designed
    # currents, the tip load moved by ±dp: dp/dv1 by central differences
    coils = _pair(60e-3, 0.0, d["currents_A"][0]) + _pair(50e-3, 90.0, d["currents_A"][1])
    field = field_from_function(lambda p: magpy.getH(coils, p, sumup=True), scene.scales.length, scene.scales.field)
    s = np.linspace(0, 1, 201)
    ev = r.evaluate(s)
    ys = []
    for dp in (1e-4, -1e-4):
        rod = FieldRod(field, h=scene.h, h_pos=scene.h_pos, h_r=0.0, alpha=0.0, beta=0.0, end_load=(0.0, dp))
        shot = solve_field_shooting(rod, guess_from_shape(rod, s, ev["theta"], ev["dtheta"][0], ev["x"], ev["y"]))
        ys.append(shot.tip[1])
    assert 2e-4 / (ys[0] - ys[1]) == pytest.approx(k, rel=1e-5)


@pytest.mark.parametrize("tip_load, theta0", [((0.0, 0.0), 0.0), ((0.3, 0.8), 0.4)])
def test_the_stiffness_derivative_in_the_currents_is_exact(tip_load, theta0):
    scene = replace(load_scene(CONFIG)[0], tip_force=tip_load, theta0=theta0)
    cmap, _ = current_map(scene, None)
    smap = StiffnessMap(cmap, 10.0, 0)
    w = GIVEN / 2.0
    pt = smap.evaluate(w)
    assert pt["stiffness"] == pytest.approx(stiffness_by_differences(at_weights(scene, w), cmap.options,
                                                                     cmap.result(w, pt["z"])), rel=1e-7)
    dlog = pt["tip_jac"][0]  # d log(c K_target)/dw
    for j in range(2):
        e = np.zeros(2)
        e[j] = 1e-4
        c = [1.0 / smap.evaluate(w + sg * e)["stiffness"] for sg in (1, -1)]  # states from rest there
        assert dlog[j] == pytest.approx((math.log(c[0]) - math.log(c[1])) / 2e-4, rel=1e-6)


def test_a_corner_with_youngs_modulus_moved_reports_the_stiffness_in_the_nominal_units():
    # the corner's scene is solved in its own units (b = 1 with E moved): its stiffness is brought
    # back to B0/l^3; the reference is the rod made of the stiffer material, in N/m
    raw = yaml.safe_load(CONFIG.read_text())
    raw["scene"]["rod"]["youngs_modulus"] = "1.1 MPa"
    stiffer = load_config(raw).to_scene()
    scene = lens.parameter("p").require(load_scene(CONFIG)[0])
    cmap, _ = current_map(scene, None)
    smap = StiffnessMap(cmap, 10.0, 0)
    w = GIVEN / 2.0
    corner = cmap.corner(apply_deltas(at_weights(scene, w), {"youngs_rel": 0.1}), smap.evaluate(w)["z"])
    k = smap.corner_stiffness(corner, {"youngs_rel": 0.1})["stiffness"] * scene.scales.stiffness
    assert k == pytest.approx(_reference(stiffer, GIVEN)[1] * stiffer.scales.stiffness, rel=1e-6)


@pytest.mark.slow  # a whole design (~25 s) and 12 forward solves
def test_a_stiffness_alone_spends_the_least_power_its_lagrange_condition_holds():
    scene = load_scene(CONFIG)[0]
    d = design_current_stiffness(scene, 6.0)
    assert d.success and d.least_effort and d.effort == "power" and math.isnan(d.tip_error), d.message
    assert d.achieved_stiffness == pytest.approx(6.0, rel=1e-8)
    assert d.verification["stiffness"] == pytest.approx(6.0, rel=1e-6)
    # at the least power on the curve K(I) = 6 the power's gradient is parallel to K's; K's by
    # central differences of independent solves from rest at the currents moved by ±0.01 A
    I = np.array(d.currents)
    grad_k = []
    for j in range(2):
        e = np.zeros(2)
        e[j] = 1e-2
        grad_k.append((_reference(scene, I + e)[1] - _reference(scene, I - e)[1]) / 2e-2)
    grad_p = np.array([2 * 2.5 * I[0], 2 * 2.0 * I[1]])
    cross = grad_p[0] * grad_k[1] - grad_p[1] * grad_k[0]
    assert abs(cross) <= 1e-4 * np.linalg.norm(grad_p) * np.linalg.norm(grad_k)
    assert d.power == pytest.approx(2.5 * I[0] ** 2 + 2.0 * I[1] ** 2, rel=1e-12)


@pytest.mark.slow  # a whole design (~25 s)
def test_a_stiffness_beyond_the_current_limits_is_unreachable_and_says_so(tmp_path, capsys):
    # the stiffness grows with the field; at 8 A on both coils it stays far below 1000 B0/l^3
    rc = main(["design", str(CONFIG), "--target-stiffness", "1000", "--json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 4 and not d["success"] and d["status"] == "unreachable"
    assert "nearest found" in d["message"] and "at the limit" in d["message"]
    assert d["stiffness"]["achieved"] < 1000


@pytest.mark.parametrize("argv_tail, words", [
    (["--target-stiffness", "5", "--vary", "h"], "--vary"),
    (["--target-stiffness", "5", "--h-max", "3"], "--h-max"),
    (["--target-stiffness", "0"], "--target-stiffness"),
    (["--target-stiffness", "5", "--target-tip", "0.8,0.5;0.7,0.6"], "--target-stiffness"),
])
def test_flags_that_do_not_apply_are_refused_in_one_line(tmp_path, capsys, argv_tail, words):
    rc = main(["design", str(CONFIG), *argv_tail, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and words in err[0] and not (tmp_path / "o").exists()


def test_a_fixed_magnet_for_a_stiffness_is_refused_naming_what_can(capsys):
    rc = main(["design", str(FIXED_MAGNET), "--target-stiffness", "5"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "or a stiffness (`--target-stiffness K`" in err[0]


def test_the_python_api_refuses_a_stiffness_that_is_not_positive():
    scene = load_scene(CONFIG)[0]
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="stiffness target"):
            design_current_stiffness(scene, bad)
