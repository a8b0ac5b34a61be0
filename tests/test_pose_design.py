"""A magnet's pose as the design (issue 19 item 2): a hard-magnetic strip and a cylinder magnet on a
stage (configs/magnet_pose_design.yaml). The moved fit is checked against magpylib's field of the
magnet moved by hand; the map's implicit derivatives against finite differences of states from
rest; the designed pose against an independent shooting solver in magpylib's field of a magnet
built here at that pose, against the pose that made the target (no larger a move), and for
first-order optimality; bad requests end in one line."""
import json
import math
from dataclasses import replace
from pathlib import Path

import casadi as ca
import magpylib as magpy
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from actuator_design.hardware.current_sqp import CurrentProblem
from actuator_design.hardware.map import HardwareMap
from actuator_design.hardware.pose_design import _active, design_pose
from actuator_design.hardware.pose_problem import PoseVariables, at_pose, clearance, pose_problem, scene_at_pose
from actuator_design.robust.tolerances import Tolerances
from actuator_design.cli.main import main
from actuator_design.config import load_scene
from actuator_design.config.errors import ConfigError
from actuator_design.equilibrium.pipeline import solve
from actuator_design.physics.fields import field_model
from actuator_design.physics.harmonic import field_function
from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
CONFIG = CONFIGS / "magnet_pose_design.yaml"
MU0 = 4e-7 * math.pi
#: the pose that makes the target: (x, y) m, axis angle rad
MADE_BY = ((22e-3, -14e-3), math.radians(110.0))


def _cylinder(position, axis_angle):
    """The config's magnet by hand: 10 mm × 10 mm, B_r = 1.2 T along its axis, in the plane."""
    turn = Rotation.from_euler("z", axis_angle) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])  # local z → axis
    return magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                 position=(position[0], position[1], 0.0), orientation=turn)


@pytest.fixture(scope="module")
def scene():
    return load_scene(CONFIG)[0]


def test_a_moved_fit_is_magpylibs_field_of_the_moved_magnet(scene):
    f, length, h0 = scene.field, scene.scales.length, scene.scales.field
    model = field_model(f)
    rng = np.random.default_rng(7)
    for dx, dy, turn in ((0.0, 0.0, 0.0), (-0.2, 0.1, 0.4), (0.5, -0.5, -2.5), (-0.6, 0.15, 3.0)):
        placed = replace(f, placements=((dx, dy, turn),))
        t = placed.placed_terms()[0]
        pts = rng.uniform(-1.0, 1.0, (4000, 2))
        pts = pts[(np.hypot(*pts.T) <= 1.0) & t.contains(pts[:, 0], pts[:, 1])][:300]
        ours = model.evaluate(pts[:, 0], pts[:, 1], model.parameter_values(placed)).T
        pos = (0.025 + dx * length, -0.015 + dy * length)
        theirs = magpy.getH(_cylinder(pos, math.pi / 2 + turn), np.column_stack([pts * length, 0 * pts[:, 0]]))[:, :2] / h0
        assert np.max(np.linalg.norm(ours - theirs, axis=1)) <= 1e-6, (dx, dy, turn)
        # the moved parameters are the expansion about the moved centre and axis, which is a solid
        # harmonic: its divergence and curl in three dimensions vanish to round-off
        moved = field_function((t,), with_z=True)
        assert np.allclose(np.array([[float(v) for v in moved(x, y, 0.0)[:2]] for x, y in pts[:20]]), ours[:20],
                           rtol=1e-12, atol=1e-12)
        r = ca.SX.sym("r", 3)
        h = ca.vertcat(*moved(r[0], r[1], r[2]))
        J = ca.Function("J", [r], [ca.jacobian(h, r)])
        for x, y in pts[:20]:
            g = np.array(J([x, y, 0.05]))
            assert abs(np.trace(g)) <= 1e-9 * np.abs(g).max() and np.abs(g - g.T).max() <= 1e-9 * np.abs(g).max()
    # unmoved, the numbers are the fit's own to the last bit
    pts = rng.uniform(-1.0, 1.0, (50, 2))
    pts = pts[f.terms[0].contains(pts[:, 0], pts[:, 1])]
    direct = np.array([[float(v) for v in field_function(f.terms)(x, y)] for x, y in pts])
    assert np.array_equal(model.evaluate(pts[:, 0], pts[:, 1], {}).T, direct)


