"""Schedules over coil currents (issue 19 item 3): the controls-only optimal-control NLP against
closed forms of slew-limited ramps, the lens' source weights, the CLI's bad input in one line, and
(slow) the shipped example: verified from zero currents, no hungrier (energy) or slower (time) than
the greedy schedule, every limit recomputed here at every step from the reported currents, and each
waypoint's currents checked by an independent solve from rest on magpylib's field refitted there."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design.physics import parameters as lens
from actuator_design.schedules.current_schedule_nlp import CurrentOCP
from actuator_design.cli.main import main
from actuator_design.model.scene import default_scene

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "coils_schedule.yaml"


def _ocp(nodes, waypoint_nodes, bound, rates, effort, objective, power=None, max_power=math.inf):
    return CurrentOCP(nodes, waypoint_nodes, np.asarray(bound, float), np.asarray(rates, float),
                      np.asarray(effort, float), power, max_power, objective)


def _start(nodes, waypoint_nodes, pinned, dt=0.5):
    u = np.zeros((nodes, len(pinned[0])))
    for k, w in zip(waypoint_nodes, pinned):
        u[k] = w
    return u, np.full(nodes - 1, dt)


@pytest.mark.parametrize("objective", ["time", "energy"])
@pytest.mark.parametrize("start", ["line", "jump"])
def test_one_coil_ramp_is_the_slew_limited_line(objective, start):
    """0 → I at slew s: the least energy ∫ R I² dt is R I² (I/s) / 3, a ramp at s (closed form; from
    a straight start or one that jumps in the last step), and the fastest schedule, like the energy's
    from the straight start the greedy schedule gives, lasts T = I/s."""
    I, s, R = 3.0, 20.0, 2.5
    ocp = _ocp(9, [8], [8.0], [s], [R], objective)
    u0, dt0 = _start(9, [8], [[I]])
    if start == "line":
        u0[:, 0] = np.linspace(0.0, I, 9)
    got = ocp.solve(u0, dt0, pinned=np.array([[I]]))
    times = np.concatenate([[0.0], np.cumsum(got["dt"])])
    u = got["u"][:, 0]
    energy = float(np.sum(np.diff(times) * R * (u[:-1] ** 2 + u[:-1] * u[1:] + u[1:] ** 2) / 3))
    assert energy == pytest.approx(R * I ** 2 * (I / s) / 3, rel=1e-6)
    assert np.all(np.abs(np.diff(u)) <= s * got["dt"] * (1 + 1e-7) + 1e-12)
    # (the least-energy schedules ramp in m of the 8 steps, m dt = I/s, all alike in energy: the
    # fastest of them is the whole leg's ramp, whatever the start)
    assert times[-1] == pytest.approx(I / s, rel=1e-7)


def test_two_coils_leg_time_is_the_slowest_coil():
    """Two coils, two legs, minimum time: each leg lasts max_k |ΔI_k| / s_k (closed form)."""
    pinned = np.array([[2.0, -1.0], [0.5, 3.0]])
    s = np.array([10.0, 4.0])
    ocp = _ocp(11, [5, 10], [8.0, 8.0], s, [1.0, 1.0], "time")
    got = ocp.solve(*_start(11, [5, 10], pinned), pinned=pinned)
    legs = [float(np.sum(got["dt"][:5])), float(np.sum(got["dt"][5:]))]
    assert legs[0] == pytest.approx(max(np.abs(pinned[0]) / s), rel=1e-7)
    assert legs[1] == pytest.approx(max(np.abs(pinned[1] - pinned[0]) / s), rel=1e-7)


def test_power_limit_binds_at_the_nodes():
    """A power row below the pinned currents' power makes the NLP infeasible (None); above it, every
    node's Σ R I² stays within it."""
    R = np.array([2.0, 3.0])
    pinned = np.array([[2.0, 1.0]])
    need = float(R @ pinned[0] ** 2)
    low = _ocp(6, [5], [8.0, 8.0], [10.0, 10.0], R, "energy", power=R, max_power=0.9 * need)
    assert low.solve(*_start(6, [5], pinned), pinned=pinned) is None
    ok = _ocp(6, [5], [8.0, 8.0], [10.0, 10.0], R, "energy", power=R, max_power=1.01 * need)
    got = ok.solve(*_start(6, [5], pinned), pinned=pinned)
    assert np.max(got["u"] ** 2 @ R) <= 1.01 * need * (1 + 1e-8)


