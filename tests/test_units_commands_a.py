"""The user's units in every output of ``solve``, ``equilibria``, ``continue``, ``critical``, ``map``
and ``phase`` (issue 21 item 2): text, JSON (beside the dimensionless keys), CSV columns and figure
axes of a physical scene; a dimensionless scene's outputs stay without them.

Every reference value is converted here from the YAML's inputs, never by the code under test
(THEORY §5, §9): x [mm] = x̂ ℓ / 1 mm, θ' [rad/mm] = θ̂' / (ℓ / 1 mm), loads in B0/ℓ², energies in
B0/ℓ, the first integral H in B0/ℓ² (J/m), B0 = E w t³/12, the field μ0 H of a group h from
h² = μ0 χ̄ H² A ℓ² / (2 B0) and of h_r from h_r = μ0 M_r H A ℓ² / B0, A = w t.
"""
import json
import math
from pathlib import Path

import pytest
import yaml

from unit_outputs import (B0, CHI, E, L, MM, MU0, T, W, dh_dH, figures, mT_of_h,  # noqa: F401
                          read_csv, run, scene)  # figures: a fixture

SOLVER = {"elements": 4, "degree": 10}


def config(tmp_path, **changes) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"name": "units", "scene": scene(**changes), "solver": SOLVER},
                                   allow_unicode=True))
    return path


def mm(x_rod):
    return x_rod * L / MM


def per_mm(k_rod):
    return k_rod / (L / MM)


def test_solve_in_mm_mT_N_and_J(tmp_path, capsys, figures):
    out = tmp_path / "o"
    code, stdout, _ = run(["solve", config(tmp_path), "--out", out], capsys)
    assert code == 0
    phys_line = next(ln for ln in stdout.splitlines() if ln.startswith("  physical    :"))
    assert " mm, mu0 H = 25 mT, tip force (0, 7e-05) N, energy = " in phys_line and " J, clamp force" in phys_line
    assert "lengths in mm (as rod.length)" in stdout
    data = json.loads((out / "result.json").read_text())
    phys = data["physical"]
    assert phys["length_unit"] == "mm"
    assert phys["tip_x_mm"] == pytest.approx(mm(data["tip"]["x"]), rel=1e-12)
    assert phys["tip_y_mm"] == pytest.approx(mm(data["tip"]["y"]), rel=1e-12)
    assert phys["field_mT"] == pytest.approx(25.0, rel=1e-12)
    assert phys["tip_force_N"] == pytest.approx([0.0, 0.07e-3], rel=1e-12)
    assert phys["gamma_rad_per_mm"] == pytest.approx(per_mm(data["gamma"]), rel=1e-12)
    assert phys["energy_J"] == pytest.approx(data["energy"] * B0 / L, rel=1e-12)
    assert phys["tip_x_m"] == pytest.approx(data["tip"]["x"] * L, rel=1e-12)  # the SI keys stay
    rows, comments = read_csv(out / "shape.csv")
    assert {"s_mm", "x_mm", "y_mm", "dtheta_rad_per_mm"} <= set(rows[0]) and "x_mm, y_mm in mm" in comments[0]
    assert float(rows[-1]["x_mm"]) == pytest.approx(mm(float(rows[-1]["x"])), rel=1e-12)
    assert float(rows[-1]["s_mm"]) == pytest.approx(20.0, rel=1e-12)
    (fig,) = figures
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x / mm", "y / mm")
    texts = [t.get_text() for t in ax.get_legend().get_texts()] + [t.get_text() for t in ax.texts]
    assert any("μ0H = 25 mT" in t for t in texts) and any(t.endswith(" N") for t in texts)


