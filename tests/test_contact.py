"""Contact with walls and pegs (issue 20, first step): a cantilever pressed by a tip load onto a
floor below its tip, against the linear beam with a unilateral support (closed form) and against
the elastica shot with the tip pinned at the floor (the reference's own Runge–Kutta, the contact
force its unknown); the Euler–Lagrange residual includes the contact force; interior point contacts
are reported as not resolved by the mesh, never as a success."""
import math

import numpy as np
import pytest

from contact_references import floor_reference, peg_reference

from actuator_design.equilibrium.balance import balance
from actuator_design.config.errors import ConfigError
from actuator_design.config.model import load_config
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Peg, Wall
from actuator_design.model.scene import Scene
from actuator_design.equilibrium.solver import get_solver


def _floor_scene(depth, p):
    return Scene(field=None, tip_force=(0.0, -p), obstacles=(Wall((0.0, -depth), 0.5 * math.pi),))


def test_small_load_on_a_floor_is_the_linear_propped_cantilever():
    """Linear beam, tip load p down, tip held at −δ (p > 3δ): the floor pushes back R = p − 3δ."""
    depth, p = 1e-3, 0.01
    r = solve(_floor_scene(depth, p))
    assert r.success and r.stable
    pts = r.contact["points"]
    assert len(pts) == 1 and pts[0]["s"] == 1.0 and not pts[0]["weak"]
    assert abs(r.tip["y"] + depth) <= 1e-10
    R = r.contact["total_force"][1]
    assert abs(R - (p - 3 * depth)) <= 1e-4 * p  # nonlinear corrections O(δ²)


def test_tip_pressed_onto_a_floor_against_shooting():
    """Large deflection: the elastica whose net tip force −p + R puts its tip on the floor."""
    depth, p = 0.1, 1.0
    r = solve(_floor_scene(depth, p))
    assert r.success and r.stable and r.morse_index == 0

    R, ref = floor_reference(p, depth)
    assert abs(r.contact["total_force"][1] - R) <= 1e-6 and abs(r.contact["total_force"][0]) <= 1e-9
    assert abs(r.tip["x"] - ref.tip_x) <= 1e-6 and abs(r.tip["angle"] - ref.tip_angle) <= 1e-6
    # the moment balance holds with the contact force, not without it
    assert r.el_residual <= 1e-8
    sv = get_solver(r.scene, r.options)
    without = balance(sv, sv.parameter_vector(r.scene), r._dense, r.scene, r.z)[2]
    assert without > 0.1
    np.testing.assert_allclose(r.clamp_force, [0.0, p - R], atol=1e-8)


def test_a_floor_out_of_reach_changes_nothing():
    free = solve(Scene(field=None, tip_force=(0.0, -0.1)))
    r = solve(_floor_scene(0.5, 0.1))
    assert r.success and r.contact["points"] == []
    assert abs(r.tip["x"] - free.tip["x"]) <= 1e-9 and abs(r.tip["y"] - free.tip["y"]) <= 1e-9


def test_an_elastica_resting_on_a_peg_against_shooting():
    """A peg under the middle of the rod, the tip pulled down: one interior contact. The mesh gets
    an element boundary there (a point force kinks θ'), so the tip and the contact force match the
    shooting reference with the contact point as an unknown."""
    f, centre, gap = np.array([0.0, -1.6]), np.array([0.6, -0.2]), 0.025
    r = solve(Scene(field=None, tip_force=tuple(f), obstacles=(Peg(tuple(centre), 0.1),), contact_gap=gap))
    assert r.success and r.stable, r.message
    pts = r.contact["points"]
    big = [q for q in pts if np.hypot(*q["force"]) > 1e-3]
    assert len(big) == 1 and 0 < big[0]["s"] < 1 and r.contact["split_at"]
    F = np.array(r.contact["total_force"])
    guess = [r.evaluate(np.array([0.0]))["dtheta"][0], big[0]["s"], np.hypot(*F), math.atan2(F[1], F[0])]
    (gamma, sc, R, psi), end, nu = peg_reference(f, centre, 0.1 + gap, guess)
    assert abs(r.tip["x"] - end[2]) <= 1e-6 and abs(r.tip["y"] - end[3]) <= 1e-6
    assert abs(r.tip["angle"] - end[0]) <= 1e-6
    assert np.max(np.abs(F - R * nu)) <= 1e-4 and abs(big[0]["s"] - sc) <= 1e-4
    assert r.el_residual <= 1e-6


def test_an_obstacle_crossing_the_rod_at_rest_is_refused():
    r = solve(Scene(field=None, tip_force=(0.0, -0.5), obstacles=(Peg((0.5, 0.0), 0.05),)))
    assert not r.success and r.status == "obstacle_at_rest" and "at rest" in r.message


