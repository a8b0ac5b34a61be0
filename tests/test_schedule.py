"""Field schedules through waypoints, against a known field sweep and the loading-path check."""
import math

import numpy as np
import pytest

from actuator_design.schedules.schedule import field_schedule
from actuator_design.continuation.loading import follow_path
from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import default_scene


def test_schedule_through_waypoints_of_a_known_field_rotation():
    """Waypoints made by rotating a field of fixed strength h = 1.5 from φ = 0.3 to 1.1 (forward
    solves). Tip position determines (h, φ) (2 equations, 2 unknowns), so the schedule must return
    the known fields at the waypoints; an independent re-run of the loading-path follower along the
    returned schedule must show no snap, every state stable, and each waypoint hit."""
    phis = np.linspace(0.3, 1.1, 3)
    wps, prev = [], None
    for phi in phis:
        prev = solve(default_scene(h=1.5, phi=phi), initial=prev)
        wps.append((prev.tip["x"], prev.tip["y"]))
    res = field_schedule(wps, substeps=4)
    assert res.success and res.snap_free and res.all_stable
    for row, phi in zip(res.rows, phis):
        assert row["h"] == pytest.approx(1.5, abs=1e-6)
        assert row["phi"] == pytest.approx(phi, abs=1e-6)
        assert row["error"] < 1e-6
    # the schedule starts from zero field and is continuous
    assert res.schedule[0]["h"] == 0.0
    steps = np.abs(np.diff([[s["h"], s["phi"]] for s in res.schedule], axis=0)).max()
    assert steps < 0.5
    again = follow_path(default_scene(h=0.0), None, res.schedule)
    assert again.snap_free and all(s.stable for s in again.states)
    for wp, i in zip(wps, res.waypoint_index):
        assert math.hypot(again.states[i].tip["x"] - wp[0], again.states[i].tip["y"] - wp[1]) < 1e-6


def test_schedule_rejects_bad_waypoints():
    with pytest.raises(ValueError, match="waypoints"):
        field_schedule([(0.5, 0.5)])
    with pytest.raises(ValueError, match="waypoints"):
        field_schedule([(0.5, float("nan")), (0.2, 0.3)])


def test_a_purely_hard_magnetic_rod_is_refused_in_schedule_words(capsys):
    """The schedule varies h and φ; a rod with remanence and no soft coupling has no h to vary.
    The refusal names the command, not the design flag --vary the user never gave."""
    from dataclasses import replace

    from actuator_design.cli.main import main

    with pytest.raises(ValueError, match="schedule: this rod has no soft-magnetic coupling"):
        field_schedule([(0.7, 0.6), (0.3, 0.8)], scene=replace(default_scene(h=0.0), h_r=3.0))
    config = str(Path(__file__).resolve().parents[1] / "configs" / "hard_magnetic_cantilever.yaml")
    assert main(["schedule", config, "--waypoints", "0.68,0.66;0.3,0.8"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "schedule: this rod has no soft-magnetic coupling" in err[0] and "--vary" not in err[0]


# -- issue 9 item 5: schedules the rod can follow ----------------------------------------------------
import json
import os
import subprocess
import sys
from pathlib import Path

from actuator_design.schedules.schedule import nearest_axis_angle
from actuator_design.reference.shooting import ShootingParams, jacobi_morse_index, solve_shooting
from result_invariants import schedule_contradictions

ROOT = Path(__file__).resolve().parents[1]


def _cli(*argv, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "actuator_design.cli.main", *argv], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)


def _follow_by_shooting(schedule, refine=4):
    """Follow a schedule of uniform fields (α = 0, b = 1, no load) with the independent reference
    shooting solver, warm-starting θ'(0) from the previous state; returns the state at every schedule
    point and the largest tip displacement of one refined step (a snap shows as a jump)."""
    states, gamma, jump, tip = [], 0.0, 0.0, None
    for k, pt in enumerate(schedule):
        prev = schedule[max(k - 1, 0)]
        for t in np.linspace(0, 1, refine + 1)[1:] if k else [1.0]:
            h = prev["h"] + t * (pt["h"] - prev["h"])
            phi = prev["phi"] + t * (pt["phi"] - prev["phi"])
            sol = solve_shooting(ShootingParams(h=h, phi=phi), gamma_guess=gamma)
            assert sol.converged
            gamma = sol.gamma
            if tip is not None:
                jump = max(jump, math.hypot(sol.tip_x - tip[0], sol.tip_y - tip[1]))
            tip = (sol.tip_x, sol.tip_y)
        states.append(sol)
    return states, jump


def test_config_schedule_rotates_the_short_way_and_the_rod_follows():
    """configs/study_design_schedule.yaml failed: the planner rotated 164° where 16° would do and the
    rod swung down and snapped. φ and φ + π are one field axis, so between waypoints the field turns
    by less than 90°; the independent shooting solver, following the schedule, stays on one stable
    branch (Jacobi test at every point, no jump) and meets every waypoint."""
    p = _cli("schedule", "configs/study_design_schedule.yaml", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["success"] and d["verified"] and not schedule_contradictions(d)
    wp_phis = [d["schedule"][i]["phi"] for i in d["waypoint_index"]]
    assert max(abs(b - a) for a, b in zip(wp_phis, wp_phis[1:])) < math.pi / 2
    states, jump = _follow_by_shooting(d["schedule"])
    assert jump < 0.05
    assert all(jacobi_morse_index(s).stable for s in states)
    for w, i in zip(d["waypoints"], d["waypoint_index"]):
        assert math.hypot(states[i].tip_x - w["x"], states[i].tip_y - w["y"]) < 1e-6


def test_field_angles_modulo_pi_are_one_field():
    """The premise of the short-way rule: forward solves at φ and φ + π give the same state (THEORY §5:
    the energy depends on cos²(θ + α − φ)); and the nearest representative is within 90° of the
    previous angle and differs from φ by a whole number of half turns."""
    r1 = solve(default_scene(h=1.6, phi=0.7))
    r2 = solve(default_scene(h=1.6, phi=0.7 + math.pi))
    assert np.allclose([r1.tip[k] for k in ("x", "y", "angle")], [r2.tip[k] for k in ("x", "y", "angle")],
                       atol=1e-9)
    rng = np.random.default_rng(3)
    for phi, ref in rng.uniform(-20, 20, size=(200, 2)):
        q = nearest_axis_angle(phi, ref)
        assert -math.pi / 2 - 1e-12 < q - ref <= math.pi / 2 + 1e-12
        turns = (q - phi) / math.pi
        assert abs(turns - round(turns)) < 1e-9


def test_failed_schedule_is_not_called_verified():
    """A waypoint out of reach (|r| > 1 for a rod of length 1): not a success, not verified, and the
    message says why."""
    res = field_schedule([(0.985, 0.161), (1.2, 0.3)], substeps=2)
    d = res.to_dict()
    assert not d["success"] and not d["verified"] and "not reachable" in d["message"]
    assert not schedule_contradictions(d)
