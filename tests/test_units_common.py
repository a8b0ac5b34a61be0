"""Common units read without pint (``units.COMMON_UNITS``) against pint itself (a second method),
and the registry created only when a value needs it."""
import subprocess
import sys

import pytest

from actuator_design.model import units
from actuator_design.model.units import COMMON_UNITS, DIMENSIONS, QuantityError, parse_quantity


def _by_pint(text, dimension):
    """parse_quantity's pint path (the common-unit table bypassed)."""
    dim = DIMENSIONS[dimension]
    q = units._parse_string(text, dim, "x")
    return units._to_si(q, text, dimension, dim, "x")


@pytest.mark.parametrize("unit", sorted(COMMON_UNITS))
@pytest.mark.parametrize("number", ["30", "-2.5", "1e-3", ".75", "4.0E2"])
def test_common_units_give_pint_values(unit, number):
    text = f"{number} {unit}"
    for dimension in DIMENSIONS:
        try:
            expected = _by_pint(text, dimension)
        except QuantityError:
            with pytest.raises(QuantityError):  # the same refusal (pint's message)
                parse_quantity(text, dimension, "x")
            continue
        got = parse_quantity(text, dimension, "x")
        assert got == pytest.approx(expected, rel=1e-15, abs=0.0)


def test_degree_sign_and_spacing():
    assert parse_quantity("30°", "angle") == pytest.approx(_by_pint("30 deg", "angle"), rel=1e-15)
    assert parse_quantity("  5kA/m ", "magnetic_field") == 5000.0


def test_pint_is_loaded_only_when_a_value_needs_it():
    code = ("import sys; from actuator_design.config import load_config; "
            "c = load_config({'scene': {'type': 'dimensionless', 'h': 1.0, 'phi': '30 deg', 'p': 0}}); "
            "c.to_scene(); a = 'pint' in sys.modules; "
            "from actuator_design.model.units import parse_quantity; parse_quantity('2 inch', 'length'); "
            "print(a, 'pint' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True"]
