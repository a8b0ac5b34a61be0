"""A tip path with a tolerance (issue 19 item 3): the waypoints read as a polyline the replayed tip
must stay near. The distance is checked against a brute-force sampling of the polyline; the
schedule's verdict against the replayed tips of the API's own schedule; bad tolerances end in one
line."""
import json
from pathlib import Path

import numpy as np
import pytest

from actuator_design.schedules.path_corridor import distance_to_path
from actuator_design.schedules.schedule import field_schedule
from actuator_design.cli.main import main
from actuator_design.config import load_scene

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "study_design_schedule.yaml"
WAYPOINTS = [(0.985, 0.161), (0.935, 0.326), (0.861, 0.465), (0.782, 0.563)]


def test_the_distance_to_a_polyline_is_the_nearest_of_its_dense_samples():
    rng = np.random.default_rng(2)
    poly = rng.uniform(-1, 1, (5, 2))
    pts = rng.uniform(-1.5, 1.5, (200, 2))
    t = np.linspace(0, 1, 20001)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(poly[:-1], poly[1:])])
    brute = np.min(np.linalg.norm(pts[:, None, :] - dense[None], axis=2), axis=1)
    assert np.max(np.abs(distance_to_path(pts, poly) - brute)) < 1e-4 * np.max(np.linalg.norm(np.diff(poly, axis=0), axis=1))
    assert distance_to_path([[3.0, 4.0]], [[0.0, 0.0]])[0] == 5.0  # one waypoint: the distance to it
    assert distance_to_path([[1.0, 1.0]], [[0.0, 0.0], [0.0, 0.0], [2.0, 0.0]])[0] == 1.0  # a repeated waypoint


@pytest.mark.parametrize("tolerance, code", [(0.02, 0), (1e-4, 3)])
def test_a_schedule_held_to_its_path_within_and_beyond_the_tolerance(tolerance, code, capsys):
    assert main(["schedule", str(CONFIG), "--path-tolerance", str(tolerance), "--json"]) == code
    out = json.loads(capsys.readouterr().out)
    # the replayed tips of the same schedule, from the API, measured here by brute force
    res = field_schedule(WAYPOINTS, scene=load_scene(CONFIG)[0], substeps=8)
    start = res.waypoint_index[0]
    tips = np.array([[s.tip["x"], s.tip["y"]] for s in res.states[start:]])
    t = np.linspace(0, 1, 20001)[:, None]
    w = np.array(WAYPOINTS)
    dense = np.concatenate([a + t * (b - a) for a, b in zip(w[:-1], w[1:])])
    largest = float(np.max(np.min(np.linalg.norm(tips[:, None, :] - dense[None], axis=2), axis=1)))
    assert out["path"]["largest_deviation"] == pytest.approx(largest, abs=2e-5)
    assert out["path"]["within"] is (largest <= tolerance) and out["success"] is (code == 0)
    if code:
        assert "strays" in out["message"] and "beyond the tolerance" in out["message"]


@pytest.mark.parametrize("value, message", [
    ("-0.1", "--path-tolerance: must be a finite number > 0"),
    ("0.5mm", "--path-tolerance: '0.5mm' has units, but the scene is dimensionless"),
    ("nan", "--path-tolerance: must be a finite number > 0"),
])
def test_a_bad_path_tolerance_is_one_line(value, message, capsys):
    assert main(["schedule", str(CONFIG), f"--path-tolerance={value}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_a_path_tolerance_that_is_not_a_number_is_one_line(tmp_path, capsys):
    import yaml

    data = yaml.safe_load(CONFIG.read_text())
    for value in (True, [1, 2]):
        data["study"]["path_tolerance"] = value
        cfg = tmp_path / "s.yaml"
        cfg.write_text(yaml.safe_dump(data))
        assert main(["schedule", str(cfg)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "study.path_tolerance: expected a number or a quantity" in err[0], err


@pytest.mark.slow
def test_an_optimised_schedule_that_strays_names_its_nodes(capsys):
    config = CONFIG.parent / "study_schedule_optimal_control.yaml"
    assert main(["schedule", str(config), "--path-tolerance", "0.001", "--json"]) == 3
    out = json.loads(capsys.readouterr().out)
    assert out["optimal_control"]["optimal"] and not out["success"] and not out["path"]["within"]
    assert "--nodes: the optimised schedule's steps are its time nodes" in out["message"]
