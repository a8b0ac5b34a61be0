"""Polygons and channels as obstacles (issue 20 item 1): an edge of a polygon under the tip acts as
a floor, a corner under the rod as a point (a peg of radius 0 met by the rod's surface), each
against the shooting references of :mod:`contact_references`; a channel is its two walls."""
import math

import numpy as np
import pytest
from contact_references import floor_reference, peg_reference

from actuator_design.config.errors import ConfigError
from actuator_design.config.model import load_config
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Polygon, Wall
from actuator_design.model.scene import Scene


def test_a_box_edge_under_the_tip_is_a_floor():
    depth, p = 0.1, 1.0
    box = Polygon(((0.5, -0.5), (1.5, -0.5), (1.5, -depth), (0.5, -depth)))
    r = solve(Scene(field=None, tip_force=(0.0, -p), obstacles=(box,)))
    assert r.success and r.stable, r.message
    R, ref = floor_reference(p, depth)
    assert [q["s"] for q in r.contact["points"]] == [1.0]
    assert abs(r.contact["total_force"][1] - R) <= 1e-6 and abs(r.contact["total_force"][0]) <= 1e-9
    assert abs(r.tip["x"] - ref.tip_x) <= 1e-6 and abs(r.tip["angle"] - ref.tip_angle) <= 1e-6


def test_a_corner_under_the_rod_against_shooting():
    """The rod's surface (gap 0.025) on a wedge's top corner: the centre line keeps the gap from
    one point, the shooting reference of a peg of radius 0.025 about that corner."""
    f, corner, gap = np.array([0.0, -1.6]), np.array([0.6, -0.2]), 0.025
    wedge = Polygon((tuple(corner), (0.75, -0.6), (0.45, -0.6)))
    r = solve(Scene(field=None, tip_force=tuple(f), obstacles=(wedge,), contact_gap=gap))
    assert r.success and r.stable, r.message
    big = [q for q in r.contact["points"] if np.hypot(*q["force"]) > 1e-3]
    assert len(big) == 1 and 0 < big[0]["s"] < 1
    F = np.array(r.contact["total_force"])
    guess = [r.evaluate(np.array([0.0]))["dtheta"][0], big[0]["s"], np.hypot(*F), math.atan2(F[1], F[0])]
    (gamma, sc, R, psi), end, nu = peg_reference(f, corner, gap, guess)
    assert abs(r.tip["x"] - end[2]) <= 1e-6 and abs(r.tip["y"] - end[3]) <= 1e-6
    assert abs(r.tip["angle"] - end[0]) <= 1e-6
    assert np.max(np.abs(F - R * nu)) <= 1e-4 and abs(big[0]["s"] - sc) <= 1e-4


def test_polygon_distance_is_euclidean_outside_and_signed_inside():
    sq = Polygon(((0, 0), (0, 1), (1, 1), (1, 0)))  # clockwise: stored counter-clockwise
    x = np.array([0.5, 2.0, 0.5, 0.9, -3.0])
    y = np.array([2.0, 2.0, 0.5, 0.5, -4.0])
    np.testing.assert_allclose(sq.distance(x, y), [1.0, math.sqrt(2), -0.5, -0.1, 5.0], atol=1e-15)
    np.testing.assert_allclose(sq.normal([2.0, 0.5], [2.0, 2.0]), [[1 / math.sqrt(2), 0], [1 / math.sqrt(2), 1]],
                               atol=1e-12)


def test_a_channel_is_two_walls():
    cfg = load_config({"scene": {"type": "dimensionless", "p": -2,
                                 "obstacles": [{"type": "channel", "centre": {"x": 0, "y": 0.05},
                                                "angle": "0 deg", "width": 0.5}]}})
    walls = cfg.to_scene().obstacles
    assert len(walls) == 2 and all(isinstance(w, Wall) for w in walls)
    assert walls[0].distance(0.0, 0.05) == pytest.approx(0.25) and walls[1].distance(0.0, 0.05) == pytest.approx(0.25)
    assert walls[0].distance(0.0, 0.3) == pytest.approx(0.0, abs=1e-15) and walls[1].distance(0.0, -0.2) == pytest.approx(0.0, abs=1e-15)
    r = solve(cfg.to_scene())
    assert r.success and r.stable and abs(r.tip["y"] + 0.2) <= 1e-10


