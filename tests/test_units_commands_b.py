"""The user's units in every output of ``path``, ``stiffness``, ``fit`` and ``study`` (issue 21
item 2): text, JSON (beside the dimensionless keys), CSV headers and figure axes of a physical
scene; a dimensionless scene's outputs stay without them.

Every reference value is converted here from the YAML's inputs, never by the code under test
(THEORY §5): x [mm] = x̂ ℓ / 1 mm, loads in B0/ℓ², energies in B0/ℓ, stiffness in B0/ℓ³ with
B0 = E w t³/12, and the field μ0 H of a group h from h² = μ0 χ̄ H² A ℓ² / (2 B0), A = w t.
"""
import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from unit_outputs import (B0, CHI, E, L, MM, MU0, T, W, dh_dH, figures, mT_of_h,  # noqa: F401
                          read_csv, run, scene)  # figures: a fixture

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "problems" / "data"


def write(tmp_path, cfg: dict, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(cfg, allow_unicode=True))
    return path


SOLVER = {"elements": 4, "degree": 10}


# -- path -----------------------------------------------------------------------------------------
def test_path_load_ramp_with_snaps_in_mm_N_and_J(tmp_path, capsys, figures):
    cfg = write(tmp_path, {"name": "path units", "scene": scene(), "solver": SOLVER})
    out = tmp_path / "p"
    code, stdout, _ = run(["path", cfg, "--param", "p", "--schedule", "0.07 mN,-0.2 mN,0.2 mN,0.07 mN",
                           "--out", out], capsys)
    assert code == 0
    assert "final tip [mm]" in stdout and " J" in stdout and "schedule of p [N]" in stdout
    assert "jump (fold) at p = " in stdout and " N: tip (" in stdout and "hysteresis width [N]" in stdout
    assert "nan" not in stdout
    data = json.loads((out / "path.json").read_text())
    phys = data["physical"]
    assert phys["length_unit"] == "mm" and phys["units"]["tip"] == "mm"
    for pt in data["points"]:
        assert pt["physical"]["tip"]["x"] == pytest.approx(pt["tip"]["x"] * L / MM, rel=1e-12)
        assert pt["physical"]["tip"]["y"] == pytest.approx(pt["tip"]["y"] * L / MM, rel=1e-12, abs=1e-12)
        assert pt["physical"]["energy_J"] == pytest.approx(pt["energy"] * B0 / L, rel=1e-12, abs=1e-25)
        assert pt["value_N"] == pytest.approx(pt["param"] * B0 / L**2, rel=1e-12)
    assert len(data["jumps"]) == 2
    for j in data["jumps"]:
        assert j["physical"]["from_tip"]["x"] == pytest.approx(j["from"]["tip"]["x"] * L / MM, rel=1e-12)
        assert j["physical"]["energy_released_J"] == pytest.approx(j["energy_released"] * B0 / L, rel=1e-12)
    assert phys["hysteresis"]["unit"] == "N"
    assert phys["hysteresis"]["width"] == pytest.approx(data["hysteresis"]["width"] * B0 / L**2, rel=1e-12)
    assert phys["schedule"]["p"][0] == "N"
    assert phys["schedule"]["p"][1] == pytest.approx([0.07e-3, -0.2e-3, 0.2e-3, 0.07e-3], rel=1e-12)
    rows, comments = read_csv(out / "path.csv")
    assert {"tip_x_mm", "tip_y_mm", "energy_J", "value_p_N"} <= set(rows[0])
    assert "tip_x_mm, tip_y_mm in mm" in comments[0] and "value_p_N in N" in comments[0]
    for r in rows:
        assert float(r["tip_x_mm"]) == pytest.approx(float(r["tip_x"]) * L / MM, rel=1e-12)
        assert float(r["value_p_N"]) == pytest.approx(float(r["value_p"]) * B0 / L**2, rel=1e-12)
    (fig,) = figures
    ax_angle, ax_energy = fig.axes[:2]
    assert ax_angle.get_xlabel() == ax_energy.get_xlabel() == "p / N"
    assert ax_energy.get_ylabel() == "energy / J"
    assert "N" in ax_angle.get_title()  # the hysteresis width, in N


