"""The ``path``, ``stiffness`` and ``phase`` commands: JSON contracts, files, YAML studies, bad input.

Physical claims are checked against independent references: mirror symmetry of the hysteresis
loop, THEORY §6's s(h), and the closed-form transverse modes."""
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from actuator_design.cli.main import main
from actuator_design.reference.closed_forms import lowload_stiffness, transverse_mode

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def run_json(capsys, argv):
    code = main(argv + ["--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out), err


def test_path_json_contract_and_symmetric_loop(capsys):
    code, d, _ = run_json(capsys, ["path", "--param", "p", "--schedule", "0.5,-1,1,0.5",
                                   "--h", "1.5", "--phi-deg", "90"])
    assert code == 0
    for key in ("points", "jumps", "snap_free", "hysteresis"):
        assert key in d
    pt = d["points"][0]
    assert {"param", "tip", "energy", "stable", "min_eigenvalue"} <= set(pt)
    assert set(pt["tip"]) == {"x", "y", "angle"}
    assert d["snap_free"] is False and len(d["jumps"]) == 2
    a, b = (j["param"] for j in d["jumps"])
    assert a == pytest.approx(-b, rel=1e-9)  # mirror symmetry θ → −θ, p → −p
    assert d["hysteresis"]["width"] == pytest.approx(b - a, rel=1e-12)
    j = d["jumps"][0]
    assert {"from", "to", "energy_released"} <= set(j) and j["energy_released"] > 0


def test_path_in_degrees_is_mirror_symmetric_about_90(capsys):
    code, d, _ = run_json(capsys, ["path", "--param", "phi_deg", "--from", "30", "--to", "150",
                                   "--back", "--h", "1.5"])
    assert code == 0 and d["param"] == "phi_deg" and d["param_unit"] == "deg"
    up, down = (j["param"] for j in d["jumps"])
    assert up + down == pytest.approx(180.0, abs=1e-6)
    assert 90 < up < 150


def test_path_over_h_r_small_field_is_the_linear_closed_form(capsys):
    """`--param h_r` (listed in --help): a hard-magnetic strip in a transverse field, h_r ramped to
    1e-3. Linearised, θ'' = −h_r gives θ = h_r (s − s²/2) and a tip rising by h_r/3 (O(h_r³) off)."""
    code, d, _ = run_json(capsys, ["path", "--param", "h_r", "--from", "0", "--to", "1e-3", "--steps", "4",
                                   "--h-r", "0", "--phi-deg", "90"])
    assert code == 0 and d["param"] == "h_r"
    tip = d["points"][-1]["tip"]
    assert d["points"][-1]["param"] == pytest.approx(1e-3, rel=1e-12)
    assert tip["y"] == pytest.approx(1e-3 / 3, abs=1e-9) and tip["angle"] == pytest.approx(1e-3 / 2, abs=1e-9)


def test_path_help_lists_every_name_of_the_lens_and_a_magnetization_ramp_lands_on_solve_bvp(capsys):
    """The help lists what the parameter lens accepts (each angle also in degrees); a ramp of the
    magnetisation angle β to 30° at h_r = 1 in a transverse field ends on the strip of scipy's
    solve_bvp: θ'' = h_r sin(θ + β − φ), θ(0) = 0, θ'(1) = 0 (THEORY §9), x' = cos θ, y' = sin θ."""
    from scipy.integrate import solve_bvp

    from actuator_design.physics.parameters import degree_aliases, names

    assert main(["path", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    listed = text.split("parameter to ramp:")[1].split("--schedule")[0]
    assert all(f" {n}," in listed or f" {n} " in listed for n in list(names()) + list(degree_aliases()))
    code, d, _ = run_json(capsys, ["path", "--param", "magnetization_deg", "--from", "0", "--to", "30",
                                   "--h-r", "1", "--phi-deg", "90"])
    assert code == 0 and d["param"] == "magnetization_deg"
    shift = math.radians(30.0) - math.radians(90.0)  # β − φ
    s = np.linspace(0.0, 1.0, 201)
    bvp = solve_bvp(lambda s, u: np.vstack([u[1], np.sin(u[0] + shift), np.cos(u[0]), np.sin(u[0])]),
                    lambda a, b: np.array([a[0], b[1], a[2], a[3]]), s, np.zeros((4, s.size)), tol=1e-12,
                    max_nodes=100000)
    assert bvp.success
    tip = d["points"][-1]["tip"]
    assert tip["angle"] == pytest.approx(bvp.sol(1.0)[0], abs=1e-8)
    assert tip["x"] == pytest.approx(bvp.sol(1.0)[2], abs=1e-8) and tip["y"] == pytest.approx(bvp.sol(1.0)[3], abs=1e-8)


def test_path_out_writes_files_atomically(tmp_path, capsys):
    out = tmp_path / "res"
    code = main(["path", "--param", "h", "--from", "0", "--to", "2", "--steps", "10", "--p", "0.2",
                 "--out", str(out)])
    assert code == 0
    names = sorted(os.listdir(out))
    assert names == ["path.csv", "path.json", "path.png"]
    d = json.loads((out / "path.json").read_text())
    assert d["snap_free"] is True and d["config"] is None
    assert (out / "path.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "path.csv").read_text().startswith("# units")


def test_path_from_yaml_study(capsys):
    code, d, _ = run_json(capsys, ["path", str(CONFIGS / "study_path_axial_field_snap_free.yaml")])
    assert code == 0 and d["snap_free"] is True and d["param"] == "h"
    assert max(p["param"] for p in d["points"]) == pytest.approx(3.0)
    code, d, _ = run_json(capsys, ["path", str(CONFIGS / "study_path_field_rotation.yaml")])
    assert code == 0 and d["param"] is None and len(d["jumps"]) == 2
    assert d["jumps"][0]["values"]["phi"] + d["jumps"][1]["values"]["phi"] == pytest.approx(math.pi, abs=1e-8)


@pytest.mark.parametrize("study, match", [
    ("{type: path, param: h, frm: 0}", "study.frm: unknown key"),
    ("{type: path, param: h, from: 0, to: 1, steps: 0}", "study.steps"),
    ("{type: stiffness}", "study.type: expected 'path'"),
    ("{type: path, schedule: [{h: 0, bogus: 1}, {h: 1, bogus: 2}]}", r"study.schedule\[0\].bogus"),
])
def test_path_study_errors_name_the_field(tmp_path, capsys, study, match):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"scene: {{type: dimensionless, h: 1, phi: 0, p: 0}}\nstudy: {study}\n")
    assert main(["path", str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert __import__("re").search(match, err), err


@pytest.mark.parametrize("argv, match", [
    (["path", "--param", "bogus", "--from", "0", "--to", "1"], "--param: unknown parameter 'bogus'"),
    (["path", "--param", "h", "--from", "0"], "--schedule or both --from and --to"),
    (["path", "--from", "0", "--to", "1"], "--param: required"),
    (["path", "--param", "h", "--schedule", "0,-1"], "h: must be >= 0"),
    (["path", "--param", "h", "--schedule", "0,x"], "--schedule: expected comma-separated numbers"),
    (["stiffness", "--field-sweep", "1"], "--field-sweep: expected two values"),
    (["stiffness", "--field-sweep", "0,1", "--n", "1"], "--n: must be >= 2"),
    (["phase", "--theta-range", "2,1"], "--theta-range"),
])
def test_bad_input_exit_2_one_line(capsys, argv, match):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err, err


def test_out_that_is_a_file_is_refused_before_solving(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    for cmd in (["path", "--param", "h", "--from", "0", "--to", "1"], ["stiffness"], ["phase"]):
        assert main(cmd + ["--out", str(f)]) == 2
        assert "--out" in capsys.readouterr().err
    assert f.read_text() == "x"


def test_stiffness_json_matches_lowload_closed_form(capsys):
    code, d, _ = run_json(capsys, ["stiffness", "--h", "1.3"])
    assert code == 0
    assert d["vertical_stiffness"] == pytest.approx(lowload_stiffness(1.3), rel=1e-8)
    assert d["vertical_stiffness_N_per_m"] is None and d["symmetry_error"] < 1e-12


def test_stiffness_sweep_out_and_yaml(tmp_path, capsys):
    out = tmp_path / "st"
    code = main(["stiffness", str(CONFIGS / "study_stiffness_axial_field.yaml"), "--n", "5",
                 "--out", str(out)])
    assert code == 0
    assert sorted(os.listdir(out)) == ["stiffness.json", "stiffness.png", "stiffness_curve.csv"]
    d = json.loads((out / "stiffness.json").read_text())
    sw = d["field_sweep"]
    assert len(sw["h"]) == 5 and sw["lowload_applies"]
    for h, s in zip(sw["h"], sw["vertical_stiffness"]):
        assert s == pytest.approx(lowload_stiffness(h), rel=1e-8)


def test_stiffness_physical_config_reports_newtons_per_metre(capsys):
    code, d, _ = run_json(capsys, ["stiffness", str(CONFIGS / "study_stiffness_paper_actuator.yaml"),
                                   "--n", "3"])
    assert code == 0
    B = 2.25e6 * 7e-3 * 3e-3 ** 3 / 12
    assert d["vertical_stiffness_N_per_m"] == pytest.approx(d["vertical_stiffness"] * B / 27.5e-3 ** 3,
                                                            rel=1e-12)
    assert d["field_sweep"]["field_A_per_m"][-1] == pytest.approx(5e3, rel=1e-3)


def test_phase_json_and_out(tmp_path, capsys):
    h = 2.0
    code, d, _ = run_json(capsys, ["phase", "--h", str(h), "--phi-deg", "90"])
    assert code == 0 and len(d["trajectories"]) == 3
    g = sorted(abs(t["gamma"]) for t in d["trajectories"])
    assert g[0] < 1e-9 and g[2] == pytest.approx(transverse_mode(h).gamma, rel=1e-7)
    out = tmp_path / "ph"
    assert main(["phase", "--h", str(h), "--phi-deg", "90", "--out", str(out)]) == 0
    assert sorted(os.listdir(out)) == ["phase.json", "phase.png", "trajectories.csv"]


def test_phase_refuses_non_autonomous_config(capsys):
    assert main(["phase", str(CONFIGS / "varying_fibres.yaml")]) == 2
    err = capsys.readouterr().err
    assert "fibres:" in err or "stiffness:" in err