def test_equilibria_in_mm_and_J(tmp_path, capsys, figures):
    out = tmp_path / "o"
    code, stdout, _ = run(["equilibria", config(tmp_path, loads={}), "--out", out], capsys)
    assert code == 0
    data = json.loads((out / "equilibria.json").read_text())
    assert data["count"] == 3 and data["physical"]["field_mT"] == pytest.approx(25.0, rel=1e-12)
    for e in data["equilibria"]:
        assert e["physical"]["tip"]["x"] == pytest.approx(mm(e["tip"]["x"]), rel=1e-12)
        assert e["physical"]["energy_J"] == pytest.approx(e["energy"] * B0 / L, rel=1e-12, abs=1e-30)
        assert e["physical"]["gamma_rad_per_mm"] == pytest.approx(per_mm(e["gamma"]), rel=1e-12, abs=1e-15)
    assert stdout.count("in the user's units: tip = (") == 3 and "mu0 H = 25 mT" in stdout
    rows, comments = read_csv(out / "equilibria.csv")
    assert {"tip_x_mm", "tip_y_mm", "energy_J", "gamma_rad_per_mm"} <= set(rows[0])
    for r in rows:
        assert float(r["tip_y_mm"]) == pytest.approx(mm(float(r["tip_y"])), rel=1e-12, abs=1e-12)
    (fig,) = figures
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x / mm", "y / mm") and "25 mT" in ax.get_title()
    assert all("rad/mm" in t.get_text() for t in ax.get_legend().get_texts() if t.get_text().startswith("γ"))


def test_continue_in_mT(tmp_path, capsys, figures):
    out = tmp_path / "o"
    code, stdout, _ = run(["continue", config(tmp_path, loads={}), "--param", "h", "--from", "5 mT",
                           "--to", "40 mT", "--straight", "--out", out], capsys)
    assert code == 0
    data = json.loads((out / "branch.json").read_text())
    assert data["physical"]["parameters"] == {"h": "mT (mu0 H)"}
    (bp,) = data["branch_points"]
    assert bp["field_mT"] == pytest.approx(mT_of_h(math.pi / (2 * math.sqrt(2))), rel=1e-6)  # THEORY §6
    for pt in data["branch"]:
        assert pt["field_mT"] == pytest.approx(mT_of_h(pt["value"]), rel=1e-12)
        assert pt["physical"]["tip"]["x"] == pytest.approx(mm(pt["tip_x"]), rel=1e-12)
    assert "mu0 H = 5 mT" in stdout and "branch point at h = " in stdout
    rows, comments = read_csv(out / "branch.csv")
    assert "value_mT in mT (mu0 H)" in comments[0]
    for r in rows:
        assert float(r["value_mT"]) == pytest.approx(mT_of_h(float(r["value"])), rel=1e-12)
        assert float(r["energy_J"]) == pytest.approx(float(r["energy"]) * B0 / L, rel=1e-12, abs=1e-30)
    (fig,) = figures
    assert fig.axes[0].get_xlabel() == "field μ0H / mT"


def test_critical_in_N(tmp_path, capsys, figures):
    out = tmp_path / "o"
    code, stdout, _ = run(["critical", config(tmp_path), "--param", "p", "--window", "-0.2 mN,0.2 mN",
                           "--out", out], capsys)
    assert code == 0
    data = json.loads((out / "critical.json").read_text())
    assert len(data["folds"]) == 2 and data["physical"]["parameters"] == {"p": "N"}
    for d in data["folds"]:
        assert d["value_N"] == pytest.approx(d["value"] * B0 / L**2, rel=1e-12)
        assert d["physical"]["tip"]["y"] == pytest.approx(mm(d["tip"]["y"]), rel=1e-12)
    # the folds are symmetric in p (the scene's mirror symmetry, THEORY §6)
    assert data["folds"][0]["value_N"] == pytest.approx(-data["folds"][1]["value_N"], rel=1e-6)
    assert stdout.count(" N)  tip angle") == 2
    rows, comments = read_csv(out / "critical.csv")
    assert {"value_N", "tip_x_mm", "tip_y_mm", "energy_J"} <= set(rows[0])
    (fig,) = figures
    assert fig.axes[0].get_xlabel() == "p / N"


def test_map_in_mT_and_N(tmp_path, capsys, figures):
    out = tmp_path / "o"
    code, stdout, _ = run(["map", config(tmp_path), "--x-param", "h", "--x-range", "5 mT,40 mT",
                           "--y-param", "p", "--y-range", "-0.2 mN,0.2 mN", "--n", "5", "--quiet",
                           "--workers", "1", "--no-curves", "--out", out], capsys)
    assert code == 0
    data = json.loads((out / "map.json").read_text())
    assert data["physical"]["x_mT"] == pytest.approx([mT_of_h(v) for v in data["x"]], rel=1e-12)
    assert data["physical"]["x_mT"][0] == pytest.approx(5.0, rel=1e-12)
    assert data["physical"]["y_N"] == pytest.approx([v * B0 / L**2 for v in data["y"]], rel=1e-12)
    assert "(5 to 40 mT)" in stdout and "(-0.0002 to 0.0002 N)" in stdout
    rows, comments = read_csv(out / "map.csv")
    assert "h_mT: mu0 H in mT" in comments[0] and "p_N: p in N" in comments[0]
    for r in rows:
        assert float(r["h_mT"]) == pytest.approx(mT_of_h(float(r["h"])), rel=1e-12)
        assert float(r["p_N"]) == pytest.approx(float(r["p"]) * B0 / L**2, rel=1e-12, abs=1e-20)
    (fig,) = figures
    panels = [ax for ax in fig.axes if ax.get_title().startswith("number of")]
    assert len(panels) == 2
    for ax in panels:
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("field μ0H / mT", "p / N")


