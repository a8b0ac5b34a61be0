"""The design and schedule commands: JSON contracts, exit codes, outputs."""
import json
import math

import pytest

from actuator_design.cli.main import main


def _json(capsys):
    out = capsys.readouterr().out
    return json.loads(out)


def test_main_job_contract(capsys, tmp_path):
    """The README's main job: a verified, stable, snap-free design within 1e-3 of (0.3, 0.5).

    (0.3, 0.5) needs the rod to curl past vertical, which a uniform field on straight fibres cannot
    do (the fibres only align with the field axis): the tool adds α(s) and says so."""
    code = main(["design", "--target-tip", "0.3,0.5", "--json", "--out", str(tmp_path / "d")])
    d = _json(capsys)
    assert code == 0
    for key in ("success", "reachable", "verified", "stable", "snap_free", "target", "achieved", "error",
                "design", "schedule"):
        assert key in d
    assert d["success"] and d["verified"] and d["stable"] and d["snap_free"] and d["reachable"]
    assert math.hypot(d["achieved"]["x"] - 0.3, d["achieved"]["y"] - 0.5) < 1e-3
    assert set(d["design"]) >= {"h", "phi", "p", "alpha"}
    assert len(d["design"]["alpha"]["s"]) == len(d["design"]["alpha"]["value"]) >= 101
    assert "alpha" in d["vary"] and "cannot reach" in d["message"]
    h_phi_only = [o for o in d["optima"] if o["vary"] == ["h", "phi"]]
    assert h_phi_only and min(o["error"] for o in h_phi_only) > 1e-2
    assert d["schedule"][0]["h"] == 0.0
    assert d["schedule"][-1]["h"] == pytest.approx(d["design"]["h"])
    assert {p.name for p in (tmp_path / "d").iterdir()} >= {"design.json", "schedule.csv", "design.png", "shape.csv"}


def test_unreachable_target_has_its_own_exit_code(capsys):
    code = main(["design", "--target-tip", "1.3,0.5", "--vary", "h,phi", "--json"])
    d = _json(capsys)
    assert code == 4
    assert not d["reachable"] and not d["success"]
    assert d["error"] >= math.hypot(1.3, 0.5) - 1.0 - 1e-12


