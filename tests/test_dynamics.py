"""Small vibrations and the quasi-static check (issue 19 item 4): natural frequencies of the
straight cantilever against the Euler–Bernoulli roots of 1 + cos β cosh β = 0 (ω = β²), the
fundamental frequency vanishing at the Euler buckling load π²/4 (a static closed form), the
relaxation time in seconds against the hand formula, and the design's timed schedule checked."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from actuator_design.analysis.dynamics import natural_frequencies, relaxation_time
from actuator_design.equilibrium import solve
from actuator_design.options import SolverOptions
from actuator_design.scene import Scales, Scene


def _beta(k):
    return brentq(lambda b: 1 + math.cos(b) * math.cosh(b), (k - 1) * math.pi + 1e-9, k * math.pi, xtol=1e-15)


@pytest.mark.parametrize("elements, degree", [(4, 10), (8, 10), (16, 10), (2, 20)])
def test_cantilever_frequencies_are_euler_bernoulli(elements, degree):
    r = solve(Scene(field=None), SolverOptions(elements=elements, degree=degree))
    ref = np.array([_beta(k) ** 2 for k in (1, 2, 3)])
    np.testing.assert_allclose(natural_frequencies(r, 3), ref, rtol=1e-9)


def test_the_fundamental_frequency_vanishes_at_the_buckling_load():
    """Under an axial compressive tip load the straight rod's lowest frequency falls to zero at
    P = π²/4, Euler's load of the cantilever (ω₁² is nearly linear in P below it)."""
    pc = math.pi**2 / 4
    w = [float(natural_frequencies(solve(Scene(field=None, tip_force=(-f * pc, 0.0))), 1)[0]) for f in (0, 0.5, 0.9, 0.999)]
    assert all(a > b for a, b in zip(w, w[1:]))
    assert w[-1] < 0.05 * w[0]
    slope = (w[2] ** 2 - w[1] ** 2) / 0.4  # extrapolate ω₁² linearly to zero
    assert abs(0.9 - w[2] ** 2 / slope - 1.0) <= 0.02


def test_relaxation_time_in_seconds():
    """τ = 1/(ζ ω₁) with ω₁ = β₁² √(B/(ρA ℓ⁴)) for a 30 × 10 × 1 mm strip of E = 1 MPa, 1800 kg/m³."""
    E, w, t, L, rho, zeta = 1e6, 0.01, 0.001, 0.03, 1800.0, 0.05
    B, A = E * w * t**3 / 12, w * t
    sc = Scales(length=L, bending_stiffness=B, mass_per_length=rho * A)
    tau = relaxation_time(solve(Scene(field=None)), rho * A, zeta, sc)
    assert tau == pytest.approx(1.0 / (zeta * _beta(1) ** 2 * math.sqrt(B / (rho * A * L**4))), rel=1e-9)


def test_a_timed_design_schedule_is_checked_against_the_relaxation_time(tmp_path, capsys):
    import json

    import yaml

    from actuator_design.cli.main import main

    cfg = yaml.safe_load((Path(__file__).resolve().parents[1] / "configs" / "isotropic_mre_strip.yaml").read_text())
    cfg["scene"]["rod"]["density"] = "1800 kg/m^3"
    path = tmp_path / "strip.yaml"
    path.write_text(yaml.safe_dump(cfg))
    argv = ["design", str(path), "--target-tip", "0.98764,0.142834", "--rotation-rate", "30 deg/s"]
    assert main(argv + ["--rate", "5 mT/s", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    qs = d["quasi_static"]
    assert qs["damping_assumed"] and qs["damping_ratio"] == 0.05 and qs["too_fast"]
    assert qs["slowest_relaxation_time_s"] > 0.75  # the straight rod's 0.7524 s, slower in the field
    assert main(argv + ["--rate", "0.05 mT/s", "--json"]) == 0  # a hundred times slower: quasi-static
    d = json.loads(capsys.readouterr().out)
    assert d["quasi_static"]["too_fast"] == []
    cfg["scene"]["rod"].pop("density")
    path.write_text(yaml.safe_dump(cfg))
    assert main(argv + ["--rate", "5 mT/s"]) == 0
    assert "quasi-static: not checked (give rod.density" in capsys.readouterr().out
