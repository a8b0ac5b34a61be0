"""Output in the user's units (issue 9 item 4): round-trips through the dimensionless group, the
schedule's fields and time column, values with units on the command line.

Every reference is computed here by hand from the scene's inputs (THEORY §5:
h² = μ0 χ̄ H² A ℓ² / (2 B0), A = w t, B0 = E w t³ / 12; B = μ0 H), never by the code under test.
"""
import csv
import io
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from actuator_design.schedules.schedule import schedule_table
from actuator_design.config import load_scene
from actuator_design.physics.parameters import parameter
from actuator_design.io.user_units import (length_unit_of, pair_from_text, parameter_from_text,
                                        physical_value_keys, user_units)

ROOT = Path(__file__).resolve().parents[1]
MU0 = 4e-7 * math.pi

# the inputs, in SI, written into the YAML below with units
L, W, T, E, CHI = 20e-3, 5e-3, 1e-3, 1e6, 0.5
RAW = {"name": "units test", "scene": {
    "type": "physical",
    "rod": {"length": "20 mm", "width": "5 mm", "thickness": "1 mm", "youngs_modulus": "1 MPa"},
    "magnetics": {"chi_bar": CHI, "chi_hat": 0},
    "field": {"type": "uniform", "magnitude": "10 mT", "angle": "60 deg"},
    "fibres": "0 deg"}}


def h_per_A_per_m() -> float:
    """dh/dH by hand: h = H √(μ0 χ̄ A ℓ² / (2 B0))."""
    area, b0 = W * T, E * W * T**3 / 12.0
    return math.sqrt(MU0 * CHI * area * L**2 / (2.0 * b0))


def mT_of_h(h: float) -> float:
    return h / h_per_A_per_m() * MU0 * 1e3


@pytest.fixture(scope="module")
def physical():
    scene, _options, raw = load_scene(RAW)
    return scene, user_units(scene, raw)


def test_the_scene_field_is_the_hand_computed_group(physical):
    scene, units = physical
    assert scene.h == pytest.approx(10e-3 / MU0 * h_per_A_per_m(), rel=1e-12)
    assert units.length_unit == "mm" and units.metres_per_unit == pytest.approx(1e-3)


@pytest.mark.parametrize("text, mT", [("10 mT", 10.0), ("2.5 mT", 2.5), ("5 kA/m", 5e3 * MU0 * 1e3),
                                      ("0.03 T", 30.0)])
def test_a_field_in_mT_comes_back_in_mT(physical, text, mT):
    """mT → h (through the scene's scales) → mT, and h equals the hand-computed group."""
    _scene, units = physical
    h = parameter_from_text(text, parameter("h"), units, "--from")
    assert h == pytest.approx(mT * 1e-3 / MU0 * h_per_A_per_m(), rel=1e-12)
    assert units.field_mT(h) == pytest.approx(mT, rel=1e-12)
    assert physical_value_keys(parameter("h"), h, units)["field_mT"] == pytest.approx(mT, rel=1e-12)
    # h2 = h²: the same field squared, and back
    h2 = parameter_from_text(text, parameter("h2"), units, "--from")
    assert h2 == pytest.approx(h * h, rel=1e-12)
    assert physical_value_keys(parameter("h2"), h2, units)["field_mT"] == pytest.approx(mT, rel=1e-12)


def test_lengths_loads_and_angles_round_trip(physical):
    _scene, units = physical
    assert units.length(0.5) == pytest.approx(10.0)  # half of 20 mm
    assert units.length_to_rod(units.length(0.37)) == pytest.approx(0.37)
    b0 = E * W * T**3 / 12.0
    p = parameter_from_text("1 mN", parameter("p"), units, "--from")
    assert p == pytest.approx(1e-3 / (b0 / L**2), rel=1e-12)
    assert physical_value_keys(parameter("p"), p, units)["value_N"] == pytest.approx(1e-3, rel=1e-12)
    assert parameter_from_text("30 deg", parameter("phi"), units, "--from") == pytest.approx(math.pi / 6)
    assert parameter_from_text("0.7", parameter("h"), units, "--from") == 0.7  # plain: dimensionless
    assert pair_from_text("2 mT, 6 mT", parameter("h"), units, "--window") == pytest.approx(
        (2e-3 / MU0 * h_per_A_per_m(), 6e-3 / MU0 * h_per_A_per_m()))


