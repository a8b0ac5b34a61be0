"""Sweep studies: grids with units, the study folder, resuming without recomputing, parallel runs.

Numbers in the tables are checked against independent references: THEORY §6's closed form for the
transverse buckling angle and THEORY §5's definition of h from SI inputs. Resuming is checked by
what is *not* recomputed (journal records kept byte-identical, the run's computed count) after a
real interruption (SIGINT to a running process) and after a journal with a torn last line.
"""
import copy
import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from actuator_design.analysis import registry
from actuator_design.cli.main import main
from actuator_design.config import ConfigError
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.study.grid import grid_indices, resolve_axes
from actuator_design.study.runner import StudyError, plan_study, run_study
from actuator_design.config.studies.sweep import SweepSpec
from actuator_design.config.studies.validation import validate_spec

MU0 = 4e-7 * math.pi
ROOT = Path(__file__).resolve().parents[1]

TRANSVERSE = {
    "name": "transverse test sweep",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "grid": "cartesian",
              "sweep": {"h": [0.5, 1.0, 1.5, 2.0], "phi": ["90 deg"]},
              "analyses": ["solve"]},
}

PHYSICAL = {
    "name": "physical test sweep",
    "scene": {"type": "physical",
              "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm",
                      "youngs_modulus": "1 MPa"},
              "magnetics": {"chi_bar": 0.5},
              "field": {"type": "uniform", "magnitude": "1 kA/m", "angle": "0 deg"}},
    "study": {"type": "sweep", "grid": "zip",
              "sweep": {"field.magnitude": ["5 kA/m", "10 mT", "0.5e4 A/m"],
                        "field.angle": ["0 deg", "30 deg", "1 rad"]},
              "analyses": ["solve"], "outputs": ["solve.h", "solve.phi", "solve.tip.*"]},
}


def _read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _journal_lines(path):
    return Path(path).read_text().splitlines()


# -- grids and validation ----------------------------------------------------------------------------
def test_cartesian_and_zip_grids_with_units():
    spec = validate_spec(SweepSpec, {"type": "sweep", "sweep": {
        "field.magnitude": {"from": "0 kA/m", "to": "10000 A/m", "n": 3},
        "field.angle": ["0 deg", "0.5 rad"]}})
    axes = resolve_axes(spec)
    assert axes[0].unit == "kA/m" and axes[0].numbers == (0.0, 5.0, 10.0)
    assert axes[0].column == "field.magnitude [kA/m]"
    assert axes[1].unit == "deg" and axes[1].numbers[1] == pytest.approx(math.degrees(0.5))
    assert grid_indices(axes, "cartesian") == [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]
    spec = validate_spec(SweepSpec, {"type": "sweep", "grid": "zip",
                                     "sweep": {"h": [1, 2, 3], "phi": [0, 0.1, 0.2]}})
    assert grid_indices(resolve_axes(spec), "zip") == [(0, 0), (1, 1), (2, 2)]
    spec = validate_spec(SweepSpec, {"type": "sweep", "sweep": {
        "h": {"from": 0.01, "to": 1, "n": 3, "spacing": "log"}}})
    np.testing.assert_allclose(resolve_axes(spec)[0].numbers, [0.01, 0.1, 1.0])


