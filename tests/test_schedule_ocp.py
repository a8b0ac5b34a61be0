"""Field schedules as one optimal-control problem (issue 19 item 3).

References, none of them the optimal-control NLP itself:
* the greedy schedule (:func:`field_schedule`) under the same limits, its duration and field effort
  recomputed here from its (h, φ) by the rate rule (each step as long as the slower change allows)
  and the trapezoid rule: the optimised schedule is never slower (``time``) or hungrier (``energy``);
* the limits checked at every step of the reported schedule from its own times;
* an independent quasi-static loading path from zero field (:func:`follow_path`, not the NLP)
  through the reported schedule: no snap, every state stable, every waypoint hit to 1e-6.
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design.schedules.schedule import field_schedule
from actuator_design.schedules.schedule_ocp import RateLimits, optimal_schedule
from actuator_design.continuation.loading import follow_path
from actuator_design.cli.main import main
from actuator_design.model.scene import default_scene

CONFIG = str(Path(__file__).resolve().parents[1] / "configs" / "study_design_schedule.yaml")
# the shipped example's waypoints (configs/study_design_schedule.yaml)
WAYPOINTS = [(0.985, 0.161), (0.935, 0.326), (0.861, 0.465), (0.782, 0.563)]


@pytest.fixture(scope="module")
def greedy():
    g = field_schedule(WAYPOINTS)
    assert g.success, g.message
    return g


def _effort(schedule, times):
    """∫h² dt with h linear in time within each step: ∫₀^Δt (a + (b − a) t/Δt)² dt = Δt (a² + ab + b²)/3."""
    h = np.array([s["h"] for s in schedule])
    return float(np.sum(np.diff(times) * (h[:-1] ** 2 + h[:-1] * h[1:] + h[1:] ** 2) / 3))


def _by_hand(schedule, limits):
    """Duration and ∫h² dt of a schedule timed by the rate rule."""
    h = np.array([s["h"] for s in schedule])
    phi = np.array([s["phi"] for s in schedule])
    dt = np.maximum(np.abs(np.diff(h)) / limits.h_rate, np.abs(np.diff(phi)) / limits.rotation_rate)
    return float(dt.sum()), _effort(schedule, np.concatenate([[0.0], np.cumsum(dt)]))


def _check_limits_and_path(res, limits):
    sched = res.result.schedule
    h = np.array([s["h"] for s in sched])
    phi = np.array([s["phi"] for s in sched])
    dt = np.diff(res.times)
    assert h[0] == 0.0 and np.all(dt >= -1e-12) and np.all(h >= -1e-12) and np.all(h <= 10.0 + 1e-9)
    assert np.all(np.abs(np.diff(h)) <= limits.h_rate * dt + 1e-8)
    assert np.all(np.abs(np.diff(phi)) <= limits.rotation_rate * dt + 1e-8)
    # the independent check: the loading path from zero field through the schedule's points
    path = follow_path(default_scene(h=0.0), None, sched, max_step=0.25, max_dtheta=0.5)
    assert path.success and path.snap_free and len(path.states) == len(sched)
    assert all(st.stable for st in path.states)
    for wp, i in zip(WAYPOINTS, res.result.waypoint_index):
        tip = path.states[i].tip
        assert math.hypot(tip["x"] - wp[0], tip["y"] - wp[1]) <= 1e-6


@pytest.mark.parametrize("objective, rates", [("time", (1.0, 30.0)), ("energy", (5.0, 10.0))])
def test_never_slower_or_hungrier_than_greedy_and_within_limits(greedy, objective, rates):
    limits = RateLimits(h_rate=rates[0], rotation_rate=math.radians(rates[1]))
    res = optimal_schedule(WAYPOINTS, limits, objective=objective, nodes=12, greedy=greedy)
    assert res.success and res.optimal, res.message
    g_time, g_effort = _by_hand(greedy.schedule, limits)
    assert res.greedy_time_s == pytest.approx(g_time, rel=1e-12)
    assert res.greedy_effort == pytest.approx(g_effort, rel=1e-12)
    effort = _effort(res.result.schedule, res.times)  # the reported schedule's, by hand
    assert res.effort == pytest.approx(effort, rel=1e-12) and res.time_s == res.times[-1]
    if objective == "time":
        assert res.time_s <= g_time * (1 + 1e-6) and effort <= g_effort * (1 + 1e-6)
    else:
        # the field switched off while it turns (the rotation is the slow change here): the greedy
        # schedule keeps it at full strength while it rotates from waypoint to waypoint
        assert effort < 0.5 * g_effort
    _check_limits_and_path(res, limits)


def test_bad_requests_are_refused_in_one_line(greedy):
    with pytest.raises(ValueError, match="rotation_rate"):
        RateLimits(1.0, 0.0)
    with pytest.raises(ValueError, match="h_rate"):
        RateLimits(float("nan"), 1.0)
    limits = RateLimits(1.0, 1.0)
    with pytest.raises(ValueError, match="objective"):
        optimal_schedule(WAYPOINTS, limits, objective="fuel", greedy=greedy)
    with pytest.raises(ValueError, match=r"nodes: must be a whole number in \[5, 200\]"):
        optimal_schedule(WAYPOINTS, limits, nodes=4, greedy=greedy)


def test_cli_optimal_control_reports_both_schedules(tmp_path, capsys):
    args = ["schedule", CONFIG, "--optimal-control", "energy", "--h-rate", "5/s",
            "--rotation-rate", "10deg/s", "--nodes", "12", "--json"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    oc = out["optimal_control"]
    assert oc["optimal"] and oc["effort_h2_s"] < oc["greedy_effort_h2_s"] and oc["nodes"] == 12
    times = [s["time_s"] for s in out["schedule"]]
    assert times[0] == 0.0 and times[-1] == pytest.approx(oc["time_s"])
    assert out["quasi_static"] is None  # timed, but a dimensionless scene has no mass: not checked, and said so
    assert main(args[:-1]) == 0
    assert "quasi-static: not checked (a dimensionless scene has no mass" in capsys.readouterr().out
    for bad, words in ((["--optimal-control", "time", "--h-rate", "2/s"], "--rotation-rate"),
                       (["--optimal-control", "time", "--rotation-rate", "10deg/s"], "--rate"),
                       (["--optimal-control", "time", "--h-rate", "-1/s", "--rotation-rate", "1deg/s"], "--h-rate"),
                       (["--optimal-control", "time", "--h-rate", "1/s", "--rotation-rate", "1deg/s", "--nodes", "4"],
                        "--nodes"),
                       (["--h-rate", "1/s"], "--h-rate: only with --optimal-control")):
        assert main(["schedule", CONFIG, *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0]