def test_length_unit_as_written_in_the_yaml():
    assert length_unit_of({"scene": {"rod": {"length": "27.5 mm"}}}) == ("mm", pytest.approx(1e-3))
    assert length_unit_of({"scene": {"rod": {"length": "2.75 cm"}}}) == ("cm", pytest.approx(1e-2))
    assert length_unit_of({"scene": {"rod": {"length": 0.0275}}}) == ("m", 1.0)
    assert length_unit_of(None) == ("m", 1.0)


def test_units_are_refused_with_one_clear_line(physical):
    _scene, units = physical
    with pytest.raises(ValueError, match=r"^--window: '2 mT' has a unit, but the scene is dimensionless"):
        parameter_from_text("2 mT", parameter("h"), None, "--window")
    with pytest.raises(ValueError, match=r"^--from: expected an angle"):
        parameter_from_text("2 mT", parameter("phi"), units, "--from")
    with pytest.raises(ValueError, match=r"^--from: expected a magnetic field"):
        parameter_from_text("2 mm", parameter("h"), units, "--from")
    with pytest.raises(ValueError, match=r"^--to: expected a number or a quantity"):
        parameter_from_text("abc", parameter("h"), units, "--to")
    with pytest.raises(ValueError, match="need A < B"):
        pair_from_text("6 mT,2 mT", parameter("h"), units, "--window")


def test_schedule_fields_and_time_column_by_hand(physical):
    """field_mT = h / (dh/dH) μ0 by hand; each step takes max(|ΔB| / rate, |Δφ| / rotation rate)."""
    _scene, units = physical
    h1 = 1e-2 / MU0 * h_per_A_per_m()  # 10 mT
    sched = [{"h": 0.0, "phi": 0.0}, {"h": h1, "phi": 0.0},           # 10 mT at 5 mT/s: 2 s
             {"h": h1, "phi": math.radians(30)},                      # 30° at 30°/s: 1 s
             {"h": 1.1 * h1, "phi": math.radians(90)}]                # 1 mT (0.2 s) vs 60° (2 s): 2 s
    rows = schedule_table(sched, units, field_rate=5e-3 / MU0, rotation_rate=math.radians(30))
    for row, s in zip(rows, sched):
        assert row["field_mT"] == pytest.approx(mT_of_h(s["h"]), rel=1e-12)
        assert row["field_A_per_m"] == pytest.approx(s["h"] / h_per_A_per_m(), rel=1e-12)
        assert row["angle_deg"] == pytest.approx(math.degrees(s["phi"]))
    assert [r["time_s"] for r in rows] == pytest.approx([0.0, 2.0, 3.0, 5.0])
    # only one rate: a change without its rate is an error naming the missing flag, never 0 s
    with pytest.raises(ValueError, match=r"^--rotation-rate: the schedule rotates the field \(step 2, by 30 deg\)"):
        schedule_table(sched, units, field_rate=5e-3 / MU0)
    with pytest.raises(ValueError, match=r"^--rate: the schedule changes the field magnitude \(step 1\)"):
        schedule_table(sched, units, rotation_rate=math.radians(30))
    # a dimensionless scene keeps today's columns; a pure rotation is timed by the rotation rate
    assert list(schedule_table(sched)[0]) == ["step", "h", "phi_rad"]
    turn = [{"h": 1.0, "phi": 0.0}, {"h": 1.0, "phi": math.radians(90)}]
    assert schedule_table(turn, None, rotation_rate=math.radians(30))[-1]["time_s"] == pytest.approx(3.0)
    with pytest.raises(ValueError, match="^--rate: the schedule changes the field magnitude"):
        schedule_table(sched, None, rotation_rate=math.radians(30))
    with pytest.raises(ValueError, match="^--rate: a field rate needs a physical scene"):
        schedule_table(sched, None, field_rate=1.0)


def _cli(*argv, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "actuator_design.cli.main", *argv], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)


@pytest.fixture(scope="module")
def config_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("units") / "physical.yaml"
    path.write_text(yaml.safe_dump(RAW))
    return path


