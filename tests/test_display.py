"""Printed numbers: never "-0", round-off of a zero angle printed as 0 (issue 21 item 4)."""
import math
import re

import pytest

from actuator_design.cli.main import main
from actuator_design.io.display import ANGLE_NOISE_RAD, degrees, number

_NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e[+-]?\d+)?", re.IGNORECASE)


def _negative_zeros(text):
    return [tok for tok in _NUMBER.findall(text) if tok.startswith("-") and float(tok) == 0.0]


@pytest.mark.parametrize("value,spec,expected", [
    (-0.0, ".6g", "0"), (0.0, ".6g", "0"), (-1e-20, ".10f", "0.0000000000"), (-4e-7, ".3f", "0.000"),
    (-3.0, ".6g", "-3"), (-2.5e-7, ".3g", "-2.5e-07"), (1.5, ".4g", "1.5"),
])
def test_number_drops_the_sign_of_a_zero_only(value, spec, expected):
    assert number(value, spec) == expected


def test_noise_threshold_and_degrees():
    assert number(3e-13, ".6g", noise=1e-12) == "0"
    assert number(3e-12, ".6g", noise=1e-12) == "3e-12"
    assert degrees(-1.2e-17) == "0"
    assert degrees(math.pi / 2) == "90"
    # a small angle above the round-off level is a value, printed as such
    assert degrees(10 * ANGLE_NOISE_RAD * 1e3) == format(math.degrees(1e-8), ".6g")
    assert degrees(float("nan")) == "nan"


def test_solve_on_the_axis_prints_no_negative_zero(capsys):
    """φ = 0: the straight rod; its clamp reaction is (-0, -0) in floating point."""
    assert main(["solve", "--h", "2", "--phi-deg", "0"]) == 0
    out = capsys.readouterr().out
    assert "clamp" in out
    assert _negative_zeros(out) == []


def test_a_fit_config_named_fit_is_not_titled_fit_fit(capsys):
    """Every shipped fit config is named "fit: ..."; the report's first line says "fit:" once."""
    from pathlib import Path

    import yaml

    root = Path(__file__).resolve().parents[1]
    config = root / "configs" / "fit_zhao2019.yaml"
    assert yaml.safe_load(config.read_text())["name"].startswith("fit: ")
    assert main(["fit", str(config), "--data", str(root / "problems" / "data" / "zhao2019_cantilever.csv")]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("fit: ") and not first.startswith("fit: fit:")