def test_phase_in_rad_per_mm_and_J_per_m(tmp_path, capsys, figures):
    out = tmp_path / "o"
    code, stdout, _ = run(["phase", config(tmp_path, loads={}), "--out", out], capsys)
    assert code == 0
    data = json.loads((out / "phase.json").read_text())
    assert data["physical"]["field_mT"] == pytest.approx(25.0, rel=1e-12)
    for t in data["trajectories"]:
        ph = t["physical"]
        assert ph["gamma_rad_per_mm"] == pytest.approx(per_mm(t["gamma"]), rel=1e-12, abs=1e-15)
        assert ph["level_J_per_m"] == pytest.approx(t["level"] * B0 / L**2, rel=1e-12, abs=1e-30)
        assert ph["dtheta_rad_per_mm"] == pytest.approx([per_mm(v) for v in t["dtheta"]], rel=1e-12, abs=1e-15)
    assert "J/m" in stdout and "mu0 H = 25 mT" in stdout
    rows, _ = read_csv(out / "trajectories.csv")
    assert float(rows[0]["dtheta_rad_per_mm"]) == pytest.approx(per_mm(float(rows[0]["dtheta"])), rel=1e-12)
    (fig,) = figures
    ax = fig.axes[0]
    assert ax.get_ylabel() == "θ' = κ [rad/mm]" and "μ0H = 25 mT" in ax.get_title()


def test_hard_magnetic_field_in_mT_from_h_r(tmp_path, capsys):
    """A hard-magnetic strip without a soft susceptibility: the field is read from h_r
    (μ0 H = h_r B0 / (M_r A ℓ²)) — in solve's text and JSON and continue's values."""
    mr = 0.1 / MU0  # μ0 M_r = 0.1 T
    cfg = scene(magnetics={"remanent_flux_density": "0.1 T"}, magnetization="0 deg",
                field={"type": "uniform", "magnitude": "10 mT", "angle": "90 deg"}, loads={})
    del cfg["fibres"]
    path = tmp_path / "hard.yaml"
    path.write_text(yaml.safe_dump({"name": "hard", "scene": cfg, "solver": SOLVER}))
    code, stdout, _ = run(["solve", path, "--json"], capsys)
    assert code == 0
    assert json.loads(stdout)["physical"]["field_mT"] == pytest.approx(10.0, rel=1e-12)
    code, stdout, _ = run(["continue", path, "--param", "h_r", "--from", "1 mT", "--to", "4 mT", "--json"],
                          capsys)
    assert code == 0
    data = json.loads(stdout)
    assert data["physical"]["parameters"] == {"h_r": "mT (mu0 H)"}
    for pt in data["branch"]:
        by_hand = pt["value"] * B0 / (mr * W * T * L**2) * 1e3
        assert pt["field_mT"] == pytest.approx(by_hand, rel=1e-12)
    assert data["branch"][0]["field_mT"] == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("argv", [
    ["solve", "--json"],
    ["equilibria", "--json"],
    ["continue", "--param", "h", "--from", "0.5", "--to", "1", "--json"],
    ["critical", "--param", "h", "--window", "0.5,1.5", "--phi-deg", "90", "--json"],
    ["map", "--n", "3", "--quiet", "--no-curves", "--workers", "1", "--json"],
    ["phase", "--json"],
])
def test_dimensionless_outputs_have_no_physical_keys(argv, capsys):
    code, stdout, _ = run(argv, capsys)
    assert code == 0
    data = json.loads(stdout)
    text = json.dumps(data)
    assert data.get("physical") is None
    assert not any(k in text for k in ('"field_mT"', '_mm"', '"energy_J"', '"value_N"'))
