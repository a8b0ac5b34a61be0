"""Coil currents as design variables (issue 19 item 2): a soft strip between two crossed Helmholtz
pairs (configs/coils_two_pairs_design.yaml). The designed currents are checked against an
independent shooting solver that calls magpylib for the field of coils built here by hand; the
currents' weights against a refit of magpylib at those currents; the implicit derivatives against
finite differences of states from rest; limits and bad requests end in one line."""
import json
import math
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from actuator_design.hardware.current_design import design_currents, scene_at_currents
from actuator_design.hardware.current_map import CurrentMap, at_weights
from actuator_design.cli.main import main
from actuator_design.config import load_scene
from actuator_design.config.errors import ConfigError
from actuator_design.equilibrium.pipeline import solve
from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "coils_two_pairs_design.yaml"
TARGET = (0.83, 0.5)


def _pair(radius, axis_deg, current, turns=200, centre=(10e-3, 0.0)):
    """A Helmholtz pair by hand: two loops of ``turns`` turns, ``radius`` apart along the axis."""
    a = math.radians(axis_deg)
    axis = Rotation.from_euler("z", a) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])  # loop normal → the axis
    return [magpy.current.Circle(diameter=2 * radius, current=turns * current, orientation=axis,
                                 position=(centre[0] + z * math.cos(a), centre[1] + z * math.sin(a), 0))
            for z in (-0.5 * radius, 0.5 * radius)]


@pytest.fixture(scope="module")
def designed():
    scene = load_scene(CONFIG)[0]
    return scene, design_currents(scene, TARGET)


def test_designed_currents_put_the_tip_on_the_target_by_shooting_in_magpylibs_field(designed):
    scene, d = designed
    assert d.success and d.verified and d.holds_over_box, d.message
    i1, i2 = d.currents
    assert abs(i1) <= 8 and abs(i2) <= 8
    assert d.power == pytest.approx(2.5 * i1 ** 2 + 2.0 * i2 ** 2, rel=1e-12)  # the config's resistances
    # the field of the designed currents from magpylib, in units of the scene's own H0 (its groups
    # h, h_pos are per H0): no weights, no fit
    coils = _pair(60e-3, 0.0, i1) + _pair(50e-3, 90.0, i2)
    length, h0 = scene.scales.length, scene.scales.field
    field = field_from_function(lambda p: magpy.getH(coils, p, sumup=True), length, h0)
    rod = FieldRod(field, h=scene.h, h_pos=scene.h_pos, h_r=0.0, alpha=0.0, beta=0.0)
    s = np.linspace(0, 1, 201)
    st = d.state.evaluate(s)
    shot = solve_field_shooting(rod, guess_from_shape(rod, s, st["theta"], st["dtheta"][0], st["x"], st["y"]))
    assert np.max(np.abs(np.array(shot.tip[:2]) - TARGET)) <= 1e-6, shot.tip
    # the field reported at the clamp is magpylib's there
    b = magpy.getB(coils, (0.0, 0.0, 0.0), sumup=True)
    assert d.field_at_clamp[0] == pytest.approx(math.hypot(b[0], b[1]), rel=1e-6)
    # one representative of ±I (a soft rod's state is even in the field): the first coil positive
    assert i1 > 0
    # every corner of the box: switched on from rest, the rod is on the designed branch
    assert len(d.box) == 8 and all(c["same_branch"] and c["stable"] for c in d.box)
    assert d.worst_tip_error == max(c["tip_error"] for c in d.box) > d.tip_error


def test_weights_are_currents_and_their_derivatives_are_the_finite_differences():
    scene = load_scene(CONFIG)[0]
    w = np.array([0.7, 1.3])
    i0 = np.array([c.current for c in scene.field.sources])
    weighted = solve(at_weights(scene, w))
    refit = solve(scene_at_currents(scene, w * i0))  # magpylib fitted anew at those currents
    assert weighted.success and refit.success
    for k in ("x", "y", "angle"):
        assert abs(weighted.tip[k] - refit.tip[k]) < 1e-8
    cmap = CurrentMap(scene, weighted, w)
    pt = cmap.evaluate(w)
    step = 1e-5
    for k in range(2):
        e = np.zeros(2)
        e[k] = step
        fd = (cmap.evaluate(w + e)["tip"] - cmap.evaluate(w - e)["tip"]) / (2 * step)
        assert np.allclose(pt["tip_jac"][:, k], fd, rtol=1e-6, atol=1e-8), (k, pt["tip_jac"][:, k], fd)
        fd_h2 = (cmap.evaluate(w + e)["limit"] - cmap.evaluate(w - e)["limit"]) / (2 * step)
        assert np.allclose(pt["limit_jac"][:, k], fd_h2, rtol=1e-6, atol=1e-9)