def test_a_magnet_with_travel_is_fitted_down_to_next_to_its_body(scene):
    travel_fit = scene.field.terms[0]
    fixed = load_scene(CONFIGS / "magnet_cylinder_hard_strip.yaml")[0].field.terms[0]  # the same magnet, fixed
    rv = math.hypot(5e-3, 5e-3) / scene.scales.length  # the sphere holding the cylinder
    assert travel_fit.valid_radius <= 1.25 * rv < fixed.valid_radius


def test_the_pose_maps_derivatives_are_finite_differences_of_states_from_rest(scene):
    var, prob = pose_problem(scene, (0.96, 0.25))
    at = at_pose(var)
    v = np.array([-0.1, 0.05, 0.3])
    pmap = HardwareMap(scene, solve(at(scene, v)), v, var.names, at, clearance(scene, var))
    pt = pmap.evaluate(v)
    for k, step in enumerate((1e-5, 1e-5, 1e-5)):
        e = np.zeros(3)
        e[k] = step
        plus, minus = pmap.evaluate(v + e), pmap.evaluate(v - e)
        assert np.allclose(pt["tip_jac"][:, k], (plus["tip"] - minus["tip"]) / (2 * step), rtol=1e-5, atol=1e-8)
        assert np.allclose(pt["limit_jac"][:, k], (plus["limit"] - minus["limit"]) / (2 * step), rtol=1e-5, atol=1e-8)


@pytest.fixture(scope="module")
def designed(scene):
    made = solve(scene_at_pose(scene, *MADE_BY))  # an independent fit of the magnet placed there
    target = (made.tip["x"], made.tip["y"])
    return target, design_pose(scene, target)


@pytest.mark.slow  # the pose design fixture takes ~55 s; the default run keeps the CI budget
def test_the_designed_pose_puts_the_tip_on_the_target_by_shooting_in_magpylibs_field(scene, designed):
    target, d = designed
    assert d.success and d.verified and d.holds_over_box and d.least_move, d.message
    assert 10e-3 <= d.position[0] <= 40e-3 and -30e-3 <= d.position[1] <= -12e-3
    length, h0 = scene.scales.length, scene.scales.field
    magnet = _cylinder(d.position, d.axis_angle)
    field = field_from_function(lambda p: magpy.getH(magnet, p), length, h0)
    rod = FieldRod(field, h=0.0, h_pos=0.0, h_r=scene.h_r, alpha=0.0, beta=0.0)
    s = np.linspace(0, 1, 201)
    st = d.state.evaluate(s)
    shot = solve_field_shooting(rod, guess_from_shape(rod, s, st["theta"], st["dtheta"][0], st["x"], st["y"]))
    assert np.max(np.abs(np.array(shot.tip[:2]) - target)) <= 1e-6, shot.tip
    # the field reported at the clamp is magpylib's there
    b = magpy.getB(magnet, (0.0, 0.0, 0.0))
    assert d.field_at_clamp[0] == pytest.approx(math.hypot(b[0], b[1]), rel=1e-6)


@pytest.mark.slow  # the pose design fixture takes ~55 s; the default run keeps the CI budget
def test_the_designed_pose_moves_no_more_than_the_pose_that_made_the_target_nor_its_neighbours(scene, designed):
    target, d = designed
    var, prob = pose_problem(scene, target)
    (x, y), a = MADE_BY
    made = np.array([(x - 25e-3) / scene.scales.length, (y + 15e-3) / scene.scales.length, a - math.pi / 2])
    assert d.move <= float(np.dot(prob.cost, made ** 2)) * (1 + 1e-6)
    # no limit is active: the target's solution set is a curve through the design; its neighbours
    # on it both ways (a step along the tangent, brought back onto the target by Newton's method on
    # the tip equations, which never sees the effort) move the magnet no less
    assert not d.limits_active
    v = np.array([(d.position[0] - 25e-3) / scene.scales.length, (d.position[1] + 15e-3) / scene.scales.length,
                  d.axis_angle - math.pi / 2])
    at = at_pose(var)
    pmap = HardwareMap(scene, solve(at(scene, v)), v, var.names, at, clearance(scene, var))
    tangent = np.linalg.svd(pmap.evaluate(v)["tip_jac"][:2])[2][-1]
    for sign in (1.0, -1.0):
        u = v + sign * 0.02 * tangent
        for _ in range(30):
            p = pmap.evaluate(u)
            e = p["tip"][:2] - np.asarray(target)
            if np.max(np.abs(e)) <= 1e-10:
                break
            u = u - np.linalg.pinv(p["tip_jac"][:2]) @ e
        assert np.max(np.abs(e)) <= 1e-10
        assert float(np.dot(prob.cost, u ** 2)) >= d.move * (1 - 1e-9)
        assert np.max(np.abs(u - v)) > 1e-3  # a neighbour indeed