def test_obstacles_from_yaml():
    cfg = {"scene": {"type": "physical",
                     "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm", "youngs_modulus": "1 MPa"},
                     "loads": {"tip_force": {"x": "0 N", "y": "-1 mN"}},
                     "obstacles": [{"type": "wall", "point": {"x": "0 mm", "y": "-2 mm"}, "normal_angle": "90 deg"},
                                   {"type": "peg", "centre": {"x": "10 mm", "y": "5 mm"}, "radius": "2 mm"}]}}
    sc = load_config(cfg).to_scene()
    assert sc.contact_gap == pytest.approx(0.025)  # half the thickness, in rod lengths
    assert sc.obstacles[0] == Wall((0.0, -0.1), 0.5 * math.pi)
    assert sc.obstacles[1] == Peg((0.5, 0.25), 0.1)
    r = solve(sc)
    assert r.success and abs(r.tip["y"] + 0.1 - 0.025) <= 1e-9  # the surface, not the centre line, touches
    assert r.contact["points"][0]["force_N"][1] > 0


@pytest.mark.parametrize("obstacle, where", [
    ({"type": "hole", "centre": {"x": 0.5, "y": 0}}, "scene.obstacles[0].type"),
    ({"type": "peg", "centre": {"x": 0.5, "y": 0.3}, "radius": -0.1}, "scene.obstacles[0].radius"),
    ({"type": "wall", "point": {"x": 0, "y": -0.1}}, "scene.obstacles[0].normal_angle"),
])
def test_bad_obstacles_name_the_field(obstacle, where):
    with pytest.raises(ConfigError) as err:
        load_config({"scene": {"type": "dimensionless", "p": -1, "obstacles": [obstacle]}})
    assert err.value.field == where, str(err.value)


def test_the_shape_figure_draws_obstacles_and_contact_forces():
    from matplotlib.patches import Polygon

    from actuator_design.viz.shape import plot_shape

    r = solve(Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025))
    ax = plot_shape(r)
    assert any(isinstance(p, Polygon) and len(p.get_xy()) > 90 for p in ax.patches)  # the peg's disc
    labels = ax.get_legend_handles_labels()[1]
    assert "obstacle" in labels and "contact force (1 point)" in labels


@pytest.mark.parametrize("argv", [["design", "--target-stiffness", "1.5"],
                                  ["design", "--target-tip", "0.5,0.5;0.6,0.2"],
                                  ["equilibria"]])