def test_design_schedule_csv_in_mT_with_time(config_file, tmp_path):
    """A physical design's schedule.csv: field_mT from each step's h by hand, and the time column
    re-summed from the rates; the JSON keeps its keys and adds the physical ones."""
    out = tmp_path / "d"
    # the config gives its fibres (0 deg): a design keeps them unless alpha is varied (issue 9 item 3)
    p = _cli("design", str(config_file), "--target-tip", "0.6,0.6", "--tolerance", "none", "--vary", "h,phi,alpha",
             "--rate", "5mT/s", "--rotation-rate", "30deg/s", "--json", "--out", str(out))
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["physical"]["length_unit"] == "mm"
    assert d["physical"]["tip"]["x"] == pytest.approx(d["achieved"]["x"] * 20.0)
    rows = list(csv.DictReader(io.StringIO((out / "schedule.csv").read_text())))
    assert len(rows) == len(d["schedule"]) >= 2
    t = 0.0
    for k, (row, s) in enumerate(zip(rows, d["schedule"])):
        assert {"h", "phi"} <= set(s)  # the existing keys stay
        assert float(row["field_mT"]) == pytest.approx(mT_of_h(float(row["h"])), rel=1e-12)
        assert s["field_mT"] == pytest.approx(mT_of_h(s["h"]), rel=1e-12)
        assert float(row["angle_deg"]) == pytest.approx(math.degrees(float(row["phi_rad"])))
        if k:
            prev = rows[k - 1]
            t += max(abs(float(row["field_mT"]) - float(prev["field_mT"])) / 5.0,
                     abs(float(row["angle_deg"]) - float(prev["angle_deg"])) / 30.0)
        assert float(row["time_s"]) == pytest.approx(t, rel=1e-9, abs=1e-12)
    assert d["physical"]["field_mT"] == pytest.approx(mT_of_h(d["design"]["h"]), rel=1e-12)