def test_physical_polygon_in_mm():
    cfg = load_config({"scene": {"type": "physical", "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm",
                                                             "youngs_modulus": "1 MPa"},
                                 "obstacles": [{"type": "polygon", "vertices": [{"x": "10 mm", "y": "-4 mm"},
                                                                                 {"x": "16 mm", "y": "-4 mm"},
                                                                                 {"x": "16 mm", "y": "-2 mm"}]}]}})
    (poly,) = cfg.to_scene().obstacles
    np.testing.assert_allclose(poly.vertices, [(0.5, -0.2), (0.8, -0.2), (0.8, -0.1)], atol=1e-15)


@pytest.mark.parametrize("obstacle, words", [
    ({"type": "polygon", "vertices": [{"x": 0, "y": 0}, {"x": 1, "y": 0}]}, "obstacles"),
    ({"type": "polygon", "vertices": [{"x": 0, "y": 0}, {"x": 1, "y": 0}, {"x": 0.5, "y": 0.1}, {"x": 1, "y": 1}]},
     "convex"),
    ({"type": "polygon", "vertices": [{"x": 0, "y": 0}, {"x": 1, "y": 0}, {"x": 2, "y": 0}]}, "convex"),
    ({"type": "channel", "centre": {"x": 0, "y": 0}, "width": 0}, "width"),
    ({"type": "channel", "centre": {"x": float("nan"), "y": 0}, "width": 0.2}, "finite"),
])
def test_bad_polygons_and_channels_name_the_field(obstacle, words):
    with pytest.raises(ConfigError) as err:
        load_config({"scene": {"type": "dimensionless", "obstacles": [obstacle]}}).to_scene()
    msg = str(err.value)
    assert "obstacles" in msg and words in msg and "\n" not in msg.strip()


@pytest.mark.parametrize("obstacle, words", [
    ({"type": "polygon", "vertices": [{"x": 0, "y": -1e308}, {"x": 1e308, "y": -1e308}, {"x": 1e308, "y": -1}]},
     "within"),
    ({"type": "wall", "point": {"x": 0, "y": -1e7}, "normal_angle": "90 deg"}, "within"),
    ({"type": "lumen", "radius": 0.06, "start": {"x": 2e6, "y": 0}, "path": [{"straight": 1}]}, "within"),
])
def test_obstacles_out_of_any_reach_are_refused(obstacle, words):
    with pytest.raises(ConfigError) as err:
        load_config({"scene": {"type": "dimensionless", "obstacles": [obstacle]}}).to_scene()
    assert "obstacles[0]" in str(err.value) and words in str(err.value)


def test_a_lumen_narrower_than_the_rod_holds_no_state():
    from actuator_design.contact.obstacles import Lumen

    r = solve(Scene(field=None, tip_force=(0.0, -1.0), contact_gap=0.01,
                    obstacles=(Lumen((0.0, 0.0), 0.0, 0.005, (("straight", 1.0),)),)))
    assert not r.success and r.status == "obstacle_at_rest" and "not wider than the rod" in r.message


