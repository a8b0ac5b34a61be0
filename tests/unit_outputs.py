"""Shared helpers of the tests of the user's units in command outputs (test_units_commands_*):
the rod both use (in SI, written in mm, MPa and mT in its YAML) and its conversions by hand, run a
command in-process, catch the figures it encodes, read a CSV with its comment lines."""
import csv
import io
import math
from pathlib import Path

import pytest

from actuator_design.cli.main import main

MU0 = 4e-7 * math.pi
# the rod, in SI; scene() writes it in mm, MPa and mT
L, W, T, E, CHI = 20e-3, 5e-3, 0.5e-3, 1e6, 0.5
B0 = E * W * T**3 / 12.0
MM = 1e-3


def scene(**changes) -> dict:
    """The rod's ``scene:`` section in the user's units (25 mT across it, a 0.07 mN tip load)."""
    s = {"type": "physical",
         "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm", "youngs_modulus": "1 MPa"},
         "magnetics": {"chi_bar": CHI},
         "field": {"type": "uniform", "magnitude": "25 mT", "angle": "90 deg"},
         "loads": {"tip_force": {"x": "0 N", "y": "0.07 mN"}},
         "fibres": "0 deg"}
    s.update(changes)
    return s


def dh_dH(chi: float = CHI, e: float = E, length: float = L) -> float:
    """h per A/m by hand: h = H √(μ0 χ̄ A ℓ² / (2 B0)) (THEORY §5)."""
    return math.sqrt(MU0 * chi * W * T * length**2 / (2.0 * e * W * T**3 / 12.0))


def mT_of_h(h: float) -> float:
    """μ0 H in mT of the group h, by hand."""
    return h / dh_dH() * MU0 * 1e3


def run(argv, capsys):
    """``(exit code, stdout, stderr)`` of ``actuator-design argv`` run in this process."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def figures(monkeypatch):
    """Every Figure a command encodes as PNG, in order (an Axes given is taken as its figure)."""
    from actuator_design.viz import style

    real, seen = style.png_bytes, []

    def capture(fig, *args, **kwargs):
        seen.append(getattr(fig, "figure", fig) if not hasattr(fig, "savefig") else fig)
        return real(fig, *args, **kwargs)

    monkeypatch.setattr(style, "png_bytes", capture)
    return seen


def read_csv(path: Path):
    """``(rows as dicts, comment lines)`` of a CSV whose comments start with ``#``."""
    text = Path(path).read_text().splitlines()
    rows = list(csv.DictReader(io.StringIO("\n".join(ln for ln in text if not ln.startswith("#")))))
    return rows, [ln for ln in text if ln.startswith("#")]
