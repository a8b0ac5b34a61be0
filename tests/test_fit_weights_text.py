"""The fit says which weights its s² uses (issue 21 item 4): the σ of each output, in the data
file's unit, and the row weights; s² is Σ ((model − data)/σ)² / dof over the reported points."""
import json
from pathlib import Path

import pytest

from actuator_design.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
CONFIG, DATA = str(ROOT / "configs/fit_zhao2019.yaml"), str(ROOT / "problems/data/zhao2019_cantilever.csv")


def test_s2_names_its_weights_and_is_the_weighted_residual_sum(capsys):
    assert main(["fit", CONFIG, "--data", DATA]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "s² =" in ln)
    # the config's uncertainty: ±0.01 L with L = 17.2 mm
    assert "σ = tip_deflection 0.172 mm" in line and "w = 1" in line
    assert main(["fit", CONFIG, "--data", DATA, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    sigma = 0.01 * 17.2e-3
    chi2 = sum((p["residual"]["tip_deflection"] / sigma) ** 2 for p in d["points"])
    assert d["s2"] == pytest.approx(chi2 / d["dof"], rel=1e-9)