@pytest.mark.parametrize("study, field", [
    ({"type": "sweep", "grid": "zip", "sweep": {"h": [1, 2], "phi": [0]}}, "study.sweep.phi"),
    ({"type": "sweep", "sweep": {}}, "study.sweep"),
    ({"type": "sweep", "sweep": {"h": []}}, "study.sweep.h"),
    ({"type": "sweep", "sweep": {"h": {"from": 0, "to": 1, "n": 0}}}, "study.sweep.h.n"),
    ({"type": "sweep", "sweep": {"h": {"from": 0, "to": 1}}}, "study.sweep.h.n"),
    ({"type": "sweep", "sweep": {"h": [1, 2]}, "analyses": ["nope"]}, "study.analyses[0]"),
    ({"type": "sweep", "sweep": {"h": [1, 2]}, "analysis": ["solve"]}, "study.analysis"),
    ({"type": "sweep", "sweep": {"hh": [1, 2]}}, "study.sweep.hh"),
    ({"type": "sweep", "sweep": {"phi": ["10 deg", "1 mm"]}}, "study.sweep.phi[1]"),
    ({"type": "sweep", "sweep": {"phi": ["10 deg", 0.5]}}, "study.sweep.phi[1]"),
    ({"type": "sweep", "sweep": {"phi": ["10 deg", "abc"]}}, "study.sweep.phi[1]"),
    ({"type": "sweep", "sweep": {"h": [1]}, "figures": [{"x": "p", "y": "solve.tip.angle"}]},
     "study.figures[0].x"),
    ({"type": "sweep", "sweep": {"h": [1]}, "grid": "diagonal"}, "study.grid"),
    ({"type": "fit", "parameters": {}}, "study.type"),
])
def test_bad_study_names_the_field(tmp_path, study, field):
    cfg = copy.deepcopy(TRANSVERSE)
    cfg["study"] = study
    with pytest.raises(ConfigError) as info:
        plan_study(cfg, tmp_path / "s")
    assert info.value.field == field, str(info.value)
    assert "\n" not in str(info.value)


