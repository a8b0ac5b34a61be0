"""A magnet's pose in time (issue 19 item 2: `schedule` over a magnet's pose): a hard-magnetic strip
and a cylinder magnet on a stage (configs/magnet_pose_design.yaml). The waypoints are the tips of
two poses from independent fits of the magnet placed there; the scheduled poses are checked by a
shooting solver in magpylib's field of a magnet built here at each waypoint's pose, against the
stage's travel and rates step by step, and against the poses that made the waypoints (no larger a
move in time); bad requests end in one line."""
import json
import math
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from actuator_design.hardware.pose_problem import scene_at_pose
from actuator_design.cli.main import main
from actuator_design.config import load_scene
from actuator_design.equilibrium.pipeline import solve
from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "magnet_pose_design.yaml"
MU0 = 4e-7 * math.pi
#: the poses that make the waypoints: (x, y) m, axis angle rad
POSES = (((22e-3, -14e-3), math.radians(110.0)), ((18e-3, -13e-3), math.radians(130.0)))
SPEED, TURN = 10e-3, math.radians(90.0)  # m/s, rad/s


def _cylinder(position, axis_angle):
    """The config's magnet by hand: 10 mm × 10 mm, B_r = 1.2 T along its axis, in the plane."""
    turn = Rotation.from_euler("z", axis_angle) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])  # local z → axis
    return magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                 position=(position[0], position[1], 0.0), orientation=turn)


@pytest.mark.slow
def test_the_scheduled_poses_put_the_tip_on_every_waypoint_within_the_stages_limits(tmp_path, capsys):
    scene = load_scene(CONFIG)[0]
    waypoints = []
    for pos, angle in POSES:
        made = solve(scene_at_pose(scene, pos, angle))  # an independent fit of the magnet placed there
        waypoints.append((made.tip["x"], made.tip["y"]))
    text = ";".join(f"{x!r},{y!r}" for x, y in waypoints)
    code = main(["schedule", str(CONFIG), "--waypoints", text, "--stage-speed", "10mm/s", "--turn-rate", "90deg/s",
                 "--substeps", "4", "--json", "--out", str(tmp_path / "out")])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["success"], out["message"]
    assert {"schedule.json", "schedule.csv", "waypoints.csv", "schedule.png"} <= {p.name for p in (tmp_path / "out").iterdir()}
    steps = out["schedule"]
    x, y = np.array([s["x_mm"] for s in steps]) * 1e-3, np.array([s["y_mm"] for s in steps]) * 1e-3
    a, t = np.radians([s["axis_angle_deg"] for s in steps]), np.array([s["time_s"] for s in steps])
    # within the travel, and every step no faster than the stage: the slowest axis at its rate
    assert np.all((10e-3 <= x) & (x <= 40e-3) & (-30e-3 <= y) & (y <= -12e-3))
    dt = np.diff(t)
    use = np.max([np.abs(np.diff(x)) / SPEED, np.abs(np.diff(y)) / SPEED, np.abs(np.diff(a)) / TURN], axis=0)
    assert np.allclose(use, dt, rtol=1e-12, atol=0) and np.all(dt > 0)
    # each waypoint's pose puts the tip there in magpylib's field (shooting, no fit)
    length, h0 = scene.scales.length, scene.scales.field
    for row, wp in zip(out["rows"], waypoints):
        pos, angle = (row["x_mm"] * 1e-3, row["y_mm"] * 1e-3), math.radians(row["axis_angle_deg"])
        magnet = _cylinder(pos, angle)
        rod = FieldRod(field_from_function(lambda p: magpy.getH(magnet, p), length, h0), h_r=scene.h_r)
        guess = solve(scene_at_pose(scene, pos, angle))
        s = np.linspace(0, 1, 201)
        st = guess.evaluate(s)
        shot = solve_field_shooting(rod, guess_from_shape(rod, s, st["theta"], st["dtheta"][0], st["x"], st["y"]))
        assert np.max(np.abs(np.array(shot.tip[:2]) - wp)) <= 1e-6, (shot.tip, wp)
    # the first waypoint's pose is reached no later (in the least-squares time the search minimises)
    # than the pose that made it
    first = out["rows"][0]
    ours = [(first["x_mm"] * 1e-3 - 25e-3) / SPEED, (first["y_mm"] * 1e-3 + 15e-3) / SPEED,
            (math.radians(first["axis_angle_deg"]) - math.pi / 2) / TURN]
    (mx, my), ma = POSES[0]
    theirs = [(mx - 25e-3) / SPEED, (my + 15e-3) / SPEED, (ma - math.pi / 2) / TURN]
    assert np.dot(ours, ours) <= np.dot(theirs, theirs) * (1 + 1e-6)


@pytest.mark.parametrize("argv, message", [
    (["--waypoints", "0.96,0.25;0.97,0.2", "--turn-rate", "90deg/s"], "--stage-speed: a schedule over a magnet's pose needs"),
    (["--waypoints", "0.96,0.25;0.97,0.2", "--stage-speed", "10mm/s"], "--turn-rate: a schedule over a magnet's pose needs"),
    (["--waypoints", "0.96,0.25;0.97,0.2", "--stage-speed", "10mm", "--turn-rate", "90deg/s"], "--stage-speed: expected a speed"),
    (["--waypoints", "0.96,0.25;0.97,0.2", "--stage-speed=-1mm/s", "--turn-rate", "90deg/s"], "--stage-speed: must be > 0"),
    (["--waypoints", "0.96,0.25;0.97,0.2", "--stage-speed", "10mm/s", "--turn-rate", "90deg/s", "--slew-rate", "2A/s"],
     "--slew-rate: only for a scene whose field comes from coils"),
    (["--waypoints", "0.96,0.25;0.97,0.2", "--stage-speed", "10mm/s", "--turn-rate", "90deg/s", "--rate", "1mT/s"],
     "--rate: the scene's magnet has a travel"),
])
def test_bad_pose_schedule_requests_are_one_line(argv, message, capsys):
    assert main(["schedule", str(CONFIG)] + argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_stage_rates_on_a_scene_without_a_moving_magnet_are_refused(capsys):
    other = CONFIG.parent / "magnet_cylinder_hard_strip.yaml"
    assert main(["schedule", str(other), "--waypoints", "0.9,0.3;0.9,0.35", "--stage-speed", "10mm/s"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--stage-speed: only for a scene whose magnet has a travel" in err[0], err


def test_a_turntable_that_turns_without_end_turns_the_short_way_and_a_limited_one_does_not():
    from types import SimpleNamespace

    from actuator_design.schedules.pose_schedule import _short_way, _whole_turn, _within_turn

    whole = SimpleNamespace(coords=(0, 2), lower=np.array([-1.0, -math.pi]), upper=np.array([1.0, math.pi]))
    limited = SimpleNamespace(coords=(0, 2), lower=np.array([-1.0, -1.0]), upper=np.array([1.0, 3.0]))
    assert _whole_turn(whole) == 1 and _whole_turn(limited) is None
    prev = np.array([0.2, math.radians(170.0)])
    nxt = _short_way(_whole_turn(whole), np.array([0.3, math.radians(-170.0)]), prev)
    assert nxt[0] == 0.3 and math.degrees(nxt[1]) == pytest.approx(190.0, abs=1e-12)  # +20 deg, not -340
    assert math.degrees(_within_turn(whole, 1, nxt)[1]) == pytest.approx(-170.0, abs=1e-12)
    same = _short_way(_whole_turn(limited), np.array([0.3, -0.9]), np.array([0.2, 2.9]))
    assert same.tolist() == [0.3, -0.9]