@pytest.mark.parametrize("argv,field", [
    (["design"], "--target-tip"),
    (["design", "--target-tip", "0.3"], "--target-tip"),
    (["design", "--target-tip", "0.3,nan"], "--target-tip"),
    (["design", "--target-tip", "0.3,0.5", "--vary", "h,gamma"], "--vary"),
    (["design", "--target-stiffness", "-2"], "--target-stiffness"),
    (["design", "--target-stiffness", "2 N/m"], "--target-stiffness"),
    (["schedule", "--waypoints", "0.9,0.1"], "--waypoints"),
    (["schedule", "--waypoints", "0.9,0.1;abc"], "--waypoints"),
])
def test_bad_design_input_exits_2_and_writes_nothing(capsys, tmp_path, argv, field):
    out = tmp_path / "o"
    code = main(argv + ["--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and field in err[0]
    assert not out.exists()


# -- issue 9 item 6: defects found when tried as a new user would (CLI subprocess tests) ------------
import csv
import re
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from result_invariants import design_contradictions

ROOT = Path(__file__).resolve().parents[1]


def _cli(*argv, timeout=300):
    """Run ``actuator-design`` in a subprocess on this checkout's code."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "actuator_design.cli.main", *argv], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)


def test_stiffness_only_design_writes_its_files(tmp_path):
    """``design --target-stiffness 5 --out`` crashed after printing SUCCESS (the figure wanted a target
    pose). The files are written, and the designed axial field gives the straight rod the stiffness
    5 by THEORY §6's closed form s(h) (not by the design code's own measure)."""
    from actuator_design.reference.closed_forms import lowload_stiffness

    out = tmp_path / "k"
    p = _cli("design", "--target-stiffness", "5", "--json", "--out", str(out))
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["success"] and not design_contradictions(d)
    assert float(lowload_stiffness(d["design"]["h"])) == pytest.approx(5.0, rel=1e-6)
    assert {f.name for f in out.iterdir()} >= {"design.json", "schedule.csv", "design.png", "shape.csv"}
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize("angle_deg,expected_deg", [(1e6, -80.0), (-1e6, 80.0), (360.0 * 7 + 10.0, 10.0)])
def test_target_angles_are_taken_modulo_360(angle_deg, expected_deg):
    """1e6 = 2778·360 − 80 (integer arithmetic): the target angle is −80°. It ran for minutes before;
    now it finishes (the subprocess timeout is the bound) with a consistent verdict."""
    p = _cli("design", "--target-tip", f"0.3,0.5,{angle_deg!r}", "--json", timeout=240)
    assert p.returncode in (0, 3, 4), p.stderr
    d = json.loads(p.stdout)
    assert d["target"]["angle"] == pytest.approx(math.radians(expected_deg), abs=1e-12)
    assert not design_contradictions(d)


def test_astronomical_target_angle_is_finite_work():
    """1e300 deg gave a KeyError: it is a finite angle, reduced modulo 360 into [−180°, 180°]."""
    p = _cli("design", "--target-tip", "0.3,0.5,1e300", "--json", timeout=240)
    assert p.returncode in (0, 3, 4), p.stderr
    d = json.loads(p.stdout)
    assert abs(d["target"]["angle"]) <= math.pi
    assert not design_contradictions(d)
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize("argv,field", [
    (["--target-tip", "0.3,0.5,inf"], "--target-tip"),
    (["--target-tip", "0.3,0.5,1e400"], "--target-tip"),
    (["--target-tip", "0.3,0.5", "--time-limit", "0"], "time_limit"),
])
def test_non_finite_targets_and_bad_budgets_exit_2(tmp_path, argv, field):
    out = tmp_path / "o"
    p = _cli("design", *argv, "--out", str(out))
    err = p.stderr.strip().splitlines()
    assert p.returncode == 2
    assert len(err) == 1 and field in err[0]
    assert not out.exists()


def _numbers(path):
    """Every data cell of a CSV (comment lines skipped) parsed as a float."""
    rows = [r for r in csv.reader(line for line in path.read_text().splitlines() if not line.startswith("#"))]
    header, body = rows[0], rows[1:]
    return header, np.array([[float(c) for c in r] for r in body])


def test_branch_csv_holds_plain_numbers(tmp_path):
    """``branch.csv`` held ``np.float64(0.05)``. Below h₁ = π/(2√2) (THEORY §6) the transverse field
    leaves the straight rod the stable state: tip (1, 0), angle 0, on every row."""
    out = tmp_path / "c"
    p = _cli("continue", "--param", "h", "--phi-deg", "90", "--from", "0", "--to", "1", "--out", str(out))
    assert p.returncode == 0, p.stderr
    header, table = _numbers(out / "branch.csv")
    col = {name: table[:, k] for k, name in enumerate(header)}
    assert len(table) >= 3 and col["value"].max() == pytest.approx(1.0)
    assert np.allclose(col["tip_x"], 1.0, atol=1e-9) and np.allclose(col["tip_y"], 0.0, atol=1e-9)
    assert np.allclose(col["tip_angle"], 0.0, atol=1e-9) and np.all(col["stable"] == 1)


def test_map_csv_holds_plain_numbers(tmp_path):
    """``map.csv`` held ``np.float64(…)``: its grid columns are the requested uniform grid."""
    out = tmp_path / "m"
    p = _cli("map", "--x-param", "h2", "--x-range", "0,2", "--y-param", "p", "--y-range", "0,1", "--n", "3",
             "--no-curves", "--quiet", "--out", str(out))
    assert p.returncode == 0, p.stderr
    header, table = _numbers(out / "map.csv")
    assert header == ["h2", "p", "equilibria", "stable"]
    assert sorted(set(table[:, 0])) == pytest.approx([0.0, 1.0, 2.0])
    assert sorted(set(table[:, 1])) == pytest.approx([0.0, 0.5, 1.0])
    assert np.all(table[:, 2] >= 1)


def test_main_job_prints_one_field_angle_and_says_it_is_an_axis(tmp_path):
    """The design line printed φ = −22.3° and the schedule line 157.7°. Now the design line prints the
    angle the schedule ends at and names its representative in (−90°, 90°] as the same axis; a forward
    solve at either angle (from the straight rod, same fibres) gives the same state, as it must."""
    from dataclasses import replace as dc_replace

    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.model.profiles import table_profile
    from actuator_design.model.scene import default_scene

    out = tmp_path / "d"
    p = _cli("design", "--target-tip", "0.3,0.5", "--out", str(out))
    assert p.returncode == 0, p.stderr
    text = p.stdout
    design_line = next(line for line in text.splitlines() if line.strip().startswith("design"))
    sched_line = next(line for line in text.splitlines() if line.strip().startswith("schedule"))
    m = re.search(r"phi = (\S+) deg \(field axis, the same as (\S+) deg\)", design_line)
    end = float(re.search(r"at phi = (\S+) deg", sched_line).group(1))
    d = json.loads((out / "design.json").read_text())
    assert not design_contradictions(d)
    # the README shows this output verbatim, except the lines it says vary by machine
    readme = (ROOT / "README.md").read_text()
    block = readme.split("What the design prints")[1].split("```")[1].strip("\n").splitlines()
    mask = lambda lines: [re.sub(r"error \S+$", "error E", line) for line in lines
                          if not line.strip().startswith(("time", "wrote"))]
    assert mask(block) == mask(text.strip("\n").splitlines())
    if m is None:  # the schedule ends at the design's own representative
        assert "phi = " in design_line and end == pytest.approx(math.degrees(d["design"]["phi"]), abs=1e-3)
        return
    shown, same = float(m.group(1)), float(m.group(2))
    assert shown == pytest.approx(end, abs=1e-9)
    assert -90.0 < same <= 90.0 and same == pytest.approx(math.degrees(d["design"]["phi"]), abs=1e-3)
    turns = (shown - same) / 180.0
    assert abs(turns - round(turns)) < 1e-4 and round(turns) != 0
    assert math.degrees(d["schedule"][-1]["phi"]) == pytest.approx(shown, abs=1e-3)
    a = d["design"]["alpha"]  # the printed angles are rounded: solve at the JSON's exact ones
    scenes = [dc_replace(default_scene(h=d["design"]["h"], phi=v), fibres=table_profile(a["s"], a["value"]))
              for v in (d["schedule"][-1]["phi"], d["design"]["phi"])]
    r1, r2 = (solve(sc) for sc in scenes)
    assert r1.success and r2.success
    assert np.allclose([r1.tip[k] for k in ("x", "y", "angle")], [r2.tip[k] for k in ("x", "y", "angle")], atol=1e-8)


def test_summary_of_a_failed_search_with_the_fibre_layout_prints():
    """When no variable set yields a stable optimum, the design has no α(s): the text summary (which
    raised KeyError 'alpha') prints the verdict and the reason."""
    import time

    from actuator_design.inverse.design import _no_design, design_problem
    from actuator_design.cli.design import _summary

    problem = design_problem((0.3, 0.5), None, ["h", "phi", "alpha"], None, None, None, time.perf_counter())
    res = _no_design(problem, {"total": 0.0})
    text = _summary(res)
    assert "unreachable target" in text and "no stable design of h, phi, alpha" in text
    assert not design_contradictions(res.to_dict())
