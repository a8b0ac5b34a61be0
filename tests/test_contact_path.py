"""Loading paths through contact (issue 20 item 4): touch-down and lift-off located as events,
against the free elastica shot by the independent reference (the load at which the free rod just
touches) and the contact states against the shooting references of :mod:`contact_references`."""
import math
from pathlib import Path

import numpy as np
import pytest
from contact_references import floor_reference
from scipy.optimize import brentq, minimize_scalar

from actuator_design.contact.path import follow_contact_path
from actuator_design.continuation.loading import follow_path
from actuator_design.contact.obstacles import Peg, Wall
from actuator_design.reference.shooting import ShootingParams, solve_shooting
from actuator_design.model.scene import Scene


def _free_tip_y(p):
    sol = solve_shooting(ShootingParams(fy=p), gamma_guess=0.0)
    assert sol.converged
    return sol.tip_y


def test_a_rod_in_a_channel_lifts_off_one_wall_and_touches_down_on_the_other():
    """Channel walls at y = ±0.2, the rod's half-thickness 0.01; the tip load p goes from −2 (tip
    pressed on the lower wall) to +2: lift-off where the free tip is at −0.19, touch-down at +0.19."""
    g, gap = 0.2, 0.01
    walls = (Wall((0.0, g), -0.5 * math.pi), Wall((0.0, -g), 0.5 * math.pi))
    path = follow_contact_path(Scene(field=None, tip_force=(0.0, 0.0), obstacles=walls, contact_gap=gap),
                               None, {"p": [-2.0, 2.0]})
    assert path.success and path.snap_free, path.message
    ev = path.contact_events
    assert [(e["kind"], e["obstacle"]) for e in ev] == [("lift-off", 1), ("touch-down", 0)]
    assert all(e["located"] and e["s"] == 1.0 for e in ev)
    p_lift = brentq(lambda p: _free_tip_y(p) + (g - gap), -2.0, 0.0, xtol=1e-14)
    p_touch = brentq(lambda p: _free_tip_y(p) - (g - gap), 0.0, 2.0, xtol=1e-14)
    assert abs(ev[0]["param"] - p_lift) <= 1e-6 and abs(ev[1]["param"] - p_touch) <= 1e-6
    # the states in contact: the tip on the wall with the floor reference's reaction
    first = path.states[0]
    R, ref = floor_reference(2.0, g - gap)
    assert abs(first.contact["total_force"][1] - R) <= 1e-4 and abs(first.tip["x"] - ref.tip_x) <= 1e-6
    kinds = [q.kind for q in path.points]
    assert kinds.count("lift-off") == 1 and kinds.count("touch-down") == 1
    assert all(q.stable for q in path.points)


def _free_min_distance(p, centre):
    sol = solve_shooting(ShootingParams(fy=p), gamma_guess=0.0)
    assert sol.converged
    xy = lambda s: sol.ode(s)[2:4]
    d = lambda s: float(np.hypot(*(xy(s) - centre)))
    grid = np.linspace(0, 1, 401)
    i = int(np.argmin([d(s) for s in grid]))
    best = minimize_scalar(d, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 400)]), method="bounded",
                           options={"xatol": 1e-13})
    return best.fun, best.x


def test_a_rod_pulled_onto_a_peg_and_released():
    """A peg under the rod's middle, the tip load ramped to −1.6 and back: touch-down and lift-off
    at the same load (frictionless, elastic: no hysteresis), where the free rod's surface first
    meets the peg (shooting reference, the contact point as its nearest point)."""
    centre, radius, gap = np.array([0.6, -0.2]), 0.1, 0.025
    path = follow_contact_path(Scene(field=None, tip_force=(0.0, 0.0), obstacles=(Peg(tuple(centre), radius),),
                                     contact_gap=gap), None, {"p": [0.0, -1.6, 0.0]}, max_step=0.25)
    assert path.success and path.snap_free, path.message
    ev = path.contact_events
    assert [e["kind"] for e in ev] == ["touch-down", "lift-off"] and all(e["located"] for e in ev)
    p_ref = brentq(lambda p: _free_min_distance(p, centre)[0] - (radius + gap), -1.6, -0.1, xtol=1e-14)
    s_ref = _free_min_distance(p_ref, centre)[1]
    for e in ev:
        assert abs(e["param"] - p_ref) <= 1e-6 and abs(e["s"] - s_ref) <= 1e-4