def test_analyses_that_would_ignore_obstacles_refuse_them_in_one_line(argv, capsys):
    from pathlib import Path

    from actuator_design.cli.main import main

    cfg = Path(__file__).resolve().parents[1] / "configs" / "contact_tip_on_floor.yaml"
    assert main([argv[0], str(cfg), *argv[1:]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert ("obstacles (contact), which only solve, path, stiffness, continue (on from the first touch by a loading path) and design "
            "(--target-tip, one pose") in err[0]


def test_the_api_refuses_too():
    from actuator_design.inverse.shape import design_shape
    from actuator_design.analysis.equilibria import find_equilibria

    with pytest.raises(ValueError, match="equilibria: this scene has obstacles"):
        find_equilibria(_floor_scene(0.1, 1.0))
    with pytest.raises(ValueError, match="design --target-shape: this scene has obstacles"):
        design_shape(np.array([[0.5, 0.4, 0.2], [1.0, 0.7, 0.5]]), scene=_floor_scene(0.1, 1.0))


def test_stiffness_of_a_rod_over_a_peg_against_shooting():
    """The compliance dy(1)/dfy of the elastica resting on a peg, by central differences of contact
    solves, against the same differences of the shooting reference (its contact point sliding)."""
    from actuator_design.analysis.stiffness import tip_stiffness

    f, centre, gap = np.array([0.0, -1.6]), np.array([0.6, -0.2]), 0.025
    r = solve(Scene(field=None, tip_force=tuple(f), obstacles=(Peg(tuple(centre), 0.1),), contact_gap=gap))
    st = tip_stiffness(r)
    F = np.array(r.contact["total_force"])
    big = [q for q in r.contact["points"] if np.hypot(*q["force"]) > 1e-3]
    guess = [r.evaluate(np.array([0.0]))["dtheta"][0], big[0]["s"], np.hypot(*F), math.atan2(F[1], F[0])]
    ys = [peg_reference(f + np.array([0.0, d]), centre, 0.1 + gap, guess)[1][3] for d in (-1e-4, 1e-4)]
    assert st.compliance[1, 1] == pytest.approx((ys[1] - ys[0]) / 2e-4, rel=1e-5)
    assert np.allclose(st.compliance, st.compliance.T, rtol=1e-4, atol=1e-8)  # reciprocity


def test_a_tip_on_a_floor_is_infinitely_stiff_vertically():
    from actuator_design.analysis.stiffness import tip_stiffness

    st = tip_stiffness(solve(_floor_scene(0.1, 1.0)))
    assert st.vertical == math.inf and st.compliance[1, 1] == 0.0 and st.compliance[0, 0] > 0


def test_continuation_follows_the_free_branch_to_the_first_touch_and_on_with_contact():
    """Tip load p from 0 down, a floor 0.1 below the clamp: the branch stops where the free tip
    reaches the floor, at the load of the shooting reference (tip y(p) = −0.1), and says so; the
    loading path with contact goes on from there to p = −3, where the tip rests on the floor with
    the floor reference's reaction."""
    from scipy.optimize import brentq

    from actuator_design.continuation.follow import continue_branch
    from actuator_design.reference.shooting import ShootingParams, solve_shooting

    depth = 0.1
    res = continue_branch(_floor_scene(depth, 0.0), "p", 0.0, -3.0)
    br = res.branch
    assert br.status == "touch" and "first touches an obstacle" in br.message, br.message
    p_touch = brentq(lambda p: solve_shooting(ShootingParams(fy=p), gamma_guess=p / 2).tip_y + depth, -1.0, -0.1,
                     xtol=1e-14)
    assert br.lam[-1] == pytest.approx(p_touch, abs=1e-8)
    assert br.tips[-1, 2] == pytest.approx(-depth, abs=1e-8) and np.all(br.tips[:-1, 2] > -depth)
    cp = res.contact_path
    assert cp.success and res.complete and "followed on with contact to p = -3" in br.message, br.message
    # the touch-down is the continuation's located touch, not a second event one step later
    (ev,) = cp.contact_events
    assert ev["kind"] == "touch-down" and ev["located"] and ev["obstacle"] == 0 and ev["s"] == 1.0
    assert ev["param"] == pytest.approx(p_touch, abs=1e-8)
    assert cp.points[0].param == br.lam[-1] and cp.points[-1].param == -3.0
    R, ref = floor_reference(3.0, depth)
    end = cp.final
    assert abs(end.contact["total_force"][1] - R) <= 1e-4 and abs(end.tip["x"] - ref.tip_x) <= 1e-6
    assert end.tip["y"] == pytest.approx(-depth, abs=1e-9) and all(q.stable for q in cp.points)
    # stopped at the touch on request
    off = continue_branch(_floor_scene(depth, 0.0), "p", 0.0, -3.0, through_contact=False)
    assert off.contact_path is None and not off.complete and "not followed" in off.branch.message


def test_continue_goes_on_with_contact_and_from_a_start_in_contact(capsys, tmp_path):
    """The CLI: the branch up to the touch, then the loading path with contact to the window's end
    (exit 0; its states in branch.csv with with_contact = 1, its events in the JSON); with
    --stop-at-touch the branch ends at the touch with a warning line and exit 3, and a start already
    pressing the floor is refused; without it, that start is followed with contact down to 0."""
    import json
    from pathlib import Path

    from actuator_design.cli.main import main

    cfg = Path(__file__).resolve().parents[1] / "configs" / "contact_tip_on_floor.yaml"
    assert main(["continue", str(cfg), "--param", "h", "--from", "0", "--to", "3", "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert "(touch: stopped where the rod first touches an obstacle" in out and not err.strip()
    assert "touch-down on the wall" in out and "mu0 H = 5.9864 mT" in out and "touch state :" in out
    rows = [r.split(",") for r in (tmp_path / "branch.csv").read_text().splitlines()[2:]]
    last = [r for r in rows if r[-1] == "1"]
    assert last and all(r[0] == "1" for r in last) and float(last[-1][1]) == 3.0
    data = json.loads((tmp_path / "branch.json").read_text())
    assert data["complete"] and data["contact_path"]["success"]
    (touch,) = data["contact_path"]["contact_events"]
    assert touch["field_mT"] == pytest.approx(5.9864, abs=1e-4) and touch["located"]
    assert main(["continue", str(cfg), "--param", "h", "--from", "0", "--to", "3", "--stop-at-touch"]) == 3
    out, err = capsys.readouterr()
    assert "with contact" not in out
    assert len(err.strip().splitlines()) == 1 and "continuation stopped early" in err
    assert main(["continue", str(cfg), "--param", "h", "--from", "3", "--to", "0", "--stop-at-touch"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "touches or enters an obstacle" in err[0] and "use path" in err[0]
    # a start pressing the floor: followed with contact from there; it lifts off where the way up
    # touched down (no friction, one branch: no hysteresis)
    assert main(["continue", str(cfg), "--param", "h", "--from", "3", "--to", "0", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["complete"] and len(data["branch"]) == 1 and data["status"] == "touch"
    (ev,) = data["contact_path"]["contact_events"]
    assert ev["kind"] == "lift-off" and ev["located"] and ev["field_mT"] == pytest.approx(5.9864, abs=1e-4)
    assert abs(ev["param"] - touch["param"]) < 1e-8