def _one_axis(tmp_path, **travel):
    raw = yaml.safe_load(CONFIG.read_text())
    raw["scene"]["field"]["travel"] = travel
    path = tmp_path / "magnet.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_a_target_off_the_band_is_unreachable_with_the_nearest_tip_in_json(tmp_path, capsys):
    path = _one_axis(tmp_path, x=["20 mm", "30 mm"])
    assert main(["design", str(path), "--target-tip", "0.9,0.4", "--json"]) == 4
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "unreachable" and not out["success"]
    assert 20 <= out["position_mm"][0] <= 30 and out["position_mm"][1] == pytest.approx(-15)
    assert out["axis_angle_deg"] == pytest.approx(90) and "travel" in out and "x_mm" in out["travel"]
    for key in ("start_position_mm", "move", "tip", "tip_error", "field_at_clamp_mT", "limits_active", "time_s"):
        assert key in out
    assert out["tip_error"] > 1e-3


@pytest.mark.parametrize("travel, words", [
    ({"x": ["30 mm", "20 mm"]}, "scene.field.travel.x: the range must be [low, high] with low < high, got [30 mm, 20 mm]"),
    ({"y": ["-30 mm", "-20 mm"]}, "scene.field.travel.y: the configured position y (-15 mm) lies outside"),
    ({"angle": ["0 deg", "400 deg"]}, "scene.field.travel.angle: the range spans more than 360 deg"),
    ({}, "scene.field.travel: give at least one of x, y, angle"),
    ({"x": ["20 mm"]}, "scene.field.travel.x"),
    ({"z": ["0 mm", "1 mm"]}, "scene.field.travel.z: unknown key (allowed: x, y, angle)"),
    ({"angle": ["100 deg", "180 deg"]}, "scene.field.travel.angle: the configured axis_angle (90 deg) lies outside"),
])
def test_a_bad_travel_names_the_field(tmp_path, travel, words):
    with pytest.raises(ConfigError) as err:
        load_scene(_one_axis(tmp_path, **travel))
    assert words in str(err.value), str(err.value)


def test_an_axis_angle_is_the_same_a_turn_apart_and_a_whole_turn_is_both_ways_about_it(tmp_path):
    from actuator_design.hardware.pose_problem import angle_offsets, pose_variables

    raw = yaml.safe_load(CONFIG.read_text())
    raw["scene"]["field"]["axis_angle"] = "270 deg"  # = -90 deg, inside [-180, 180]
    path = tmp_path / "turned.yaml"
    path.write_text(yaml.safe_dump(raw))
    var = pose_variables(load_scene(path)[0])
    assert var.lower[2] == pytest.approx(-math.pi) and var.upper[2] == pytest.approx(math.pi)  # the short way
    lo, hi = angle_offsets((math.radians(-180), math.radians(-100)), math.radians(200))  # 200 = -160 deg
    assert (math.degrees(lo), math.degrees(hi)) == pytest.approx((-20.0, 60.0))