@pytest.mark.parametrize("objective", ["time", "energy"])
def test_a_repeated_waypoint_takes_no_time(objective):
    """Two equal waypoints: holding the current costs R I² per second, so the second leg lasts 0
    (never less: time does not run backwards), and the first is the ramp 0 → I at full slew."""
    pinned = np.array([[2.0], [2.0]])
    ocp = _ocp(7, [3, 6], [8.0], [20.0], [1.0], objective)
    got = ocp.solve(*_start(7, [3, 6], pinned), pinned=pinned)
    assert np.all(got["dt"] >= 0.0)
    assert float(np.sum(got["dt"][3:])) <= 1e-9
    assert float(np.sum(got["dt"][:3])) == pytest.approx(2.0 / 20.0, rel=1e-7)


def test_source_weight_is_a_lens_entry_only_for_source_fields():
    sc = default_scene(h=1.0)
    with pytest.raises(ValueError, match=r"^source_weight_0: the scene's field has no source 1"):
        lens.parameter("source_weight_0").set(sc, 0.5)
    assert "source_weight_0" not in lens.names()  # not listed among the user's scene parameters
    assert lens.parameter("source_weight_40").slot == "source_weight_40"  # any number of sources
    with pytest.raises(ValueError, match="unknown parameter 'source_weight_x'"):
        lens.parameter("source_weight_x")


def test_coil_schedule_arguments_are_checked_before_any_solve():
    from actuator_design.schedules.current_schedule import current_schedule
    from actuator_design.config import load_scene

    scene = load_scene(CONFIG)[0]
    wps = [(0.98, 0.18), (0.93, 0.34)]
    for kwargs, message in ((dict(substeps=0), r"^substeps: must be a whole number in \[1, 200\], got 0"),
                            (dict(nodes=2), r"^nodes: must be a whole number in \[3, 200\]"),
                            (dict(objective="power"), r"^objective: must be one of time, energy")):
        with pytest.raises(ValueError, match=message):
            current_schedule(scene, wps, 20.0, **kwargs)
    with pytest.raises(ValueError, match=r"^slew: one finite rate > 0"):
        current_schedule(scene, wps, [20.0, 0.0])