def test_path_field_ramp_in_mT(tmp_path, capsys, figures):
    cfg = write(tmp_path, {"name": "path field", "scene": scene(loads={}), "solver": SOLVER})
    out = tmp_path / "p"
    code, stdout, _ = run(["path", cfg, "--param", "h", "--from", "0", "--to", "10 mT", "--steps", "3",
                           "--json", "--out", out], capsys)
    assert code == 0
    data = json.loads(stdout)
    assert data["physical"]["schedule"]["h"][0] == "mT"
    assert data["physical"]["schedule"]["h"][1] == pytest.approx([0.0, 10.0], abs=1e-9)
    for pt in data["points"]:
        assert pt["field_mT"] == pytest.approx(mT_of_h(pt["param"]), rel=1e-12, abs=1e-12)
    rows, _ = read_csv(out / "path.csv")
    assert float(rows[-1]["value_h_mT"]) == pytest.approx(10.0, rel=1e-9)
    (fig,) = figures
    assert fig.axes[0].get_xlabel() == "field μ0H / mT"


# -- stiffness ------------------------------------------------------------------------------------
def test_stiffness_in_N_per_m_m_per_N_and_mT(tmp_path, capsys, figures):
    cfg = write(tmp_path, {"name": "stiffness units", "scene": scene(loads={}), "solver": SOLVER})
    out = tmp_path / "s"
    code, stdout, _ = run(["stiffness", cfg, "--field-sweep", "0 mT,20 mT", "--n", "3", "--out", out], capsys)
    assert code == 0
    for word in ("N/m", "m/N", "rad/(N m)", "mu0 H = 25 mT", "mm", "from 0 to 20 mT"):
        assert word in stdout, word
    assert "nan" not in stdout
    data = json.loads((out / "stiffness.json").read_text())
    phys, eq = data["physical"], data["equilibrium"]
    assert phys["field_mT"] == pytest.approx(25.0, rel=1e-9) == pytest.approx(mT_of_h(eq["h"]), rel=1e-9)
    assert phys["tip"]["x"] == pytest.approx(eq["tip"]["x"] * L / MM, rel=1e-12)
    assert phys["vertical_stiffness_N_per_m"] == pytest.approx(data["vertical_stiffness"] * B0 / L**3, rel=1e-12)
    C, K = np.array(data["compliance"]), np.array(data["stiffness"])
    assert data["tips"] == ["x", "y", "angle"] and data["loads"] == ["fx", "fy", "m_tip"]
    assert phys["compliance_units"] == [["m/N", "m/N", "1/N"], ["m/N", "m/N", "1/N"],
                                        ["rad/N", "rad/N", "rad/(N m)"]]
    assert phys["compliance"][1][1] == pytest.approx(C[1, 1] * L**3 / B0, rel=1e-12)
    assert phys["compliance"][1][2] == pytest.approx(C[1, 2] * L**2 / B0, rel=1e-12)
    assert phys["compliance"][2][2] == pytest.approx(C[2, 2] * L / B0, rel=1e-12)
    assert phys["stiffness_units"][0] == ["N/m", "N/m", "N/rad"] and phys["stiffness_units"][2][0] == "N"
    assert phys["stiffness"][1][1] == pytest.approx(K[1, 1] * B0 / L**3, rel=1e-12)
    assert phys["stiffness"][2][2] == pytest.approx(K[2, 2] * B0 / L, rel=1e-12)
    # C_SI⁻¹ is K_SI: the two SI matrices are one another's inverse
    np.testing.assert_allclose(np.linalg.inv(np.array(phys["compliance"])), phys["stiffness"], rtol=1e-6)
    sweep = data["field_sweep"]
    assert sweep["field_mT"] == pytest.approx([0.0, 10.0, 20.0], abs=1e-9)
    assert sweep["field_mT"] == pytest.approx([mT_of_h(h) for h in sweep["h"]], abs=1e-9)
    assert sweep["lowload_s_N_per_m"] == pytest.approx([s * B0 / L**3 for s in sweep["lowload_s"]], rel=1e-12)
    rows, comments = read_csv(out / "stiffness_curve.csv")
    assert {"field_mT", "lowload_s_N_per_m", "vertical_stiffness_N_per_m"} <= set(rows[0])
    assert "field_mT = mu0 H in mT" in comments[0]
    assert [float(r["field_mT"]) for r in rows] == pytest.approx([0.0, 10.0, 20.0], abs=1e-9)
    (fig,) = figures
    ax = fig.axes[0]
    assert "mT" in ax.get_xlabel() and "kA/m" not in ax.get_xlabel() and "N/m" in ax.get_ylabel()


