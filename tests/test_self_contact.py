"""Self-contact (issue 20 item 3): a coiled strip whose turns press on each other, against shooting
with the contact conditions written out (tests/self_contact_references.py), and against the energy
of its admissible neighbours."""
import math
from dataclasses import replace

import numpy as np
import pytest

import actuator_design.contact.equilibrium as equilibrium
import actuator_design.contact.self_solve as self_solve
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Peg
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import expression_profile
from actuator_design.model.scene import Scene
from actuator_design.contact.self_contact import candidate_pairs, neighbour_arc, self_penetration
from self_contact_references import coil_reference

GAP, M = 0.01, 8.5


def coil(**kw):
    """A strip thinning as exp(−s), coiled by a tip moment (configs/self_contact_coil.yaml)."""
    return Scene(**{"field": None, "tip_moment": M, "stiffness": expression_profile("exp(-s)"), "contact_gap": GAP, **kw})


@pytest.fixture(scope="module")
def coiled():
    return solve(coil())


def _pairs(result):
    """Each self-contact once, as (s_a, s_b, force) with s_a < s_b."""
    return sorted((p["s"], p["partner_s"], p["multiplier"]) for p in result.contact["points"]
                  if p.get("self") and not p["weak"] and p["s"] < p["partner_s"])


def test_coiled_strip_presses_on_itself_as_shooting_says(coiled):
    r, moment = coiled, M
    assert r.success and r.stable and r.contact["self_contact"], r.message
    pairs = _pairs(r)
    # the middle turn on the outer one, and the tip on the middle turn
    assert len(pairs) == 2 and pairs[1][1] == 1.0 and pairs[0][1] < 1.0
    (a1, b1, f1), (a2, _, f2) = pairs
    ref = coil_reference(lambda s: math.exp(-s), moment, GAP, [True, False], [a2, a1, b1], [f2, f1])
    assert ref["residual"] < 1e-12 and abs(ref["moment_at_tip"] - moment) < 1e-9
    assert abs(r.tip["x"] - ref["tip"][0]) < 1e-8 and abs(r.tip["y"] - ref["tip"][1]) < 1e-8
    assert abs(r.tip["angle"] - ref["tip"][2]) < 1e-7
    assert np.allclose([a2, a1, b1], ref["s"], atol=1e-7)
    assert abs(f2 - ref["force"][0]) < 1e-6 * ref["force"][0]
    assert abs(f1 - ref["force"][1]) < 1e-6 * ref["force"][1]
    # frictionless: the rows push along the turns' common normal (the split rounds converged)
    assert r.contact["tangential_force"] < 1e-6
    # a pair's forces are equal and opposite: no force reaches the clamp
    assert np.allclose(r.contact["total_force"], 0.0, atol=1e-12)
    assert np.allclose(r.clamp_force, 0.0, atol=1e-6) and abs(r.clamp_moment + moment) < 1e-6


def test_coiled_strip_is_below_every_admissible_neighbour(coiled):
    """A constrained minimum: θ + ε δθ (smooth, zero at the clamp) that keeps the rod out of its own
    thickness costs energy, computed here by quadrature on the dense shape (E = ∫ ½ b θ'² − M θ(1))
    and positions integrated from θ; those that would enter it are not admissible."""
    s = np.linspace(0.0, 1.0, 8001)
    _below_every_admissible_neighbour(coiled, lambda th, dth: 0.5 * np.exp(-s) * dth ** 2,
                                      lambda th: -M * th[-1], seed=7)