@pytest.mark.parametrize("argv, words", [
    (["--vary", "h"], "--vary: on this scene the design varies the magnet's pose"),
    (["--h-max", "3"], "--h-max: does not apply to a design over the magnet's pose"),
    (["--position-tolerance", "banana"], "error: --position-tolerance: expected a number with a unit"),
    (["--position-tolerance", "nan mm"], "error: --position-tolerance: must be a finite number"),
    (["--position-tolerance", "5 mm"], "--position-tolerance: must be in [0, 2 mm]"),
])
def test_flags_that_do_not_apply_are_refused_in_one_line(argv, words, capsys):
    assert main(["design", str(CONFIG), "--target-tip", "0.96,0.25", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err


def test_a_position_tolerance_on_coils_is_refused(capsys):
    assert main(["design", str(CONFIGS / "coils_two_pairs_design.yaml"), "--target-tip", "0.83,0.5",
                 "--position-tolerance", "1 mm"]) == 2
    assert "magnet's pose" in capsys.readouterr().err


@pytest.mark.slow  # the pose design fixture takes ~55 s; the default run keeps the CI budget
def test_the_box_moves_the_magnet_turns_its_axis_and_scales_its_remanence(scene, designed):
    _, d = designed
    assert d.tolerances == Tolerances()
    offsets = [c["offsets"] for c in d.box]
    axes = ("dx_mm", "dy_mm", "remanence_rel", "turn_deg")
    assert len(d.box) == 2 ** len(axes) and {tuple(sorted(o)) for o in offsets} == {axes}
    assert {(o["dx_mm"], o["dy_mm"], o["turn_deg"], o["remanence_rel"]) for o in offsets} == {
        (a, b, c, e) for a in (-0.5, 0.5) for b in (-0.5, 0.5) for c in (-2.0, 2.0) for e in (-0.05, 0.05)}
    payload = d.to_dict()["tolerances"]
    assert payload["position_mm"] == 0.5 and payload["axis_deg"] == pytest.approx(2.0)


def test_the_maps_pointwise_derivatives_hold_for_several_values_a_point(scene):
    var, _ = pose_problem(scene, (0.96, 0.25))
    at = at_pose(var)
    v = np.array([-0.1, 0.05, 0.3])
    three = lambda x, y, w: ca.vertcat(x * w[0], y * y + w[2], x * y * w[1])
    pmap = HardwareMap(scene, solve(at(scene, v)), v, var.names, at, three)
    pt = pmap.evaluate(v)
    assert pt["limit"].size == 3 * pt["limit_jac"].shape[0] // 3 and pt["limit_jac"].shape[1] == 3
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-5
        fd = (pmap.evaluate(v + e)["limit"] - pmap.evaluate(v - e)["limit"]) / 2e-5
        assert np.allclose(pt["limit_jac"][:, k], fd, rtol=1e-5, atol=1e-8)
    # the values, point by point, are the function's at the quadrature points
    z = pt["z"]
    xq, yq, _, _ = (np.asarray(a, float).ravel() for a in pmap._points(z))
    assert np.allclose(pt["limit"].reshape(-1, 3), np.column_stack([xq * v[0], yq ** 2 + v[2], xq * yq * v[1]]))


def test_optimality_weighs_bounds_and_limits_by_their_sign():
    from actuator_design.hardware.current_sqp import CurrentProblem, _stationary

    prob = CurrentProblem(target=np.array([0.0]), cost=np.ones(2), bound=np.ones(2), max_limit=1.0, tip_tol=1e-7,
                          lower=-np.ones(2), upper=np.ones(2), centre=np.zeros(2))
    tip_y = np.array([[0.0, 1.0], [0, 0], [0, 0]])  # the tip depends on the second unknown only
    at_bound = {"tip": np.zeros(3), "tip_jac": tip_y, "limit": np.array([0.5]), "limit_jac": np.zeros((1, 2))}
    assert not _stationary(prob, np.array([1.0, 0.0]), at_bound)  # x at its upper bound: moving it back is free
    assert _stationary(prob, np.array([0.0, 0.0]), at_bound)
    pushing = {"tip": np.zeros(3), "tip_jac": tip_y, "limit": np.array([1.0]), "limit_jac": np.array([[1.0, 0.0]])}
    assert not _stationary(prob, np.array([0.5, 0.0]), pushing)  # lowering x lowers both: not held by the limit
    holding = dict(pushing, limit_jac=np.array([[-1.0, 0.0]]))
    assert _stationary(prob, np.array([0.5, 0.0]), holding)  # the limit stops x from falling


def test_a_whole_turn_of_travel_has_no_end_but_the_searchs_seam_is_named():
    """Travel angle over a whole turn: an answer 180 deg from the configured axis sits at the seam of
    the search's window, not at a limit of the stage; the limits list says so (it said 'travel
    angle at the limit' of a stage that turns freely)."""
    var = PoseVariables(0, (0, 2), np.array([-0.5, -math.pi]), np.array([1.0, math.pi]), 0.02)
    half = (var.upper - var.lower) / 2
    prob = CurrentProblem(target=np.zeros(2), cost=1 / half ** 2, bound=half, max_limit=1.0, lower=var.lower,
                          upper=var.upper, centre=np.zeros(2))
    seam = _active(var, prob, np.array([0.2, math.pi]), {"limit": np.array([0.5])})
    assert len(seam) == 1 and "seam" in seam[0] and "travel" not in seam[0]
    assert _active(var, prob, np.array([1.0, 0.3]), {"limit": np.array([0.5])}) == ["travel x"]