def _config(tmp_path, edit):
    data = yaml.safe_load(CONFIG.read_text())
    edit(data["scene"]["field"])
    path = tmp_path / "coils.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_current_limit_below_the_need_is_unreachable_and_named(tmp_path, capsys):
    path = _config(tmp_path, lambda f: f["coils"][1].update(max_current="3 A"))
    assert main(["design", str(path), "--target-tip", "0.83,0.5", "--json"]) == 4
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "unreachable" and not out["success"]
    assert "coil 2 current" in out["limits_active"] and abs(out["currents_A"][1]) <= 3 * (1 + 1e-9)
    assert out["tip_error"] > 1e-3 and "coil 2 current at the limit" in out["message"]


@pytest.mark.slow  # ~28 s: the search crawls along the field limit
def test_the_field_limit_holds_on_the_whole_rod_by_magpylib(tmp_path, capsys):
    """The target needs 12.2 mT; with max_field 11 mT the nearest tip found keeps |mu0 H| <= 11 mT
    at every point of the reported shape, by magpylib at the designed currents."""
    path = _config(tmp_path, lambda f: f.update(max_field="11 mT"))
    assert main(["design", str(path), "--target-tip", "0.83,0.5", "--json", "--out", str(tmp_path / "o")]) == 4
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "unreachable" and "max_field" in out["limits_active"]
    i1, i2 = out["currents_A"]
    shape = np.genfromtxt(tmp_path / "o" / "shape.csv", delimiter=",", names=True, skip_header=1)
    pts = np.column_stack([shape["x_m"], shape["y_m"], np.zeros(shape.size)])
    b = magpy.getB(_pair(60e-3, 0.0, i1) + _pair(50e-3, 90.0, i2), pts, sumup=True)
    assert np.max(np.hypot(b[:, 0], b[:, 1])) <= 11e-3 * (1 + 1e-5)