def _below_every_admissible_neighbour(state, density, end, seed):
    """Assert that θ + ε δθ (60 smooth random δθ, zero at the clamp, ε = ±1e-3, ±1e-2) that keeps
    the rod out of its own thickness costs energy: E = ∫ density(θ, θ') ds + end(θ) by quadrature on
    8001 points of the dense shape, positions integrated from θ (trapezoid), the least distance
    between points more than 2π·gap apart along the rod on every 4th point. Admissible: at least
    as far from itself as the state, or 2·gap (a state lifted off itself may press)."""
    from scipy.spatial import cKDTree

    s = np.linspace(0.0, 1.0, 8001)
    th = state.evaluate(s)["theta"]

    def energy_and_clear(theta):
        dth = np.gradient(theta, s, edge_order=2)
        e = np.trapezoid(density(theta, dth), s) + end(theta)
        x = np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(theta[1:]) + np.cos(theta[:-1])) * np.diff(s))])
        y = np.concatenate([[0.0], np.cumsum(0.5 * (np.sin(theta[1:]) + np.sin(theta[:-1])) * np.diff(s))])
        pts, ss = np.column_stack([x, y])[::4], s[::4]
        near = cKDTree(pts).query_pairs(4 * GAP, output_type="ndarray")  # the least distance is ~2·gap
        near = near[np.abs(ss[near[:, 0]] - ss[near[:, 1]]) >= neighbour_arc(GAP)]
        return e, float(np.min(np.hypot(*(pts[near[:, 0]] - pts[near[:, 1]]).T), initial=4 * GAP))

    e0, d0 = energy_and_clear(th)
    assert d0 > 2 * GAP - 1e-5
    rng = np.random.default_rng(seed)
    admissible = 0
    for _ in range(60):
        c = rng.normal(size=6)
        delta = sum(ck * np.sin((k + 0.5) * math.pi * s) for k, ck in enumerate(c))
        for eps in (1e-3, -1e-3, 1e-2, -1e-2):
            e, d = energy_and_clear(th + eps * delta / np.max(np.abs(delta)))
            if d >= min(d0, 2 * GAP):
                admissible += 1
                assert e > e0, (eps, e - e0)
    assert admissible >= 20


def test_without_self_contact_the_old_answer_enters_its_own_thickness():
    old = solve(coil(), SolverOptions(self_contact=False))
    assert old.success and old.contact is None
    s, t, depth = self_penetration(old, GAP)
    assert depth > 1e-3 and t == 1.0  # the free spiral's tip sinks into the middle turn


def test_a_curl_the_ramp_cannot_follow_is_no_success():
    """A uniform strip with tip moment 7 winds past 2π: its tip comes back to the (point) clamp,
    slips over it and jumps. The ramp from rest stops there and says so; it never reports the
    crossing shape, and without a thickness (or with self-contact off) the crossing is refused."""
    sc = Scene(field=None, tip_moment=7.0, contact_gap=GAP)
    r = solve(sc)
    assert not r.success and "ramp from rest with self-contact stopped" in r.message, r.message
    # the shape reported is the last state reached: the tip pressed on the clamp 2·gap away, the
    # force between them along the line through the clamp, so the clamp holds the applied moment alone
    fraction = float(r.message.split("the last state reached, at ")[1].split(" %")[0]) / 100
    assert 0.9 < fraction < 0.95 and abs(math.hypot(r.tip["x"], r.tip["y"]) - 2 * GAP) < 1e-9
    assert abs(r.clamp_moment + fraction * 7.0) < 1e-6 * 7.0, (r.clamp_moment, fraction)
    for sc2, opts in ((Scene(field=None, tip_moment=7.0), SolverOptions()),
                      (sc, SolverOptions(self_contact=False))):
        refused = solve(sc2, opts)
        assert refused.status == "self_intersecting" and not refused.success
    assert "half-thickness" in solve(Scene(field=None, tip_moment=7.0)).message


def test_candidate_pairs_one_per_stretch_and_never_neighbours():
    """Two parallel strands 2·gap + 0.01 apart, each 40 points long: the distance is a valley
    along them, one pair per neighbour_arc of it; points of one strand are never paired."""
    n = 40
    s = np.linspace(0.01, 1.0, 2 * n)
    x = np.concatenate([np.linspace(0, 0.3, n), np.linspace(0.3, 0, n)])
    y = np.concatenate([np.zeros(n), np.full(n, 2 * GAP + 0.01)])
    pairs = candidate_pairs(s, x, y, GAP, reach=0.05, slots=50, spread=0)
    assert pairs and all(j >= n > i for i, j in pairs)
    starts = sorted(s[i] for i, _ in pairs)
    assert all(b - a >= neighbour_arc(GAP) for a, b in zip(starts, starts[1:]))
    assert len(pairs) <= math.ceil(0.3 / neighbour_arc(GAP)) + 1
    with_spread = candidate_pairs(s, x, y, GAP, reach=0.05, slots=50, spread=1)
    assert set(pairs) <= set(with_spread) and len(with_spread) > len(pairs)


