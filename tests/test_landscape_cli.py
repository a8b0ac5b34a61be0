"""The landscape commands `equilibria`, `continue`, `critical`, `map`: JSON contracts, files, YAML
studies and bad input. Physical values are checked against THEORY §6 (transverse modes:
2·#{m : h_crit^(m) < h} + 1 equilibria, pitchforks at (2m − 1)π/(2√2)), not against earlier output.
"""
import json
import math
from pathlib import Path

import pytest

from actuator_design.cli.main import main
from actuator_design.config import load_config
from actuator_design.reference.closed_forms import critical_field_transverse

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_equilibria_json_contract(capsys):
    code, out, err = run(capsys, "equilibria", "--h", "4", "--phi-deg", "90", "--p", "0", "--json")
    assert code == 0, err
    d = json.loads(out)
    eqs = d["equilibria"]
    assert len(eqs) == 5  # h_crit^(2) < 4 < h_crit^(3)
    for e in eqs:
        assert set(e["tip"]) == {"x", "y", "angle"}
        assert {"energy", "morse_index", "stable", "gamma"} <= set(e)
    assert sorted(e["morse_index"] for e in eqs) == [0, 0, 1, 1, 2]
    assert sum(e["stable"] for e in eqs) == 2


def test_equilibria_alpha_flag_and_files(capsys, tmp_path):
    # α = 90° with φ = 0 is the transverse case (only θ + α − φ enters)
    code, out, err = run(capsys, "equilibria", "--h", "3", "--phi-deg", "0", "--alpha-deg", "90",
                         "--out", str(tmp_path / "eq"))
    assert code == 0, err
    assert "3 equilibria" in out
    files = sorted(p.name for p in (tmp_path / "eq").iterdir())
    assert files == ["equilibria.csv", "equilibria.json", "equilibria.png"]
    assert (tmp_path / "eq" / "equilibria.png").read_bytes()[:4] == b"\x89PNG"


def test_continue_json_contract(capsys):
    code, out, err = run(capsys, "continue", "--param", "h", "--from", "0", "--to", "4", "--phi-deg", "90",
                         "--p", "0", "--json")
    assert code == 0, err
    d = json.loads(out)
    assert {"branch", "folds", "branch_points"} <= set(d)
    assert {"value", "tip_angle", "stable"} <= set(d["branch"][0])
    assert [b["value"] for b in d["branch_points"]] == pytest.approx(
        [critical_field_transverse(1), critical_field_transverse(2)], abs=1e-8)
    assert all("tip_angle" in b for b in d["branch_points"])
    assert d["branch"][0]["stable"] and not d["branch"][-1]["stable"]


def test_critical_json_contract(capsys):
    code, out, err = run(capsys, "critical", "--param", "h", "--window", "0,2", "--phi-deg", "90",
                         "--p", "0", "--samples", "3", "--json")
    assert code == 0, err
    d = json.loads(out)
    assert d["folds"] == []
    (bp,) = d["branch_points"]
    assert bp["value"] == pytest.approx(critical_field_transverse(1), abs=1e-8)
    assert (bp["equilibria_below"], bp["equilibria_above"]) == (1, 3)
    assert "tip_angle" in bp


def test_map_json_and_files(capsys, tmp_path):
    code, out, err = run(capsys, "map", "--n", "4,5", "--workers", "1", "--no-curves", "--quiet",
                         "--x-range", "0,20", "--y-range", "1,5", "--json", "--out", str(tmp_path / "m"))
    assert code == 0, err
    d = json.loads(out)
    assert len(d["counts"]) == 5 and len(d["counts"][0]) == 4
    assert all(c == 1 for row in d["counts"] for c in row)  # p < p_crit^(1)(h²) ≥ 6.1 everywhere here
    names = sorted(p.name for p in (tmp_path / "m").iterdir())
    assert names == ["map.csv", "map.json", "map.png"]
    text = (tmp_path / "m" / "map.csv").read_text()
    assert text.count("\n") == 2 + 20
    # one comment line, the header, then each grid point once with the counts of the JSON
    lines = text.splitlines()
    assert lines[0].startswith("# ") and lines[1] == "h2,p,equilibria,stable"
    rows = [tuple(float(v) for v in line.split(",")) for line in lines[2:]]
    assert len({r[:2] for r in rows}) == 20
    assert [int(r[2]) for r in rows] == [c for row in d["counts"] for c in row]


