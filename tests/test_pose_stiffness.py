"""A magnet's pose for a tip stiffness (issue 19 item 2: a stiffness target in real fields): the tip
and stiffness a known pose gives are designed back, and the stiffness checked by shooting in
magpylib's own field with the tip load moved either way; a stiffness alone takes the least move
among the poses that give it."""
import json
import math
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from actuator_design.cli.main import main
from actuator_design.config import load_scene
from actuator_design.equilibrium.pipeline import solve
from actuator_design.hardware.pose_design import pose_map
from actuator_design.hardware.pose_problem import pose_problem, scene_at_pose
from actuator_design.hardware.stiffness_map import StiffnessMap
from actuator_design.hardware.pose_stiffness import design_pose_stiffness
from actuator_design.inverse.verify import stiffness_by_differences
from actuator_design.physics import parameters as lens
from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "magnet_pose_design.yaml"
MU0 = 4e-7 * math.pi
#: the pose that makes the target: (x, y) m, axis angle rad (the configured one: (25, -15) mm, 90 deg)
MADE_BY = ((22e-3, -14e-3), math.radians(110.0))
#: each coordinate's half travel (the config's x 10..40 mm, y -30..-12 mm, angle a whole turn)
HALF = (15e-3, 9e-3, math.pi)


def _cylinder(position, axis_angle):
    """The config's magnet by hand: 10 mm × 10 mm, B_r = 1.2 T along its axis, in the plane."""
    turn = Rotation.from_euler("z", axis_angle) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])
    return magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                 position=(position[0], position[1], 0.0), orientation=turn)


def _move(position, axis_angle):
    start = ((25e-3, -15e-3), math.radians(90.0))
    deltas = (position[0] - start[0][0], position[1] - start[0][1], axis_angle - start[1])
    return sum((d / h) ** 2 for d, h in zip(deltas, HALF))


@pytest.fixture(scope="module")
def made():
    """The tip and the stiffness (central differences of independent solves) the pose MADE_BY gives,
    on magpylib's field fitted anew there."""
    scene = load_scene(CONFIG)[0]
    sc = lens.parameter("p").require(scene_at_pose(scene, *MADE_BY))
    r = solve(sc)
    assert r.success and r.stable, r.message
    return scene, r, stiffness_by_differences(sc, r.options, r)


@pytest.mark.slow  # a whole pose design (~60 s)
def test_the_tip_and_stiffness_of_a_pose_are_designed_back_and_shooting_in_magpylibs_field_agrees(made, tmp_path):
    scene, r, k = made
    rc = main(["design", str(CONFIG), "--target-tip", f"{r.tip['x']!r},{r.tip['y']!r}",
               "--target-stiffness", f"{k * scene.scales.stiffness!r} N/m", "--json", "--out", str(tmp_path / "d")])
    d = json.loads((tmp_path / "d" / "design.json").read_text())
    assert rc == 0 and d["success"] and d["verified"] and d["holds_over_box"], d["message"]
    # three equations (x, y, K), three coordinates: the pose that made them, to the field fits'
    # accuracy (the tips within reach form a thin band: a pose is fixed only to micrometres there)
    assert np.allclose(d["position_mm"], [22.0, -14.0], atol=0.02)
    assert d["axis_angle_deg"] == pytest.approx(110.0, abs=0.05)
    st = d["stiffness"]
    assert st["achieved"] == pytest.approx(k, rel=1e-6) and st["verified"] == pytest.approx(k, rel=1e-6)
    assert len(d["box"]) == 16 and st["worst_error_over_box"] > 0
    # the designed pose in magpylib's field itself (no fit), by shooting with the tip load ±dp
    magnet = _cylinder([v * 1e-3 for v in d["position_mm"]], math.radians(d["axis_angle_deg"]))
    field = field_from_function(lambda p: magpy.getH(magnet, p), scene.scales.length, scene.scales.field)
    grid = np.linspace(0, 1, 201)
    ev = r.evaluate(grid)
    ys = []
    for dp in (1e-4, -1e-4):
        rod = FieldRod(field, h=0.0, h_pos=0.0, h_r=scene.h_r, alpha=0.0, beta=0.0, end_load=(0.0, dp))
        shot = solve_field_shooting(rod, guess_from_shape(rod, grid, ev["theta"], ev["dtheta"][0], ev["x"], ev["y"]))
        ys.append(shot.tip[1])
    assert 2e-4 / (ys[0] - ys[1]) == pytest.approx(k, rel=1e-5)


@pytest.mark.slow  # a whole pose design (~40 s)
def test_a_stiffness_alone_moves_the_magnet_no_more_than_the_pose_that_gives_it(made):
    scene, r, k = made
    d = design_pose_stiffness(scene, k)
    assert d.success and d.least_move and math.isnan(d.tip_error), d.message
    assert d.achieved_stiffness == pytest.approx(k, rel=1e-8)
    assert d.verification["stiffness"] == pytest.approx(k, rel=1e-6)
    # the pose that made the stiffness gives it too: the design moves the magnet no more
    assert d.move == pytest.approx(_move(d.position, d.axis_angle), rel=1e-9)
    assert d.move < _move(*MADE_BY)
    assert d.to_dict()["stiffness"]["target"] == k


@pytest.mark.slow  # the pose map (a magnet fitted to order 120) and 7 states from rest
def test_the_stiffness_derivative_in_the_pose_is_exact():
    scene = lens.parameter("p").require(load_scene(CONFIG)[0]).with_values(p=-0.5)
    var, _ = pose_problem(scene, (0.9, 0.3))
    pmap, _ = pose_map(scene, var, None)
    smap = StiffnessMap(pmap, 5.0, 0)
    v = np.array([-0.1, 0.05, 0.2])  # the magnet moved by (-2, 1) mm (rod lengths of 20 mm) and turned by 0.2 rad
    dlog = smap.evaluate(v)["tip_jac"][0]  # d log(c K_target)/dv
    for j, step in enumerate((1e-5, 1e-5, 1e-4)):  # rod lengths, rod lengths, rad
        e = np.zeros(3)
        e[j] = step
        c = [1.0 / smap.evaluate(v + sg * e)["stiffness"] for sg in (1, -1)]  # states from rest there
        assert dlog[j] == pytest.approx((math.log(c[0]) - math.log(c[1])) / (2 * step), rel=1e-5)


def test_the_python_api_refuses_bad_requests_in_one_line():
    scene = load_scene(CONFIG)[0]
    with pytest.raises(ValueError, match="stiffness target"):
        design_pose_stiffness(scene, -2.0)
    with pytest.raises(ValueError, match="the target is x, y"):
        design_pose_stiffness(scene, 2.0, (0.5,))
    with pytest.raises(ValueError, match="position tolerance"):
        design_pose_stiffness(scene, 2.0, position_tolerance=1.0)