def test_cli_reports_the_rod_against_itself_and_the_switch_restores_the_refusal(capsys, tmp_path):
    import json
    from pathlib import Path

    from actuator_design.cli.main import main
    from actuator_design.config import load_config

    cfg = Path(__file__).resolve().parents[1] / "configs" / "self_contact_coil.yaml"
    assert main(["solve", str(cfg), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    ends = [p for p in data["contact"]["points"] if p["self"]]
    assert data["contact"]["self_contact"] and len(ends) == 4
    assert {p["partner_s"] for p in ends} == {p["s"] for p in ends}  # each end names the other
    moment7 = tmp_path / "m7.yaml"
    moment7.write_text("scene:\n  type: dimensionless\n  tip_moment: 7\n  contact_gap: 0.01\n"
                       "solver:\n  self_contact: false\n")
    assert load_config(moment7).solver.to_options().self_contact is False
    assert main(["solve", str(moment7)]) == 3
    err = capsys.readouterr().err
    assert "self_intersecting" in err and "--no-self-contact" in err


def test_a_physical_rod_has_its_half_thickness_as_gap_and_obstacles_need_a_thickness(tmp_path):
    from actuator_design.config import load_config
    from actuator_design.config.errors import ConfigError

    rod = "  rod: {length: 20 mm, width: 5 mm, thickness: 0.5 mm, youngs_modulus: 1 MPa}\n"
    f = tmp_path / "strip.yaml"
    f.write_text("scene:\n  type: physical\n" + rod + "  loads: {tip_force: {x: 0, y: -1 mN}}\n")
    assert load_config(f).to_scene().contact_gap == pytest.approx(0.25 / 20, rel=1e-12)
    g = tmp_path / "walled.yaml"
    g.write_text("scene:\n  type: physical\n  rod: {length: 20 mm, bending_stiffness: 8e-7 N m^2, area: 1e-5 m^2}\n"
                 "  obstacles:\n    - {type: wall, point: {x: 0, y: -5 mm}, normal_angle: 90 deg}\n")
    with pytest.raises(ConfigError, match="rod.thickness: required with obstacles"):
        load_config(g)


def test_a_loading_path_through_itself_is_no_success():
    """A uniform strip with the tip moment ramped 0 → 8 winds past 2π. Without self-contact the
    path fails at the schedule point where it passes through itself and says why; with it, the tip
    touches down on the (point) clamp where the closed form 2 sin(M/2)/M = 2·gap says and presses on it."""
    from scipy.optimize import brentq

    from actuator_design.continuation.loading import follow_path

    sc = Scene(field=None, tip_moment=0.0, contact_gap=GAP)
    off = SolverOptions(self_contact=False)
    path = follow_path(sc, off, {"m_tip": [0.0, 4.0, 8.0]})
    assert not path.success and "schedule point 2 (m_tip = 8) the rod crosses itself" in path.message, path.message
    # at 6 the tip comes back within 0.047 of the clamp: inside a rod 0.1 thick, outside one 0.02 thick
    assert follow_path(sc, off, {"m_tip": [0.0, 6.0]}).success
    thick = follow_path(replace(sc, contact_gap=0.05), off, {"m_tip": [0.0, 6.0]})
    assert not thick.success and "passes through its own thickness" in thick.message, thick.message
    # with it, up to 6.4 (pressing on the corner), then on to where that turns unstable (slow test below)
    on = follow_path(sc, SolverOptions(), {"m_tip": [0.0, 6.4]})
    exact = brentq(lambda m: 2.0 / m * math.sin(m / 2.0) - 2 * GAP, 5.5, 2 * math.pi, xtol=1e-15)
    (touch,) = on.contact_events
    assert touch["kind"] == "touch-down" and touch["obstacle"] is None and abs(touch["param"] - exact) < 1e-7
    assert on.success and on.final.contact["self_contact"], on.message


@pytest.mark.slow
def test_a_path_pressing_the_tip_on_the_clamp_stops_where_it_turns_unstable():
    """The same strip's path on to 8 stops where the tip pressing on the clamp's corner turns unstable,
    between 6.3 and 7 (the ramp from rest stops at 93.3 % of 7, 6.53); ~65 s of small steps near it."""
    from actuator_design.continuation.loading import follow_path

    on = follow_path(Scene(field=None, tip_moment=0.0, contact_gap=GAP), SolverOptions(), {"m_tip": [0.0, 8.0]})
    assert len(on.contact_events) == 1
    assert not on.success and "unstable" in on.message and 6.3 < on.points[-1].param < 7.0, on.message


@pytest.mark.slow  # ~28 s: a loading path through self-contact (benchmarks)
def test_a_path_follows_the_coil_onto_itself():
    """The coil's tip moment ramped 0 → 8.5: the tip touches down on the middle turn where the free
    spiral θ = M (e^s − 1) first comes 2·gap near itself (Brent on the integrated curve), and the
    path ends on the state shooting gives (the one solve finds from rest)."""
    from actuator_design.continuation.loading import follow_path
    from self_contact_references import free_coil_touch

    path = follow_path(replace(coil(), tip_moment=0.0), SolverOptions(), {"m_tip": [0.0, M]})
    assert path.success and not path.jumps, path.message
    (touch,) = path.contact_events
    assert touch["kind"] == "touch-down" and touch["obstacle_text"] == "rod itself"
    assert abs(touch["param"] - free_coil_touch(1.0, GAP, 7.0, 8.0)) < 1e-8
    end = path.final
    pairs = _pairs(end)
    (a1, b1, f1), (a2, _, f2) = pairs
    ref = coil_reference(lambda s: math.exp(-s), M, GAP, [True, False], [a2, a1, b1], [f2, f1])
    assert abs(end.tip["x"] - ref["tip"][0]) < 1e-8 and abs(end.tip["y"] - ref["tip"][1]) < 1e-8


def test_continuation_stops_where_the_rod_first_touches_itself_and_goes_on_pressing_the_clamp():
    """A uniform strip under a tip moment M is a circle of curvature M; its tip comes back to the
    clamp, 2 sin(M/2)/M away, and touches the rod (2·gap) at the root of that closed form. On with
    contact, the tip presses on the clamp point: it stays 2·gap from it, and the contact force
    passes through the clamp, so the clamp takes the whole applied moment (to M = 6.4: pressing on
    that corner turns unstable near 6.54, where the path stops and says so, a slow test of path)."""
    from scipy.optimize import brentq

    from actuator_design.continuation.follow import continue_branch

    res = continue_branch(Scene(field=None, tip_moment=0.0, contact_gap=GAP), "m_tip", 0.0, 6.4)
    exact = brentq(lambda m: 2.0 / m * math.sin(m / 2.0) - 2 * GAP, 5.5, 2 * math.pi, xtol=1e-15)
    assert res.branch.status == "touch" and "touches itself" in res.branch.message
    assert abs(res.branch.lam[-1] - exact) < 1e-9
    cp = res.contact_path
    (ev,) = cp.contact_events
    assert ev["kind"] == "touch-down" and ev["obstacle"] is None and ev["located"] and abs(ev["param"] - exact) < 1e-9
    assert cp.success and res.complete and cp.points[-1].param == 6.4, cp.message
    for q, r in zip(cp.points[1:], cp.point_states[1:]):
        assert abs(math.hypot(r.tip["x"], r.tip["y"]) - 2 * GAP) < 1e-9
        assert abs(r.clamp_moment + q.param) < 1e-6 and r.stable
    with pytest.raises(RuntimeError, match="touches or passes through itself"):
        continue_branch(Scene(field=None, tip_moment=6.2, contact_gap=GAP), "m_tip", 6.2, 8.0, through_contact=False)
    # a start pressing the clamp, unloaded: it lifts off where it touched down
    down = continue_branch(Scene(field=None, tip_moment=6.3, contact_gap=GAP), "m_tip", 6.3, 5.0)
    (ev,) = down.contact_path.contact_events
    assert down.complete and len(down.branch) == 1 and "touches itself" in down.branch.message
    assert ev["kind"] == "lift-off" and ev["located"] and abs(ev["param"] - exact) < 1e-8


@pytest.mark.parametrize("chord", [0.05, 0.0205, 0.0195])
def test_self_penetration_of_a_circular_strip_against_its_closed_form(chord):
    """A uniform strip under a tip moment M is a circle arc of radius 1/M; its ends are the nearest
    far-apart points, 2 sin(M/2)/M apart. Far (0.05), just clear (0.0205: the coarse pass cannot
    decide, the fine one does) and just inside twice the half-thickness 0.01 (0.0195)."""
    from scipy.optimize import brentq

    moment = brentq(lambda m: 2 * math.sin(m / 2) / m - chord, 5.0, 2 * math.pi - 1e-9, xtol=1e-15)
    r = solve(Scene(field=None, tip_moment=moment, contact_gap=GAP), SolverOptions(keep_self_intersecting=True))
    assert r.success and abs(math.hypot(r.tip["x"], r.tip["y"]) - chord) < 1e-9
    found = self_penetration(r, GAP)
    if chord > 2 * GAP:
        assert found is None
    else:
        s, t, depth = found
        assert (s, t) == (0.0, 1.0) and abs(depth - (2 * GAP - chord)) < 1e-9


def test_the_coil_pressed_on_a_wall_and_on_itself_against_shooting():
    """Self-contact and an obstacle at once: a wall left of the coil presses its outer turn in (the
    centre line 0.04 from x = 0); the shooting reference carries the wall's force and its tangency."""
    from actuator_design.contact.obstacles import Wall

    r = solve(coil(obstacles=(Wall((-0.05, 0.0), 0.0),)))
    assert r.success and r.stable and r.contact["self_contact"], r.message
    pairs = _pairs(r)
    wall = [p for p in r.contact["points"] if p.get("obstacle") == 0 and not p["weak"]]
    assert len(pairs) == 2 and pairs[1][1] == 1.0 and len(wall) == 1
    (a1, b1, f1), (a2, _, f2) = pairs
    ref = coil_reference(lambda s: math.exp(-s), M, GAP, [True, False], [a2, a1, b1], [f2, f1],
                         walls=[((-0.05, 0.0), 0.0)], guess_walls=[(wall[0]["s"], wall[0]["multiplier"])])
    assert ref["residual"] < 1e-11 and abs(ref["moment_at_tip"] - M) < 1e-9
    assert abs(r.tip["x"] - ref["tip"][0]) < 1e-8 and abs(r.tip["y"] - ref["tip"][1]) < 1e-8
    assert abs(r.tip["angle"] - ref["tip"][2]) < 1e-7
    assert np.allclose([a2, a1, b1], ref["s"], atol=1e-6)
    assert abs(f2 - ref["force"][0]) < 1e-6 * ref["force"][0] and abs(f1 - ref["force"][1]) < 1e-6 * ref["force"][1]
    (sw, fw), = ref["walls"]
    assert abs(wall[0]["s"] - sw) < 1e-6 and abs(wall[0]["multiplier"] - fw) < 1e-5 * fw
    # the wall's push is the only external force: the clamp holds it
    assert np.allclose(r.contact["total_force"], (fw, 0.0), atol=1e-5 * fw)
    assert np.allclose(r.clamp_force, (-fw, 0.0), atol=1e-5 * fw)


def test_a_contact_result_judged_inaccurate_while_passing_through_itself_gets_self_contact(monkeypatch):
    """A rod wound round a peg onto itself enters the peg where it passes through its own turn: that
    contact result (inaccurate) is solved again with self-contact, not reported as it is."""
    import actuator_design.contact.equilibrium as contact
    import actuator_design.contact.self_contact as self_contact
    import actuator_design.contact.self_solve as self_solve

    coil = Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01,
                 obstacles=(Peg((5.0, 5.0), 0.1),))
    through = solve(replace(coil, obstacles=()), SolverOptions(keep_self_intersecting=True))
    assert self_contact.self_penetration(through, coil.contact_gap) is not None
    through.success, through.status = False, "inaccurate"
    calls = []
    monkeypatch.setattr(contact, "solve_contact", lambda *a, **k: through)
    monkeypatch.setattr(self_solve, "solve_self_contact", lambda *a, **k: calls.append(a) or "with self-contact")
    assert solve(coil) == "with self-contact" and len(calls) == 1
    # a result that fails for another reason is reported as it is
    through.status = "not_converged"
    assert solve(coil) is through and len(calls) == 1


def test_a_round_that_passed_through_itself_gets_the_crossing_pairs():
    """The split rounds' rule (self_contact.grown_pairs): two straight strands of constrained points
    that cross at (0.25, 0) with no row between them get the pair nearest the crossing (the one
    closer than 2·gap, never neighbours along the rod), after the rows they had; strands kept
    farther apart than 2·gap get none, and no slot is used twice."""
    from types import SimpleNamespace

    from actuator_design.contact.self_contact import grown_pairs

    n = 41  # strand a: s in (0, 0.5] along the x axis; strand b: s in (0.5, 1], crossing it at x = 0.25
    s = np.concatenate([[0.0], np.linspace(0.0125, 0.5, n - 1), np.linspace(0.5125, 1.0, n)])

    def nlp(offset):  # offset 0: strand b crosses a; else b runs back above a, ``offset`` away
        xb = np.full(n, 0.25) if offset == 0.0 else np.linspace(0.5, 0.0, n)
        yb = np.linspace(0.25, -0.25, n) if offset == 0.0 else np.full(n, offset)
        X = np.concatenate([np.linspace(0.0125, 0.5, n - 1), xb])
        Y = np.concatenate([np.zeros(n - 1), yb])
        return SimpleNamespace(f_xy=lambda z: (X, Y), s_self=s, slots=3), X, Y

    crossing, X, Y = nlp(0.0)
    grown = grown_pairs(crossing, GAP, None, ((1, 2),))
    assert grown is not None and grown[0] == (1, 2) and len(grown) >= 2
    for a, b in grown[1:]:
        xa, ya = np.r_[0.0, X][a], np.r_[0.0, Y][a]
        xb, yb = np.r_[0.0, X][b], np.r_[0.0, Y][b]
        assert math.hypot(xa - xb, ya - yb) < 2 * GAP and abs(s[a] - s[b]) >= neighbour_arc(GAP)
        assert abs(xa - 0.25) < 0.02 and abs(xb - 0.25) < 0.02
    assert grown_pairs(crossing, GAP, None, ((1, 2), (3, 4), (5, 6))) is None  # no free slot
    apart, _, _ = nlp(3 * GAP)  # strand b parallel to a, 3·gap above it: clear
    assert grown_pairs(apart, GAP, None, ()) is None


def test_the_ramps_last_state_is_the_first_boundary_round(monkeypatch):
    """The ramp from rest ends with a contact solve at full load on the rounds' first mesh: the
    boundary rounds start from it instead of solving it again, one solve fewer, the same answer as
    when they solve it again (to round-off of the rounds' stopping rule)."""
    calls, seen = [], {}
    counted = equilibrium.solve_once

    def counting(*args, **kwargs):
        calls.append(kwargs.get("fraction", 1.0))
        return counted(*args, **kwargs)

    def captured(scene, options, state, **kwargs):
        seen.update(scene=scene, options=options, state=state, kwargs=kwargs)
        return equilibrium.solve_contact(scene, options, state, **kwargs)

    monkeypatch.setattr(equilibrium, "solve_once", counting)
    monkeypatch.setattr(self_solve, "solve_once", counting)
    monkeypatch.setattr(self_solve, "solve_contact", captured)
    fast = solve(coil())
    assert seen["kwargs"]["first"] is seen["state"] and seen["state"].contact is not None
    rounds_fast = len(calls) - calls.index(1.0) - 1  # the solves after the ramp's last step
    del calls[:]
    kwargs = {k: v for k, v in seen["kwargs"].items() if k != "first"}
    again = equilibrium.solve_contact(seen["scene"], seen["options"], seen["state"], **kwargs)
    assert fast.success and again.success, (fast.message, again.message)
    assert rounds_fast == len(calls) - 1 == fast.contact["boundary_rounds"] - 1
    assert np.allclose(fast.contact["split_at"], again.contact["split_at"], atol=1e-7)
    assert abs(fast.tip["angle"] - again.tip["angle"]) < 1e-7
    assert "the loads ramped in" in fast.message


def test_a_solve_that_stops_at_the_ramps_last_state_names_the_ramp_as_its_start(monkeypatch):
    """The ramp's last state is the first boundary round; when the rounds stop there (here: one
    round allowed), the result's message names where the solve started, as the contact report does."""
    monkeypatch.setattr(equilibrium, "MAX_SPLIT_ROUNDS", 1)
    r = solve(coil())
    assert "(contact, from rest, the loads ramped in" in r.message, r.message
    assert r.contact["start"].startswith("rest, the loads ramped in") and r.contact["boundary_rounds"] == 1


def test_the_ramp_starts_where_the_free_arc_comes_near_itself():
    """A uniform strip under a tip moment M is the arc θ = λ M s on the way from rest (closed form), its
    clamp and tip the nearest pair, 2 sin(κ/2)/κ apart at curvature κ. The contact-free lead-in of the
    self-contact ramp is that arc, and it stops at the last station k/64 before the clamp and the tip
    come within (2 + LEAD_MARGIN)·gap: from there the ramp's rows take over."""
    from actuator_design.contact.self_solve import LEAD_MARGIN, LEAD_STATIONS, free_lead_in
    from actuator_design.equilibrium.acceptance import graded_options
    from actuator_design.equilibrium.solver import get_solver

    moment = 6.4
    sc = Scene(field=None, tip_moment=moment, contact_gap=GAP)
    opts = replace(graded_options(sc, SolverOptions()), split_at=())
    lam, theta = free_lead_in(sc, opts)
    chord = lambda k: 2.0 * math.sin(k * moment / LEAD_STATIONS / 2.0) / (k * moment / LEAD_STATIONS)
    clear = [k for k in range(1, LEAD_STATIONS) if chord(k) >= (2 + LEAD_MARGIN) * GAP]
    assert clear == list(range(1, len(clear) + 1)) and lam == len(clear) / LEAD_STATIONS
    nodes = np.asarray(get_solver(sc, opts).transcription.nodes, float)
    assert np.max(np.abs(theta - lam * moment * nodes)) < 1e-9
    r = solve(sc)
    assert r.success and r.contact["self_contact"] and abs(math.hypot(r.tip["x"], r.tip["y"]) - 2 * GAP) < 1e-9


HARD = {"h_r": 400.0, "beta": "-2.5*pi*s", "phi": 0.5 * math.pi}


def _curled(gap, options=None):
    from actuator_design.model.scene import UniformField

    return solve(Scene(field=UniformField(phi=HARD["phi"]), h_r=HARD["h_r"],
                       magnetization=expression_profile(HARD["beta"]), contact_gap=gap), options)


@pytest.fixture(scope="module")
def curled():
    """Issue 20's strongly curled hard-magnetic strip: a magnetisation turning by 2.5π along it in a
    transverse field winds it until its tip presses on its own body (exit 3 before: the split rounds
    chased the tip between two constrained points for 30 rounds)."""
    from actuator_design.model.scene import UniformField

    return solve(Scene(field=UniformField(phi=HARD["phi"]), h_r=HARD["h_r"],
                       magnetization=expression_profile(HARD["beta"]), contact_gap=GAP))


@pytest.mark.parametrize("gap, levels", [(GAP, None), (0.0125, None), (0.003, None), (GAP, (4, 3))])
def test_a_strongly_curled_hard_magnetic_strip_presses_its_tip_on_itself_as_shooting_says(curled, gap, levels):
    """Also a thin strip (gap 0.003): on the 4 elements of the thick one its constrained points lay
    0.037 apart, and the tip passed between two of them through the body (self_contact_mesh); and
    on a mesh graded by 4 and 3 levels, where the ramp stopped at 83 % when its steps carried the
    contact forces of the step before to Newton on the contact set."""
    from self_contact_references import tip_on_body_reference

    options = None if levels is None else SolverOptions(clamp_levels=levels[0], tip_levels=levels[1])
    r = curled if (gap, levels) == (GAP, None) else _curled(gap, options)
    assert r.success and r.stable and r.contact["self_contact"], r.message
    (s_a, s_b, force), = _pairs(r)
    assert s_b == 1.0 and 0.0 < s_a < 1.0
    tip, body = (next(p for p in r.contact["points"] if p["s"] == s) for s in (1.0, s_a))
    th_a = float(r.evaluate(np.array([s_a]))["theta"][0])
    side = float(np.sign(np.dot([tip["x"] - body["x"], tip["y"] - body["y"]], [-math.sin(th_a), math.cos(th_a)])))
    def shape(s):  # solve_bvp's starting guess: the shape found, perturbed by 1e-3
        e = r.evaluate(s)
        return e["theta"] + 1e-3 * np.sin(s), e["dtheta"], e["x"], e["y"]

    ref = tip_on_body_reference(HARD["h_r"], lambda s: -2.5 * math.pi * s, HARD["phi"], gap, side,
                                (s_a + 1e-3, 1.01 * force), shape)
    assert ref["status"] == 0 and ref["rms"] < 1e-10
    assert abs(r.tip["x"] - ref["tip"][0]) < 1e-8 and abs(r.tip["y"] - ref["tip"][1]) < 1e-8
    assert abs(r.tip["angle"] - ref["tip"][2]) < 1e-7
    assert abs(s_a - ref["s_a"]) < 1e-7 and abs(force - ref["force"]) < 1e-6 * ref["force"]
    assert r.contact["tangential_force"] < 1e-6 * force


def test_the_curled_strip_is_below_every_admissible_neighbour(curled):
    """A constrained minimum, by a second method: the energy ∫ ½θ'² − h_r cos(θ + β − φ) by quadrature
    on the dense shape, against θ + ε δθ (smooth, zero at the clamp) that keeps the rod out of its own
    thickness (positions integrated from θ); those that would enter it are not admissible."""
    beta = -2.5 * math.pi * np.linspace(0.0, 1.0, 8001)
    _below_every_admissible_neighbour(
        curled, lambda th, dth: 0.5 * dth ** 2 - HARD["h_r"] * np.cos(th + beta - HARD["phi"]), lambda th: 0.0, seed=11)


def test_the_lead_in_stops_before_a_branch_point():
    """A strip compressed by an axial dead tip load 60 buckles at the Euler load π²/4 (closed form),
    on the way from rest at λ = π²/240: the contact-free lead-in stops at the last station before it,
    and the kick onto the bent branch is left to the ramp with the contact rows."""
    from actuator_design.contact.self_solve import LEAD_STATIONS, free_lead_in
    from actuator_design.equilibrium.acceptance import graded_options

    sc = Scene(field=None, tip_force=(-60.0, 0.0), contact_gap=0.08)
    lam, theta = free_lead_in(sc, replace(graded_options(sc, SolverOptions()), split_at=()))
    assert lam == math.floor(LEAD_STATIONS * math.pi ** 2 / 240.0) / LEAD_STATIONS
    assert np.max(np.abs(theta)) < 1e-12  # straight until it buckles


def test_a_ramp_that_stops_says_when_its_shape_enters_its_own_thickness():
    """The coil wound by a tip moment 10: the ramp from rest stops (a contact it cannot follow), and
    the last state it reports may come within one gap of itself (the ramp accepts such states on
    the way). Whether it does is measured here on the dense shape (4001 points, points more than
    2π·gap apart along the rod), and the message must say so exactly when it does."""
    from scipy.spatial import cKDTree

    r = solve(coil(tip_moment=10.0))
    assert not r.success and "ramp from rest with self-contact stopped" in r.message, r.message
    d = r.evaluate(np.linspace(0.0, 1.0, 4001))
    pts = np.column_stack([d["x"], d["y"]])
    near = cKDTree(pts).query_pairs(2 * GAP, output_type="ndarray")
    near = near[np.abs(d["s"][near[:, 0]] - d["s"][near[:, 1]]) >= neighbour_arc(GAP)]
    least = float(np.min(np.hypot(*(pts[near[:, 0]] - pts[near[:, 1]]).T), initial=np.inf))
    assert (least < 2 * GAP - 1e-6) == ("enters its own thickness" in r.message), (least, r.message)


@pytest.mark.parametrize("gap", [0.01, 0.003, 0.0004])
def test_the_self_contact_mesh_keeps_its_points_within_three_gaps(gap):
    """The constrained points of the mesh a self-contact solve uses (measured on the contact NLP
    built for it) are at most SELF_SPACING·gap apart, up to SELF_MAX_NODES nodes, and a mesh at that
    cap carries a note saying its points lie farther apart; the graded mesh of the scene itself is
    kept where it is fine enough."""
    from actuator_design.contact.contact_nlp import contact_nlp
    from actuator_design.contact.self_contact import SELF_MAX_NODES, SELF_SPACING, self_contact_mesh, spacing_note
    from actuator_design.equilibrium.solver import get_solver

    sc = coil(contact_gap=gap)
    opts = self_contact_mesh(sc, SolverOptions())
    nlp = contact_nlp(get_solver(sc, opts), sc, True)
    widest = float(np.max(np.diff(nlp.s_self)))
    assert (widest <= SELF_SPACING * gap) == (spacing_note(sc, opts) is None)
    if opts.elements < SELF_MAX_NODES // opts.degree:
        assert widest <= SELF_SPACING * gap
        fewer = contact_nlp(get_solver(sc, replace(opts, elements=opts.elements - 1)), sc, True)
        assert opts.elements == SolverOptions().elements or np.max(np.diff(fewer.s_self)) > SELF_SPACING * gap
    else:
        assert widest > SELF_SPACING * gap and "more than 3 half-thicknesses" in spacing_note(sc, opts)


@pytest.mark.parametrize("degree", [20, 60])
def test_a_strip_thinner_than_the_budget_allows_gets_the_finest_mesh_allowed(degree):
    """A gap of 1e-4 asks for more elements than the memory budget allows at high degree: the mesh
    is the largest that fits (config.limits.mesh_problem, with room for grading and the contact
    points' boundaries), and never an error."""
    from actuator_design.config.limits import mesh_problem
    from actuator_design.contact.self_contact import GRADING_ROOM, self_contact_mesh
    from actuator_design.equilibrium.options import MAX_SPLITS

    from actuator_design.contact.self_contact import SELF_MAX_NODES

    opts = self_contact_mesh(coil(contact_gap=1e-4), SolverOptions(degree=degree))
    extra = opts.clamp_levels + opts.tip_levels + MAX_SPLITS + GRADING_ROOM
    assert mesh_problem("lgl", opts.elements + extra, degree) is None
    assert opts.elements == SELF_MAX_NODES // degree \
        or mesh_problem("lgl", int(opts.elements / 0.9) + 1 + extra, degree) is not None