def test_follow_path_takes_the_contact_route_for_obstacles():
    sc = Scene(field=None, tip_force=(0.0, 0.0), obstacles=(Wall((0.0, -0.1), 0.5 * math.pi),))
    path = follow_path(sc, None, {"p": [0.0, -1.0]})
    assert path.success and [e["kind"] for e in path.contact_events] == ["touch-down"]
    assert path.to_dict()["contact_events"][0]["obstacle"] == 0


def test_the_channel_config_sequence_and_its_mirror_symmetry():
    """configs/contact_channel_path.yaml: the field (h = 1) turned from −60° to +60° in a channel
    symmetric about the rod: lift-off from the lower wall and touch-down on the upper one at
    mirror angles; the first touch-down (field ramped at −60°) where the free rod shot by the
    reference puts its tip on the lower wall."""
    from pathlib import Path

    from actuator_design.config.model import load_config

    cfg = load_config(Path(__file__).resolve().parents[1] / "configs" / "contact_channel_path.yaml")
    scene = cfg.to_scene()
    sched = [{"h": 0.0, "phi": -math.pi / 3}, {"h": 1.0, "phi": -math.pi / 3}, {"h": 1.0, "phi": math.pi / 3}]
    path = follow_path(scene, None, sched)
    assert path.success and path.snap_free, path.message
    ev = path.contact_events
    assert [(e["kind"], e["obstacle"]) for e in ev] == [("touch-down", 1), ("lift-off", 1), ("touch-down", 0)]
    assert abs(ev[1]["values"]["phi"] + ev[2]["values"]["phi"]) <= 1e-8
    half = 0.15 - scene.contact_gap  # the centre line's reach: half the channel less half the thickness

    def tip_y(h):
        sol = solve_shooting(ShootingParams(h=h, phi=-math.pi / 3), gamma_guess=0.0)
        assert sol.converged
        return sol.tip_y

    h_ref = brentq(lambda h: tip_y(h) + half, 0.1, 1.0, xtol=1e-14)
    assert abs(ev[0]["values"]["h"] - h_ref) <= 1e-6


def test_a_yaml_path_schedule_may_carry_quantities(tmp_path, capsys):
    """study.schedule rows with '… mT' and '… deg' on a physical scene: the same path as the
    dimensionless numbers they convert to (h = 1 given as its field in mT, exactly)."""
    import json

    import yaml

    from actuator_design.cli.main import main
    from actuator_design.config.model import load_scene
    from actuator_design.io.user_units import user_units

    config = Path(__file__).resolve().parents[1] / "configs" / "contact_channel_path.yaml"
    raw = yaml.safe_load(config.read_text())
    scene, _, loaded = load_scene(config)
    mT = user_units(scene, loaded).field_mT(1.0)
    raw["study"]["schedule"] = [{"h": "0 mT", "phi": "-60 deg"}, {"h": f"{mT!r} mT", "phi": "-60 deg"},
                                {"h": f"{mT!r} mT", "phi": "60 deg"}]
    path = tmp_path / "channel.yaml"
    path.write_text(yaml.safe_dump(raw))
    assert main(["path", str(path), "--json"]) == 0
    events = json.loads(capsys.readouterr().out)["contact_events"]
    assert [e["kind"] for e in events] == ["touch-down", "lift-off", "touch-down"]
    assert events[1]["values"]["h"] == pytest.approx(1.0, abs=1e-12)
    # the walls in the config's millimetres: y = -3 mm (pressed, then left), then y = +3 mm
    assert [e["physical"]["obstacle_text"].split(",")[:2] for e in events] == \
        [["wall through (0", " -3) mm"], ["wall through (0", " -3) mm"], ["wall through (0", " 3) mm"]]
    raw["study"]["schedule"][1]["h"] = "2 kg"
    path.write_text(yaml.safe_dump(raw))
    assert main(["path", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "study.schedule[1].h" in err[0]


def test_validate_names_the_channels_walls_and_gap_in_the_configs_millimetres(capsys):
    """configs/contact_channel_path.yaml: walls 3 mm either side of the clamp, a 0.5 mm thick strip."""
    from actuator_design.cli.main import main

    config = Path(__file__).resolve().parents[1] / "configs" / "contact_channel_path.yaml"
    assert main(["validate", str(config)]) == 0
    (line,) = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("obstacles")]
    assert "wall through (0, 3) mm" in line and "wall through (0, -3) mm" in line
    assert "the rod keeps 0.25 mm from them" in line and " l" not in line.replace(" lumen", "")
