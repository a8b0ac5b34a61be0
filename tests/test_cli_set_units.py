"""``--set NAME=VALUE`` reads units: angles always ('30deg'), fields and loads on a physical scene.

A plain number stays dimensionless (angles in rad), as before. A field given as a field ('2 mT') is
the applied field: every group it drives follows (THEORY §5: h ∝ H and h_pos ∝ H), as the design's
reported field does; on a physical scene so does the field group h given as a plain number. References: the field scale of a point dipole by hand, H0 = m / (4π ℓ³) (the
dipole field at distance ℓ, configs/permanent_magnet_dipole.yaml), and degrees to radians by hand.
"""
import json
import math
from pathlib import Path

import pytest

from actuator_design.cli.main import main

DIPOLE = str(Path(__file__).resolve().parents[1] / "configs" / "permanent_magnet_dipole.yaml")
MU0 = 4e-7 * math.pi


def _run(capsys, *argv):
    assert main(["solve", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_an_angle_with_a_unit_is_converted_and_a_plain_number_is_radians(capsys):
    deg = _run(capsys, "--set", "h=2", "--set", "phi=30deg")
    rad = _run(capsys, "--set", "h=2", "--set", f"phi={math.radians(30.0)!r}")
    assert deg["phi"] == pytest.approx(math.radians(30.0), rel=1e-15)
    assert deg["tip"] == rad["tip"]
    assert _run(capsys, "--set", "h=2", "--set", "phi=0.5")["phi"] == 0.5


def test_a_field_with_a_unit_is_the_applied_field_and_moves_every_group_it_drives(capsys):
    base = _run(capsys, DIPOLE)["groups"]
    H0 = 0.05 / (4 * math.pi * 0.020 ** 3)  # A/m: moment 0.05 A m², rod length 20 mm
    scaled = _run(capsys, DIPOLE, "--set", f"h={1.3 * MU0 * H0 * 1e3!r} mT")["groups"]
    assert scaled["h"] == pytest.approx(1.3 * base["h"], rel=1e-12)
    assert scaled["h_pos"] / scaled["h"] == pytest.approx(base["h_pos"] / base["h"], rel=1e-12)
    # on a physical scene the field group given as a plain number is the field too: the same scene
    plain = _run(capsys, DIPOLE, "--set", f"h={scaled['h']!r}")["groups"]
    assert plain["h_pos"] == pytest.approx(scaled["h_pos"], rel=1e-12)


@pytest.mark.parametrize("argv, message", [
    (["--set", "h=2 mT"], "--set h: '2 mT' has a unit, but the scene is dimensionless"),
    ([DIPOLE, "--set", "p=1 mT"], "--set p: expected a force"),
    (["--set", "phi=1e9deg"], "--set phi: must be a finite angle in"),
    (["--set", "phi=30 furlongs"], "--set phi"),
    (["--set", "phi=1e300"], "--set phi: must be a finite angle in [-17453.3, 17453.3] rad, got 1e+300 rad"),
    (["--set", "alpha=-2e4"], "--set alpha: must be a finite angle in"),
])
def test_a_value_with_a_wrong_unit_is_one_line_naming_the_flag(capsys, argv, message):
    assert main(["solve", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