def test_stiffness_without_a_field_scale_says_so_and_prints_no_nan_mT(tmp_path, capsys, figures):
    cfg = write(tmp_path, {"name": "no field scale", "scene": scene(magnetics={"chi_bar": 0}, loads={}),
                           "solver": SOLVER})
    code, stdout, _ = run(["stiffness", cfg, "--field-sweep", "0,1", "--n", "2", "--out", tmp_path / "s"],
                          capsys)
    assert code == 0
    assert "no field scale" in stdout and "nan mT" not in stdout and "N/m" in stdout
    data = json.loads((tmp_path / "s" / "stiffness.json").read_text())
    assert "field_mT" not in data["physical"] and "field_mT" not in data["field_sweep"]
    rows, _ = read_csv(tmp_path / "s" / "stiffness_curve.csv")
    assert "field_mT" not in rows[0]
    assert "no field scale" in figures[0].axes[0].get_xlabel()


# -- fit ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("length, unit, per", [("20 mm", "mm", 1e-3), ("2 cm", "cm", 1e-2)])
def test_fit_load_deflection_in_the_rod_length_unit_mT_and_N(tmp_path, capsys, figures, length, unit, per):
    """Data in kA/m, mN and mm (problems/data/synthetic_load_deflection.csv): the CSV adds the
    field in mT and the load in N (and, for a rod written in cm, the deflections in cm)."""
    s = scene(field={"type": "uniform", "magnitude": "10 mT", "angle": "0 deg"},
              loads={"tip_force": {"x": "0 N", "y": "0.2 mN"}})
    s["rod"] = dict(s["rod"], length=length, thickness="0.5 mm", youngs_modulus="2 MPa")
    s["magnetics"] = {"chi_bar": 0.2}
    cfg = write(tmp_path, {"name": "fit: units", "scene": s, "study": {
        "type": "fit", "parameters": {"chi_bar": {"bounds": [0.01, 5]},
                                      "youngs_modulus": {"bounds": ["0.1 MPa", "20 MPa"]}}}})
    out = tmp_path / "f"
    code, stdout, _ = run(["fit", cfg, "--data", DATA / "synthetic_load_deflection.csv", "--out", out], capsys)
    assert code == 0
    assert f"user units  : lengths in {unit}" in stdout and "mT" in stdout and "forces in N" in stdout
    data = json.loads((out / "fit.json").read_text())
    phys = data["physical"]
    assert phys["length_unit"] == unit
    assert phys["units"] == {"field": "mT (mu0 H)", "load": "N", "tip_deflection": unit}
    for p, sp in zip(phys["points"], data["points"]):
        assert p["inputs"]["field"] == pytest.approx(sp["inputs"]["field"] * MU0 * 1e3, rel=1e-12)
        assert p["inputs"]["load"] == pytest.approx(sp["inputs"]["load"], rel=1e-12)
        assert p["model"]["tip_deflection"] == pytest.approx(sp["model"]["tip_deflection"] / per, rel=1e-12)
    rows, _ = read_csv(out / "fit_points.csv")
    extra = {"field [mT]", "load [N]"} | ({f"tip_deflection [{unit}]", f"tip_deflection_model [{unit}]"}
                                         if unit != "mm" else set())
    assert extra <= set(rows[0])
    for r in rows:
        assert float(r["field [mT]"]) == pytest.approx(float(r["field [kA/m]"]) * 1e3 * MU0 * 1e3, rel=1e-12)
        assert float(r["load [N]"]) == pytest.approx(float(r["load [mN]"]) * 1e-3, rel=1e-12)
        if unit != "mm":
            assert float(r[f"tip_deflection [{unit}]"]) == pytest.approx(
                float(r["tip_deflection [mm]"]) * 1e-3 / per, rel=1e-12)
    model, residuals = figures
    ax = model.axes[0]
    assert ax.get_xlabel() == "load [N]" and ax.get_ylabel() == f"tip_deflection [{unit}]"
    assert any("mT" in t.get_text() for t in ax.get_legend().get_texts())
    assert residuals.axes[0].get_ylabel().endswith(f"[{unit}]")