def test_cli_bad_input_one_line(tmp_path, capsys):
    dimless = tmp_path / "d.yaml"
    dimless.write_text("scene: {type: dimensionless, h: 0}\n")
    assert main(["schedule", str(dimless), "--waypoints", "0.9,0.3;0.8,0.5", "--slew-rate", "20A/s"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("actuator-design: error: --slew-rate: only for a scene whose field comes from coils")


@pytest.mark.parametrize("flags, message", [
    (["--slew-rate", "20 A"], "--slew-rate: expected a rate of change of a current"),
    (["--slew-rate", "20A/s,10A/s,5A/s"], "--slew-rate: give one rate for every coil or one per coil (2), got 3"),
    (["--slew-rate=-5A/s"], "--slew-rate: must be > 0"),
    (["--rotation-rate", "30deg/s"], "--rotation-rate: the scene's field comes from coils"),
    (["--nodes", "3"], "--nodes: must be a whole number in [4, 200]"),
    (["--substeps", "0"], "--substeps: must be a whole number in [1, 200]"),
])
def test_cli_coil_schedule_bad_flags(flags, message, capsys, tmp_path):
    out = tmp_path / "out"
    assert main(["schedule", str(CONFIG), "--out", str(out), *flags]) == 2
    assert message in capsys.readouterr().err.strip().splitlines()[-1]
    assert not out.exists()  # never a half-written output


def _check_limits(payload, config):
    """Every limit at every step, recomputed from the reported currents and times."""
    import yaml

    coils = yaml.safe_load(config.read_text())["scene"]["field"]["coils"]
    R = np.array([float(c["resistance"].split()[0]) for c in coils])
    imax = np.array([float(c["max_current"].split()[0]) for c in coils])
    steps = payload["schedule"]
    t = np.array([s["time_s"] for s in steps])
    cur = np.array([s["currents_A"] for s in steps])
    assert np.all(cur[0] == 0.0)  # from zero currents
    assert np.all(np.abs(cur) <= imax * (1 + 1e-9))
    assert np.max(cur ** 2 @ R) <= 200.0 * (1 + 1e-9)
    assert np.all(np.abs(np.diff(cur, axis=0)) <= 20.0 * np.diff(t)[:, None] * (1 + 1e-6) + 1e-12)
    energy = float(np.diff(t) @ (((cur[:-1] ** 2 + cur[:-1] * cur[1:] + cur[1:] ** 2) / 3) @ R))
    assert energy == pytest.approx(payload["energy_J"], rel=1e-9)
    return cur


@pytest.mark.slow
@pytest.mark.parametrize("objective", ["energy", "time"])
def test_shipped_coil_schedule(objective, capsys, tmp_path):
    from actuator_design.hardware.current_design import scene_at_currents
    from actuator_design.config import load_scene
    from actuator_design.equilibrium.pipeline import solve

    rc = main(["schedule", str(CONFIG), "--optimal-control", objective, "--json", "--out", str(tmp_path)])
    payload = json.loads(capsys.readouterr().out)
    assert rc == 0 and payload["success"] and payload["optimal"], payload["message"]
    key = "energy_J" if objective == "energy" else "duration_s"
    assert payload[key] <= payload["greedy"][key] * (1 + 1e-6)
    cur = _check_limits(payload, CONFIG)
    scene = load_scene(CONFIG)[0]
    for row, k in zip(payload["rows"], payload["waypoint_index"]):
        # an independent check of each waypoint: magpylib refitted at its currents, solved from rest
        refit = scene_at_currents(scene, cur[k])
        r = solve(refit)
        assert r.success and r.stable
        assert max(abs(r.tip["x"] - row["target_x"]), abs(r.tip["y"] - row["target_y"])) <= 1e-6
        h = _field_on(refit, r)  # |μ0 H| on the rod there, from the refitted field, within max_field
        assert h <= 40.0
    assert {"schedule.json", "schedule.csv", "waypoints.csv", "schedule.png"} <= {p.name for p in tmp_path.iterdir()}
    # issue 19 item 4: step 0 (coils off, the straight strip) relaxes in 1/(ζ β₁²) √(ρA ℓ⁴/B), β₁² = 3.51602;
    # a step is flagged exactly when it is shorter than its state's relaxation time
    B, rho_a = 1e6 * 5e-3 * 0.5e-3 ** 3 / 12, 1780.0 * 5e-3 * 0.5e-3
    steps = payload["schedule"]
    assert steps[0]["relaxation_time_s"] == pytest.approx(1 / (0.1 * 3.5160152) * math.sqrt(rho_a * 0.02 ** 4 / B),
                                                          rel=1e-6)
    for a, b in zip(steps, steps[1:]):
        assert b["quasi_static"] == (b["time_s"] - a["time_s"] >= b["relaxation_time_s"])
    assert payload["quasi_static"]["slowest_relaxation_time_s"] == max(s["relaxation_time_s"] for s in steps)


def _field_on(scene, state) -> float:
    """|μ0 H| (mT) at the nodes of ``state`` in ``scene``'s own field (its fit at its currents)."""
    from actuator_design.physics.fields import field_model
    from actuator_design.model.units import MU0

    model = field_model(scene.field)
    hx, hy = model.evaluate(state.x, state.y, model.parameter_values(scene.field))
    return float(np.max(np.hypot(hx, hy))) * scene.scales.field * MU0 * 1e3


@pytest.mark.slow
def test_a_failed_optimal_control_reports_the_greedy_schedule_verified(monkeypatch, capsys):
    """When the NLP does not converge the greedy schedule is reported, replayed from zero currents
    and checked against every limit like the optimised one."""
    from actuator_design.schedules import current_schedule_nlp

    def fail(self, *args, **kwargs):
        self.status = "Maximum_Iterations_Exceeded"
        return None

    monkeypatch.setattr(current_schedule_nlp.CurrentOCP, "solve", fail)
    assert main(["schedule", str(CONFIG), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["success"] and not payload["optimal"]
    assert payload["ocp_status"] == "Maximum_Iterations_Exceeded"
    assert "did not converge (Maximum_Iterations_Exceeded): the greedy schedule is reported" in payload["message"]
    keys = ("step", "time_s", "currents_A")  # (the reported steps add their relaxation times)
    assert [{k: s[k] for k in keys} for s in payload["schedule"]] == payload["greedy"]["schedule"]
    _check_limits(payload, CONFIG)
    assert payload["extremes"]["least_eigenvalue"] >= 1e-2