def test_critical_field_in_mT_is_the_pitchfork_by_hand(config_file):
    """φ = 90°: the first pitchfork is at h_crit = π/(2√2) (THEORY §6); given a window in mT, the
    reported branch point carries μ0 h_crit / (dh/dH) in mT."""
    p = _cli("critical", str(config_file), "--param", "h", "--window", "20 mT,40 mT", "--phi-deg", "90",
             "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    want = mT_of_h(math.pi / (2 * math.sqrt(2)))
    assert d["window"] == pytest.approx([20e-3 / MU0 * h_per_A_per_m(), 40e-3 / MU0 * h_per_A_per_m()])
    assert d["branch_points"] and all("value" in b for b in d["branch_points"])
    assert d["branch_points"][0]["field_mT"] == pytest.approx(want, rel=1e-6)
    assert d["branch_points"][0]["field_A_per_m"] == pytest.approx(want * 1e-3 / MU0, rel=1e-6)


def test_bad_units_on_the_command_line_exit_2_with_one_line(config_file):
    p = _cli("critical", "--param", "h", "--window", "2 mT,6 mT")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "--window" in p.stderr and "dimensionless" in p.stderr
    p = _cli("design", "--target-tip", "0.3,0.5", "--rate", "5 mT/s")
    assert p.returncode == 2 and "--rate" in p.stderr and "physical scene" in p.stderr
    p = _cli("design", str(config_file), "--target-tip", "0.3,0.5", "--rotation-rate", "5 mT/s")
    assert p.returncode == 2 and "--rotation-rate" in p.stderr and "rotation rate" in p.stderr
    p = _cli("continue", str(config_file), "--param", "theta0", "--from", "1 mT", "--to", "0.2")
    assert p.returncode == 2 and "--from" in p.stderr


def test_schedule_command_files_carry_the_physical_columns(physical):
    """The `schedule` command's JSON and CSV (built from a hand-made result, no solve): each step
    keeps h, phi and gains field_mT by hand and time_s; waypoints in mm (20 mm rod)."""
    from actuator_design.schedules.schedule import ScheduleResult
    from actuator_design.cli.schedule import _output_files, _payload

    scene, units = physical
    h1 = 2e-2 / MU0 * h_per_A_per_m()  # 20 mT
    sched = [{"h": 0.0, "phi": 0.3}, {"h": h1, "phi": 0.3}, {"h": h1, "phi": 0.3 + math.radians(15)}]
    row = {"waypoint": 0, "target_x": 0.5, "target_y": 0.25, "x": 0.5, "y": 0.25, "angle": 0.1, "h": h1,
           "phi": 0.3, "error": 0.0, "margin": 1.0}
    res = ScheduleResult(True, True, True, True, [(0.5, 0.25), (0.6, 0.4)], [row], sched, [1, 2], "ok", scene)
    table = schedule_table(sched, units, field_rate=5e-3 / MU0, rotation_rate=math.radians(30))
    payload = _payload(res, units, table)
    assert [s["time_s"] for s in payload["schedule"]] == pytest.approx([0.0, 4.0, 4.5])
    assert payload["schedule"][1]["field_mT"] == pytest.approx(20.0) and payload["schedule"][1]["h"] == h1
    assert res.schedule[1] == {"h": h1, "phi": 0.3}  # the result itself is not changed
    wp = payload["physical"]["waypoints"][0]
    assert (wp["target_x"], wp["target_y"], wp["field_mT"]) == pytest.approx((10.0, 5.0, 20.0))
    files = _output_files(res, None, payload, table, units)
    rows = list(csv.DictReader(io.StringIO(files["schedule.csv"])))
    assert [float(r["field_mT"]) for r in rows] == pytest.approx([mT_of_h(s["h"]) for s in sched], rel=1e-12)
    assert [float(r["time_s"]) for r in rows] == pytest.approx([0.0, 4.0, 4.5])
    assert json.loads(files["schedule.json"])["schedule"][2]["angle_deg"] == pytest.approx(math.degrees(0.3) + 15)


def test_a_rate_without_the_other_is_refused_before_any_solve(config_file):
    """A design schedule ramps and rotates: one rate alone would time the other change as 0 s."""
    p = _cli("design", str(config_file), "--target-tip", "0.3,0.5", "--rate", "5mT/s")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("actuator-design: error: --rotation-rate")
    p = _cli("design", str(config_file), "--target-tip", "0.3,0.5;0.6,0.2", "--rotation-rate", "30deg/s")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and p.stderr.startswith("actuator-design: error: --rate")


def test_multi_pose_design_in_the_scenes_units(config_file, tmp_path):
    """Several poses on a physical scene: per pose the target and tip in mm and the field in mT by
    hand; the schedule in mT and degrees with time_s re-summed from the rates, in JSON and CSV."""
    out = tmp_path / "poses"
    # (two poses of the design benchmark's grid whose design agrees on both OpenBLAS kernels tried)
    p = _cli("design", str(config_file), "--target-tip", "13.02276,10.92738;16.42074,4.39992", "--target-units", "mm",
             "--vary", "h,phi,alpha", "--rate", "5mT/s", "--rotation-rate", "30deg/s", "--json",
             "--out", str(out), timeout=600)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    phys = d["physical"]
    assert phys["length_unit"] == "mm" and len(phys["poses"]) == 2
    assert d["quasi_static"] is None  # timed, but no rod.density: not checked, and said so
    for q, pose, want in zip(phys["poses"], d["poses"], [(13.02276, 10.92738), (16.42074, 4.39992)]):
        assert (q["target"]["x"], q["target"]["y"]) == pytest.approx(want, rel=1e-12)
        assert q["tip"]["x"] == pytest.approx(pose["achieved"]["x"] * 20.0, rel=1e-12)
        assert q["field_mT"] == pytest.approx(mT_of_h(pose["design"]["h"]), rel=1e-12)
        assert q["angle_deg"] == pytest.approx(math.degrees(pose["design"]["phi"]))
    rows = list(csv.DictReader(io.StringIO((out / "schedule.csv").read_text())))
    assert len(rows) == len(d["schedule"]) >= 2
    t = 0.0
    for k, (row, s) in enumerate(zip(rows, d["schedule"])):
        assert float(row["field_mT"]) == pytest.approx(mT_of_h(float(row["h"])), rel=1e-12, abs=1e-12)
        assert s["time_s"] == pytest.approx(float(row["time_s"]), rel=1e-12, abs=1e-12)
        if k:
            prev = rows[k - 1]
            t += max(abs(float(row["field_mT"]) - float(prev["field_mT"])) / 5.0,
                     abs(float(row["angle_deg"]) - float(prev["angle_deg"])) / 30.0)
        assert float(row["time_s"]) == pytest.approx(t, rel=1e-9, abs=1e-12)
    assert t > 0