def test_cli_bad_study_exit_2(tmp_path, capsys):
    cfg = copy.deepcopy(TRANSVERSE)
    cfg["study"]["sweep"] = {"feild.magnitude": ["1 kA/m"]}
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(cfg))
    code = main(["study", str(path), "--out", str(tmp_path / "s"), "--workers", "1"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("actuator-design: error: study.sweep.feild.magnitude:"), err
    assert not (tmp_path / "s").exists()


# -- a study and its folder ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def transverse_study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "transverse"
    report = run_study(TRANSVERSE, out, workers=1, progress=False)
    return report, out


def test_study_folder_manifest_table_figures(transverse_study):
    report, out = transverse_study
    assert report.status == "completed" and report.counts["ok"] == 4 and report.computed == 4
    m = json.loads((out / "manifest.json").read_text())
    assert m["status"] == "completed" and m["n_points"] == 4
    assert m["config"]["scene"] == TRANSVERSE["scene"]
    assert m["solver"]["elements"] == 4 and m["solver"]["degree"] == 10
    assert m["versions"]["numpy"] == np.__version__ and m["versions"]["casadi"]
    assert m["started"] and m["finished"]
    assert [p["status"] for p in m["points"]] == ["ok"] * 4
    assert m["points"][2]["values"] == {"h": 1.5, "phi": "90.0 deg"}
    assert m["runs"][-1]["computed"] == 4 and m["runs"][-1]["throughput_points_per_s"] > 0
    rows = _read_csv(out / "results.csv")
    assert [r["h"] for r in rows] == ["0.5", "1.0", "1.5", "2.0"]
    assert all(r["phi [deg]"] == "90.0" for r in rows)
    figs = list((out / "figures").glob("*.png"))
    assert figs and all(f.stat().st_size > 1000 for f in figs)
    assert len(_journal_lines(out / "journal.jsonl")) == 1 + 4
    assert not list(out.glob(".*.tmp"))  # no temporary files left


def test_study_results_match_the_closed_form(transverse_study):
    """φ = 90°: straight below h_crit, |θ(1)| = β with K(sin²β) = √2 h above (THEORY §6)."""
    _, out = transverse_study
    for r in _read_csv(out / "results.csv"):
        h = float(r["h"])
        angle = float(r["solve.tip.angle"])
        assert r["solve.stable"] == "true"
        if h < critical_field_transverse():
            assert abs(angle) < 1e-9
        else:
            assert abs(angle) == pytest.approx(transverse_mode(h).beta, abs=1e-8)


def test_physical_sweep_units_reach_the_scene(tmp_path):
    """h = √(μ0 χ̄ A ℓ²/(2 E I)) H (THEORY §5) for fields given in kA/m, mT and A/m."""
    run_study(PHYSICAL, tmp_path / "p", workers=1, progress=False)
    rows = _read_csv(tmp_path / "p" / "results.csv")
    c = math.sqrt(MU0 * 0.5 * 5e-3 * 0.5e-3 * (20e-3) ** 2 / (2 * 1e6 * 5e-3 * (0.5e-3) ** 3 / 12))
    H = [5e3, 10e-3 / MU0, 5e3]
    assert [r["field.magnitude [kA/m]"] for r in rows][0] == "5.0"
    assert float(rows[1]["field.magnitude [kA/m]"]) == pytest.approx(10e-3 / MU0 / 1e3)
    for r, Hi, phi in zip(rows, H, [0.0, math.radians(30), 1.0]):
        assert float(r["solve.h"]) == pytest.approx(c * Hi, rel=1e-12)
        assert float(r["solve.phi"]) == pytest.approx(phi, rel=1e-12)
    # outputs: only the columns asked for
    assert set(rows[0]) == {"point", "field.magnitude [kA/m]", "field.angle [deg]", "status",
                            "message", "time_s", "solve.h", "solve.phi", "solve.tip.x",
                            "solve.tip.y", "solve.tip.angle"}


def test_an_out_of_range_value_is_refused_before_any_work(tmp_path):
    """README "Valid ranges": a study value outside its range is exit 2 before anything is written
    (it was an ``invalid`` point in a written folder); tests/test_study_checks.py has the rest."""
    cfg = copy.deepcopy(TRANSVERSE)
    cfg["study"]["sweep"] = {"h": [0.5, -1.0, 2.0]}
    with pytest.raises(ConfigError) as info:
        run_study(cfg, tmp_path / "s", workers=1, progress=False)
    assert info.value.field == "study.sweep.h"
    assert "scene.h: must be >= 0, got -1.0" in str(info.value)
    assert not (tmp_path / "s").exists()


# -- resume ----------------------------------------------------------------------------------------------
def test_existing_study_needs_resume_and_the_same_config(tmp_path, transverse_study):
    _, out = transverse_study
    with pytest.raises(StudyError, match="already holds a study"):
        plan_study(TRANSVERSE, out)
    other = copy.deepcopy(TRANSVERSE)
    other["study"]["sweep"]["h"] = [0.5, 1.0, 1.5, 2.5]
    with pytest.raises(StudyError, match="different study"):
        plan_study(other, out, resume=True)


def test_resume_after_a_torn_journal_recomputes_only_missing_points(tmp_path, transverse_study):
    _, done = transverse_study
    out = tmp_path / "torn"
    out.mkdir()
    lines = _journal_lines(done / "journal.jsonl")
    # header + two complete records + half of the third (a write cut by a crash)
    (out / "journal.jsonl").write_text("\n".join(lines[:3]) + "\n" + lines[3][: len(lines[3]) // 2])
    report = run_study(TRANSVERSE, out, workers=1, progress=False, resume=True)
    assert report.computed == 2 and report.reused == 2
    new = _journal_lines(out / "journal.jsonl")
    assert new[:3] == lines[:3]  # kept, byte for byte: not recomputed
    assert len(new) == 5 and all(json.loads(x) for x in new)
    indices = sorted(json.loads(x)["index"] for x in new[1:])
    assert indices == [0, 1, 2, 3]
    a = {r["point"]: r["solve.tip.angle"] for r in _read_csv(done / "results.csv")}
    b = {r["point"]: r["solve.tip.angle"] for r in _read_csv(out / "results.csv")}
    assert a == b


def test_interrupt_with_sigint_then_resume(tmp_path):
    cfg = copy.deepcopy(TRANSVERSE)
    cfg["study"]["sweep"] = {"h": {"from": 0.0, "to": 2.5, "n": 30}}
    cfg["study"]["chunk_size"] = 1
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(cfg))
    out = tmp_path / "s"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "actuator_design.cli.main", "study", str(path),
                             "--out", str(out), "--workers", "1", "--no-progress"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    journal = out / "journal.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline:
        if journal.exists() and len(_journal_lines(journal)) >= 4:
            break
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the study finished before it could be interrupted"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err.decode()
    assert b"--resume" in err
    m = json.loads((out / "manifest.json").read_text())
    assert m["status"] == "interrupted"
    before = _journal_lines(journal)
    n_done = len(before) - 1
    assert 3 <= n_done < 30 and m["counts"]["pending"] == 30 - n_done
    code = main(["study", str(path), "--out", str(out), "--workers", "1", "--no-progress", "--resume"])
    assert code == 0
    m = json.loads((out / "manifest.json").read_text())
    assert m["status"] == "completed" and m["counts"]["ok"] == 30
    assert m["runs"][0]["status"] == "interrupted" and m["runs"][1]["computed"] == 30 - n_done
    after = _journal_lines(journal)
    assert after[: len(before)] == before
    assert sorted(json.loads(x)["index"] for x in after[1:]) == list(range(30))
    assert len(_read_csv(out / "results.csv")) == 30


# -- parallel -----------------------------------------------------------------------------------------
def test_process_pool_gives_the_serial_results(tmp_path, transverse_study):
    _, serial = transverse_study
    report = run_study(TRANSVERSE, tmp_path / "par", workers=2, progress=False)
    assert report.backend == "processes" and report.workers == 2
    a = _read_csv(serial / "results.csv")
    b = _read_csv(tmp_path / "par" / "results.csv")
    assert [r["solve.tip.angle"] for r in a] == [r["solve.tip.angle"] for r in b]


def test_stiffness_analysis_when_registered(tmp_path):
    if "stiffness" not in registry.names():
        pytest.skip("the 'stiffness' analysis is not registered (yet)")
    cfg = copy.deepcopy(TRANSVERSE)
    cfg["scene"]["phi"] = 0
    cfg["study"]["sweep"] = {"h": [0.5, 1.0]}
    cfg["study"]["analyses"] = ["solve", "stiffness"]
    report = run_study(cfg, tmp_path / "s", workers=1, progress=False)
    assert report.counts["ok"] + report.counts["not_converged"] == 2, report.counts
    rows = _read_csv(tmp_path / "s" / "results.csv")
    assert any(k.startswith("stiffness.") for k in rows[0])


# -- 10 000 points (slow) -------------------------------------------------------------------------
@pytest.mark.slow
def test_ten_thousand_point_study_interrupt_resume(tmp_path):
    """A 100 × 100 sweep on 2 workers, interrupted and resumed; prints its throughput."""
    cfg = copy.deepcopy(TRANSVERSE)
    cfg["study"]["sweep"] = {"h": {"from": 0.0, "to": 2.5, "n": 100},
                             "phi": {"from": "0 deg", "to": "90 deg", "n": 100}}
    cfg["study"]["outputs"] = ["solve.success", "solve.stable", "solve.tip.*", "solve.energy"]
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(cfg))
    out = tmp_path / "s"
    proc = subprocess.Popen([sys.executable, "-m", "actuator_design.cli.main", "study", str(path),
                             "--out", str(out), "--workers", "2", "--no-progress"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    journal = out / "journal.jsonl"
    while proc.poll() is None and not (journal.exists() and len(_journal_lines(journal)) > 2000):
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=120)
    assert proc.returncode == 130
    n_before = len(_journal_lines(journal)) - 1
    code = main(["study", str(path), "--out", str(out), "--workers", "2", "--no-progress", "--resume"])
    assert code == 0
    m = json.loads((out / "manifest.json").read_text())
    assert m["status"] == "completed" and m["counts"]["ok"] == 10_000
    assert m["runs"][1]["computed"] == 10_000 - n_before
    rows = _read_csv(out / "results.csv")
    assert len(rows) == 10_000
    assert list((out / "figures").glob("*.png"))
    for run in m["runs"]:
        print(f"run: {run['computed']} points in {run['elapsed_s']:.1f} s = "
              f"{run['throughput_points_per_s']:.1f} points/s on {run['workers']} workers")
    # spot check against THEORY §6 at φ = 90°
    for r in rows:
        if float(r["phi [deg]"]) == 90.0 and float(r["h"]) > 1.2:
            assert abs(float(r["solve.tip.angle"])) == pytest.approx(
                transverse_mode(float(r["h"])).beta, abs=1e-8)