def test_an_obstacle_describes_itself_in_a_users_length_unit():
    """describe(scale, unit): every length scaled (20 mm per rod length), angles kept."""
    from actuator_design.contact.obstacles import Lumen, Peg, Polygon, Wall

    assert Wall((0.0, -0.15), math.pi / 2).describe(20.0, "mm") == "wall through (0, -3) mm, free side towards 90 deg"
    assert Peg((0.5, 0.1), 0.05).describe(20.0, "mm") == "peg at (10, 2) mm, radius 1 mm"
    assert Polygon(((0.5, 0.0), (0.6, 0.0), (0.6, 0.1))).describe(20.0, "mm") == \
        "polygon with vertices (10, 0), (12, 0), (12, 2) mm"
    lumen = Lumen((0.0, 0.0), 0.0, 0.05, (("straight", 0.5), ("arc", 0.3, math.pi / 4)))
    assert lumen.describe(20.0, "mm") == ("lumen of radius 1 mm from (0, 0) mm at 0 deg: straight 10 mm, "
                                          "arc 6 mm turning 45 deg")
    assert lumen.describe() == ("lumen of radius 0.05 l from (0, 0) l at 0 deg: straight 0.5 l, "
                                "arc 0.3 l turning 45 deg")


def test_the_coarse_pass_of_the_entry_check_finds_what_sampling_every_point_finds():
    """entering() samples the dense shape finely only where a coarse sample comes within half the
    coarse spacing of an obstacle's gap (a signed distance is 1-Lipschitz, |r'| = 1). Against
    sampling all n points (clearances): on free shapes bent into (or past) a peg, a wall, a box with
    a peg and a lumen, at three gaps, the same entries (obstacle and arc length) to the depth's
    last digits (the two ways integrate positions by different Gauss rules: 1e-9), and no entry
    where there is none."""
    from actuator_design.contact.clearance import clearances, entering
    from actuator_design.contact.obstacles import Lumen, Peg

    rng = np.random.default_rng(1)
    sets = [(Lumen((-0.1, 0.0), 0.0, 0.06, (("straight", 0.3), ("arc", 0.5, math.radians(70)), ("straight", 0.6))),),
            (Peg((0.6, -0.2), 0.1),), (Wall((0.0, -0.1), 0.5 * math.pi),),
            (Polygon(((0.5, -0.5), (1.5, -0.5), (1.5, -0.1), (0.5, -0.1))), Peg((0.3, 0.2), 0.05))]
    entries = 0
    for trial in range(24):
        r = solve(Scene(field=None, tip_force=(rng.uniform(-1.0, 1.0), rng.uniform(-4.0, 2.0))))
        obstacles = sets[trial % len(sets)]
        for gap in (0.0, 0.01, 0.05):
            every = min(clearances(obstacles, gap, r), key=lambda c: c["min_distance"])
            found = entering(obstacles, gap, r)
            if every["min_distance"] >= -1e-6:
                assert found is None
                continue
            entries += 1
            assert found[:2] == (every["obstacle"], every["s"])
            assert found[2] == pytest.approx(-every["min_distance"], abs=1e-9)
    assert entries >= 20
    # a shallow entry between two coarse samples: a peg put 3e-6 inside the gap under a point of a
    # bent rod midway between them, so that every coarse sample reads clear (only the margin of half
    # the coarse spacing finds it)
    from actuator_design.contact.clearance import COARSE

    r = solve(Scene(field=None, tip_force=(0.0, -1.0)))
    s0 = 1195 / 2000  # a fine sample, 0.0037 and 0.0041 from the coarse samples 76/128 and 77/128
    assert 76 / (COARSE - 1) < s0 < 77 / (COARSE - 1)
    e = r.evaluate(np.array([s0]))
    normal = np.array([-math.sin(e["theta"][0]), math.cos(e["theta"][0])])
    for radius, side in ((0.1, -1.0), (0.3, 1.0)):
        centre = np.array([e["x"][0], e["y"][0]]) + side * normal * (radius + 0.01 - 3e-6)
        peg = (Peg(tuple(centre), radius),)
        coarse = r.evaluate(np.linspace(0.0, 1.0, COARSE))
        assert np.min(peg[0].distance(coarse["x"], coarse["y"])) - 0.01 > 1e-5
        found = entering(peg, 0.01, r)
        assert found is not None and found[:2] == (0, s0) and found[2] == pytest.approx(3e-6, abs=1e-9)