def test_study_configs_load_and_one_runs(capsys):
    for path in sorted(CONFIGS.glob("study_*.yaml")):
        load_config(path)  # the study section is a free dict for load_config
    code, out, err = run(capsys, "equilibria", str(CONFIGS / "study_equilibria_transverse.yaml"), "--json")
    assert code == 0, err
    assert len(json.loads(out)["equilibria"]) == 5
    code, out, err = run(capsys, "continue", str(CONFIGS / "study_continuation_transverse.yaml"),
                         "--to", "2", "--json")
    assert code == 0, err
    d = json.loads(out)
    assert len(d["branch_points"]) == 1 and len(d["secondary_branches"]) == 2


@pytest.mark.slow
def test_every_landscape_study_config_runs(capsys, tmp_path):
    for name, cmd in [("study_critical_elastica.yaml", "critical"), ("study_map_axial.yaml", "map")]:
        code, out, err = run(capsys, cmd, str(CONFIGS / name), "--json", "--out", str(tmp_path / cmd))
        assert code == 0, err


@pytest.mark.parametrize("argv, field", [
    (["critical", "--param", "h", "--window", "2,1"], "--window"),
    (["continue", "--param", "bogus", "--from", "0", "--to", "1"], "--param"),
    (["continue", "--param", "h", "--from", "0"], "--to"),
    (["continue", "--param", "h2", "--from", "-1", "--to", "1"], "h2"),
    (["map", "--n", "1"], "--n"),
    (["equilibria", "--n-gamma", "3"], "--n-gamma"),
])
def test_bad_flags_exit_2_naming_the_field(capsys, argv, field):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert field in err and len(err.strip().splitlines()) == 1


def test_bad_study_section_names_the_field(capsys, tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("scene: {type: dimensionless, h: 1.0, phi: 0, p: 1}\n"
                   "study: {type: critical, param: p, window: [0, 5], colour: red}\n")
    code, out, err = run(capsys, "critical", str(cfg), "--json")
    assert code == 2 and "study.colour" in err and out == ""
    cfg.write_text("scene: {type: dimensionless, h: 1.0, phi: 0, p: 1}\n"
                   "study: {type: critical, param: p, window: [5, 1]}\n")
    code, out, err = run(capsys, "critical", str(cfg))
    assert code == 2 and "study.window" in err
    code, out, err = run(capsys, "equilibria", str(cfg))
    assert code == 2 and "study.type" in err


def test_non_uniform_field_is_bad_input(capsys, tmp_path):
    cfg = tmp_path / "dip.yaml"
    cfg.write_text("scene: {type: dimensionless, h: 0.1, field: {type: dipole, position: {x: 0.5, y: -0.5}}}\n")
    code, out, err = run(capsys, "equilibria", str(cfg), "--json")
    assert code == 2 and "uniform" in err and out == ""


@pytest.mark.slow
def test_paper_problem_scripts_run(tmp_path, capsys):
    """The three paper scripts run and print the computed critical values (slow)."""
    import importlib.util
    root = CONFIGS.parent / "problems"
    for name, extra in [("paper_elastica_bifurcation", []), ("paper_transverse_modes", []),
                        ("paper_multiplicity_map", ["--n", "30", "--quiet"])]:
        spec = importlib.util.spec_from_file_location(name, root / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        assert mod.main(["--out", str(tmp_path)] + extra) == 0
        assert (tmp_path / f"{name}.png").exists()
    out = capsys.readouterr().out
    assert "10.3251607" in out and "51.00114" in out and "1.110720734" in out
