"""A rod in a curved lumen (issue 20 item 1: a channel given as a centre line and a radius): the
distance to the centre line against a brute-force sampled curve, and a rod laid through a bend,
pressed on the inner wall of the arc and with its tip on the outer wall of the exit, against an
elastica shot with both contacts written out (:mod:`contact_references`)."""
import math

import numpy as np
import pytest
from contact_references import peg_and_tip_wall_reference

from actuator_design.config.errors import ConfigError
from actuator_design.config.model import load_config
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Lumen
from actuator_design.model.scene import Scene

RADIUS, GAP, TURN = 0.06, 0.01, math.radians(70)
BEND = Lumen((-0.1, 0.0), 0.0, RADIUS, (("straight", 0.3), ("arc", 0.5, TURN), ("straight", 0.6)))


@pytest.mark.parametrize("turn_deg", [60.0, -120.0])
def test_lumen_distance_against_a_sampled_centre_line(turn_deg):
    lumen = Lumen((0.0, 0.0), 0.3, 0.1, (("straight", 0.3), ("arc", 0.5, math.radians(turn_deg)), ("straight", 0.4)))
    line = lumen.centreline(n=120000, extend=2.0)
    pts = np.random.default_rng(1).uniform([-0.5, -0.8], [1.2, 1.0], size=(300, 2))
    brute = 0.1 - np.min(np.hypot(pts[:, None, 0] - line[None, :, 0], pts[:, None, 1] - line[None, :, 1]), axis=1)
    np.testing.assert_allclose(lumen.distance(pts[:, 0], pts[:, 1]), brute, atol=2e-7)


def test_a_rod_through_a_bend_against_shooting():
    r = solve(Scene(field=None, obstacles=(BEND,), contact_gap=GAP))
    assert r.success and r.stable, r.message
    assert "lumen's centre line" in r.message  # it cannot lie straight in the bend: laid along it
    big = [q for q in r.contact["points"] if np.hypot(*q["force"]) > 1e-3]
    assert len(big) == 2 and 0 < big[0]["s"] < 1 and big[1]["s"] == 1.0
    # the inner wall of the arc is a disc about the arc's centre; the exit's outer wall a line
    rho = 0.5 / TURN
    centre = np.array([0.2, rho])
    exit_point = centre + rho * np.array([math.sin(TURN), -math.cos(TURN)])
    n_w = np.array([-math.sin(TURN), math.cos(TURN)])  # the exit's left normal: into the tube from its right wall
    wall = exit_point - (RADIUS - GAP) * n_w
    F1, F2 = (np.array(q["force"]) for q in big)
    guess = [r.evaluate(np.array([0.0]))["dtheta"][0], big[0]["s"], np.hypot(*F1), math.atan2(F1[1], F1[0]),
             np.hypot(*F2)]
    (gamma, sc, R1, psi, R2), end, nu = peg_and_tip_wall_reference(centre, rho - RADIUS + GAP, wall, n_w, guess)
    assert abs(r.tip["x"] - end[2]) <= 1e-6 and abs(r.tip["y"] - end[3]) <= 1e-6
    assert abs(r.tip["angle"] - end[0]) <= 1e-6
    assert abs(big[0]["s"] - sc) <= 1e-4
    assert np.max(np.abs(F1 - R1 * nu)) <= 1e-4 and np.max(np.abs(F2 - R2 * n_w)) <= 1e-4


def test_physical_lumen_from_yaml():
    cfg = {"scene": {"type": "physical",
                     "rod": {"length": "20 mm", "width": "1 mm", "thickness": "0.4 mm", "youngs_modulus": "1 MPa"},
                     "obstacles": [{"type": "lumen", "start": {"x": "-2 mm", "y": "0 mm"}, "angle": "0 deg",
                                    "radius": "1.2 mm",
                                    "path": [{"straight": "6 mm"}, {"arc": "10 mm", "turn": "70 deg"},
                                             {"straight": "12 mm"}]}]}}
    sc = load_config(cfg).to_scene()
    (lumen,) = sc.obstacles
    assert lumen.start == pytest.approx((-0.1, 0.0)) and lumen.radius == pytest.approx(0.06)
    assert [p[0] for p in lumen.pieces] == ["straight", "arc", "straight"]
    assert [p[1:] for p in lumen.pieces] == [pytest.approx((0.3,)), pytest.approx((0.5, TURN)), pytest.approx((0.6,))]
    assert sc.contact_gap == pytest.approx(0.01)


@pytest.mark.parametrize("piece, words", [
    ({"straight": 0.3, "arc": 0.2}, "a piece is"),
    ({"arc": 0.2}, "a piece is"),
    ({"arc": 0.05, "turn": "90 deg"}, "fold over"),
    ({"straight": -0.1}, "straight"),
])
def test_bad_lumens_name_the_field(piece, words):
    with pytest.raises(ConfigError) as err:
        load_config({"scene": {"type": "dimensionless",
                               "obstacles": [{"type": "lumen", "radius": 0.06, "path": [piece]}]}})
    msg = str(err.value)
    assert "obstacles[0]" in msg and words in msg and "\n" not in msg.strip()
