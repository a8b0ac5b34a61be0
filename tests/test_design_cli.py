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