@pytest.mark.parametrize("edit, words", [
    (lambda f: f["coils"][0].pop("max_current"), "coil 1 has no max_current"),
    (lambda f: f["coils"][1].update(current="0 A"), "coil 2's current is 0 A"),
])
def test_a_coil_design_without_what_it_needs_is_one_line(tmp_path, capsys, edit, words):
    assert main(["design", str(_config(tmp_path, edit)), "--target-tip", "0.83,0.5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err


@pytest.mark.parametrize("edit, words", [
    (lambda f: f["coils"][0].update(current="9 A"), "exceeds the coil's max_current 8 A"),
    (lambda f: f["coils"][0].pop("resistance"), "max_power needs every coil's resistance"),
    (lambda f: f["coils"][0].update(resistance="-1 ohm"), "resistance"),
    (lambda f: f.update(max_power="3 A"), "max_power"),
])
def test_bad_hardware_limits_are_config_errors(tmp_path, edit, words):
    with pytest.raises(ConfigError, match=words):
        load_scene(_config(tmp_path, edit))


def test_vary_and_a_magnet_scene_are_refused_in_one_line(capsys):
    assert main(["design", str(CONFIG), "--target-tip", "0.83,0.5", "--vary", "h"]) == 2
    assert "varies the coils' currents" in capsys.readouterr().err
    magnet = CONFIG.parent / "magnet_cylinder_hard_strip.yaml"
    assert main(["design", str(magnet), "--target-tip", "0.8,0.5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a magnet with a `travel`" in err[0]  # (its pose is then designed)


def test_currents_from_a_forward_solve_are_found_again_at_no_more_power():
    """Round trip: the tip that 3.8 A and 0.57 A give from rest (a refit of magpylib there, near the
    straight rod, where the tip's Jacobian is nearly singular) is designed back; two coils for two
    tip equations: the same currents, or others at no more power."""
    scene = load_scene(CONFIG)[0]
    given = np.array([3.8027, 0.5721])
    r = solve(scene_at_currents(scene, given))
    assert r.success and r.stable
    d = design_currents(scene, (r.tip["x"], r.tip["y"]))
    assert d.success, d.message
    assert d.power <= 2.5 * given[0] ** 2 + 2.0 * given[1] ** 2 + 1e-9
    assert np.allclose(d.currents, given, atol=1e-6)


@pytest.mark.slow  # a second whole design (~8 s)
def test_the_design_does_not_depend_on_the_configured_start_currents(designed, tmp_path):
    """The configured currents only start the search: -2 A and 0.5 A give the design of 2 A and
    2 A (the first coil's current positive: ±I hold the same state of a soft rod)."""
    _, d = designed

    def edit(f):
        f["coils"][0]["current"] = "-2 A"
        f["coils"][1]["current"] = "0.5 A"
    other = design_currents(load_scene(_config(tmp_path, edit))[0], TARGET)
    assert other.success and np.allclose(other.currents, d.currents, rtol=1e-7, atol=1e-9)


def test_obstacles_and_flags_that_do_not_apply_are_refused_in_one_line(tmp_path, capsys):
    data = yaml.safe_load(CONFIG.read_text())
    data["scene"]["obstacles"] = [{"type": "wall", "point": {"x": "0 mm", "y": "6 mm"}, "normal_angle": "-90 deg"}]
    path = tmp_path / "wall.yaml"
    path.write_text(yaml.safe_dump(data))
    for argv, words in (([str(path)], "has obstacles"), ([str(CONFIG), "--h-max", "0.1"], "--h-max: does not apply")):
        assert main(["design", *argv, "--target-tip", "0.83,0.5"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], err


def test_the_qp_step_with_as_many_coils_as_tip_equations_is_the_newton_step_and_prunes_exactly():
    """Two unknowns, two tip equations: the step is −J⁻¹e (the linearised target fixes it), with or
    without a field limit the box cannot reach (its rows are dropped exactly); three unknowns: the
    least-effort step of the equality-constrained quadratic programme (its KKT system by hand)."""
    from actuator_design.hardware.current_sqp import CurrentProblem, _qp_step

    J = np.array([[1.0, 0.3], [0.2, 1.0]])
    e = np.array([0.05, -0.02])
    pt = {"tip": e + np.array([0.3, 0.2]), "tip_jac": J, "limit": np.array([0.1, 0.2]),
          "limit_jac": np.array([[0.1, 0.0], [0.0, 0.1]])}
    w = np.array([0.2, 0.1])
    for cap in (math.inf, 1.0):  # 1.0: the box (|d| ≤ 0.25) reaches at most 0.2 + 0.025 < 1
        prob = CurrentProblem(target=np.array([0.3, 0.2]), cost=np.array([1.0, 2.0]), bound=np.ones(2),
                              tip_tol=1e-9, max_limit=cap)
        d, solved = _qp_step(prob, w, pt, 0.25, exact=True)
        assert solved
        np.testing.assert_allclose(d, -np.linalg.solve(J, e), rtol=1e-14)
    A = np.array([[1.0, 0.3, -0.5], [0.2, 1.0, 0.7]])
    c = np.array([1.0, 3.0, 0.5])
    prob = CurrentProblem(target=np.zeros(2), cost=c, bound=np.ones(3), tip_tol=1e-9)
    w = np.array([0.1, -0.05, 0.02])
    e = A @ w - np.array([0.02, 0.01])
    pt = {"tip": e, "tip_jac": A, "limit": np.zeros(1), "limit_jac": np.zeros((1, 3))}
    d, solved = _qp_step(prob, w, pt, 1.0, exact=True)
    K = np.block([[2 * np.diag(c), A.T], [A, np.zeros((2, 2))]])  # min Σ c (w + d)² s.t. A d = −e
    ref = np.linalg.solve(K, np.concatenate([-2 * c * w, -e]))[:3]
    assert solved
    np.testing.assert_allclose(d, ref, atol=1e-8)
