"""Field schedules through waypoints, against a known field sweep and the loading-path check."""
import math

import numpy as np
import pytest

from actuator_design.analysis.schedule import field_schedule
from actuator_design.analysis.loading import follow_path
from actuator_design.equilibrium import solve
from actuator_design.scene import default_scene


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