def test_fit_critical_field_in_mT(tmp_path, capsys):
    """The transverse critical field (THEORY §6: h_crit = π/(2√2)) also in mT, from the fitted χ̄."""
    s = scene(field={"type": "uniform", "magnitude": "20 kA/m", "angle": "90 deg"}, loads={})
    cfg = write(tmp_path, {"name": "fit: transverse", "scene": s, "study": {
        "type": "fit", "parameters": {"chi_bar": {"initial": 0.3, "bounds": [0.01, 5]},
                                      "clamp_angle": {"initial": "0 deg", "bounds": ["-5 deg", "5 deg"]}}}})
    code, stdout, _ = run(["fit", cfg, "--data", DATA / "synthetic_transverse_buckling.csv", "--json"], capsys)
    assert code == 0
    data = json.loads(stdout)
    chi = data["parameters"]["chi_bar"]["value"]
    hc_mT = math.pi / (2 * math.sqrt(2)) / dh_dH(chi=chi) * MU0 * 1e3
    crit = data["physical"]["derived"]["transverse_critical_field"]
    assert crit["value_mT"] == pytest.approx(hc_mT, rel=1e-9)
    assert crit["ci_mT"][0] < crit["value_mT"] < crit["ci_mT"][1]
    assert data["physical"]["units"]["tip_angle"] == "deg"


# -- study ----------------------------------------------------------------------------------------
def test_study_table_dataset_and_figure_in_the_users_units(tmp_path, capsys, figures):
    import xarray as xr

    cfg = write(tmp_path, {"name": "study units", "scene": scene(), "solver": SOLVER, "study": {
        "type": "sweep", "grid": "cartesian",
        "sweep": {"field.magnitude": {"from": "0 kA/m", "to": "20 kA/m", "n": 3},
                  "loads.tip_force.y": ["-0.02 mN", "0.02 mN"]},
        "analyses": ["solve"]}})
    out = tmp_path / "s"
    code, stdout, _ = run(["study", cfg, "--out", out, "--workers", "1", "--no-progress"], capsys)
    assert code == 0
    line = next(ln for ln in stdout.splitlines() if "user units" in ln)
    assert "lengths in mm" in line and "mT" in line and "field.magnitude [mT]" in line
    with open(out / "results.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for col in ("field.magnitude [mT]", "loads.tip_force.y [N]", "solve.tip.x_mm", "solve.h_mT",
                "solve.physical.tip_x_mm", "solve.physical.field_mT"):
        assert col in rows[0], col
    for r in rows:
        mT = float(r["field.magnitude [kA/m]"]) * 1e3 * MU0 * 1e3
        assert float(r["field.magnitude [mT]"]) == pytest.approx(mT, rel=1e-12, abs=1e-12)
        assert float(r["solve.h_mT"]) == pytest.approx(mT_of_h(float(r["solve.h"])), rel=1e-9, abs=1e-9)
        assert float(r["solve.h_mT"]) == pytest.approx(mT, rel=1e-9, abs=1e-9)
        assert float(r["loads.tip_force.y [N]"]) == pytest.approx(float(r["loads.tip_force.y [mN]"]) * 1e-3)
        assert float(r["solve.tip.x_mm"]) == pytest.approx(float(r["solve.tip.x"]) * L / MM, rel=1e-12)
        assert float(r["solve.physical.tip_x_mm"]) == pytest.approx(float(r["solve.tip.x"]) * L / MM, rel=1e-9)
    with xr.open_dataset(out / "results.nc", engine="scipy") as ds:
        ds = ds.load()
    assert ds["field.magnitude_mT"].attrs["units"] == "mT"
    assert ds["field.magnitude_mT"].dims == ("field.magnitude",)
    assert ds["field.magnitude_mT"].values == pytest.approx(ds["field.magnitude"].values * 1e3 * MU0 * 1e3)
    assert ds["loads.tip_force.y_N"].attrs["units"] == "N"
    assert ds["solve.tip.x_mm"].attrs["units"] == "mm" and ds["solve.h_mT"].attrs["units"] == "mT"
    assert ds["solve.physical.tip_x_mm"].attrs["units"] == "mm"
    (fig,) = figures
    assert fig.axes[0].get_xlabel() == "field.magnitude [mT]"
    assert any("[N]" in a.get_ylabel() for a in fig.axes[1:])  # the colour bar of the swept load
    code, stdout, _ = run(["study", cfg, "--out", out, "--workers", "1", "--no-progress", "--resume",
                           "--json"], capsys)
    assert code == 0
    phys = json.loads(stdout)["physical"]
    assert phys["length_unit"] == "mm" and phys["columns"]["solve.tip.x_mm"] == "mm"
    assert phys["columns"]["field.magnitude [mT]"] == "mT (mu0 H)"


# -- a dimensionless scene: nothing added -----------------------------------------------------------
def test_dimensionless_outputs_have_no_physical_keys(tmp_path, capsys, figures):
    code, stdout, _ = run(["path", "--param", "h", "--from", "0", "--to", "1", "--steps", "2", "--json",
                           "--out", tmp_path / "p", "--elements", "4"], capsys)
    assert code == 0
    data = json.loads(stdout)
    assert "physical" not in data and all("physical" not in p and "field_mT" not in p for p in data["points"])
    rows, comments = read_csv(tmp_path / "p" / "path.csv")
    assert not [c for c in rows[0] if c.endswith(("_mm", "_J", "_mT", "_N"))] and "mm" not in comments[0]
    assert figures[-1].axes[0].get_xlabel() == "h"
    code, stdout, _ = run(["stiffness", "--json", "--elements", "4"], capsys)
    assert code == 0
    data = json.loads(stdout)
    assert "physical" not in data and data["vertical_stiffness_N_per_m"] is None
    code, stdout, _ = run(["stiffness", "--field-sweep", "0,1", "--n", "2", "--elements", "4"], capsys)
    assert code == 0 and "user's units" not in stdout and "N/m" not in stdout

    from actuator_design.calibration import fit_config
    from actuator_design.calibration.report import points_csv_text, result_dict, summary_text
    fit_cfg = {"name": "h from field data",
               "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
               "study": {"type": "fit", "parameters": {"h": {"initial": 0.7, "bounds": [0.01, 10]}},
                         "reference_field": "10 kA/m"}}
    res = fit_config(fit_cfg, DATA / "synthetic_transverse_buckling.csv")
    from actuator_design.calibration.outputs import fit_files
    files = fit_files(res, config=fit_cfg)
    assert "physical" not in json.loads(files["fit.json"]) and "physical" not in result_dict(res)
    assert files["fit_points.csv"] == points_csv_text(res) and "user units" not in summary_text(res)

    grid = {"name": "dimensionless sweep", "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg"},
            "solver": SOLVER,
            "study": {"type": "sweep", "sweep": {"h": [0.5, 1.5]}, "analyses": ["solve"]}}
    out = tmp_path / "s"
    code, stdout, _ = run(["study", write(tmp_path, grid, "grid.yaml"), "--out", out, "--workers", "1",
                           "--no-progress", "--json"], capsys)
    assert code == 0 and "physical" not in json.loads(stdout)
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert not [c for c in header if c.endswith(("_mm", "_mT", "]"))]
