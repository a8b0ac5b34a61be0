"""Small vibrations and the quasi-static check (issue 19 item 4): natural frequencies of the
straight cantilever against the Euler–Bernoulli roots of 1 + cos β cosh β = 0 (ω = β²), the
fundamental frequency vanishing at the Euler buckling load π²/4 (a static closed form), the
relaxation time in seconds against the hand formula, and the design's timed schedule checked."""
import csv
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from actuator_design.schedules.dynamics import natural_frequencies, relaxation_time
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scales, Scene


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


def _strip_schedule(tmp_path, capsys, substeps):
    """The `schedule` command on the isotropic strip with a density, timed by field and rotation rates."""
    import json

    import yaml

    from actuator_design.cli.main import main

    cfg = yaml.safe_load((Path(__file__).resolve().parents[1] / "configs" / "isotropic_mre_strip.yaml").read_text())
    cfg["scene"]["rod"]["density"] = "1800 kg/m^3"
    cfg["scene"]["rod"]["damping_ratio"] = 0.1
    cfg.pop("study", None)
    path = tmp_path / f"strip{substeps}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    argv = ["schedule", str(path), "--waypoints", "0.98764,0.142834;0.95,0.3", "--rate", "50 mT/s",
            "--rotation-rate", "300 deg/s", "--substeps", str(substeps), "--json", "--out", str(tmp_path / f"o{substeps}")]
    assert main(argv) == 0
    d = json.loads(capsys.readouterr().out)
    with open(tmp_path / f"o{substeps}" / "schedule.csv", newline="") as fh:
        tips = [(float(r["tip_x"]), float(r["tip_y"])) for r in csv.DictReader(fh)]
    return d, tips


def test_a_timed_field_schedule_reports_relaxation_times_and_the_tip_lag(tmp_path, capsys):
    """`schedule` with rates: step 0 (zero field, the straight rod) relaxes in the closed-form
    1/(ζ β₁²) √(ρA ℓ⁴/B); each step is flagged exactly when it is shorter than its state's
    relaxation time, and its tip lag is that of the slowest mode's damped oscillator driven by the
    quasi-static tip, integrated by an ODE solver along the steps' tips; refining the schedule
    twofold changes how many steps are flagged but hardly the largest lag."""
    E, w, t, L, rho, zeta = 1e6, 0.01, 0.001, 0.03, 1800.0, 0.1
    B, A = E * w * t**3 / 12, w * t
    (coarse, tc), (fine, tf) = _strip_schedule(tmp_path, capsys, 8), _strip_schedule(tmp_path, capsys, 16)
    for d, tips in ((coarse, tc), (fine, tf)):
        steps, qs = d["schedule"], d["quasi_static"]
        assert len(tips) == len(steps)
        assert not qs["damping_assumed"] and qs["damping_ratio"] == 0.1
        tau0 = 1.0 / (zeta * _beta(1) ** 2 * math.sqrt(B / (rho * A * L**4)))
        assert steps[0]["relaxation_time_s"] == pytest.approx(tau0, rel=1e-6)
        # the tip by an ODE integrator: ẍ + 2ζωẋ + ω²(x − p*) = 0, ω = 1/(ζτ), p* linear over each step
        lags, q = [0.0], np.array([*tips[0], 0.0, 0.0])
        for k in range(1, len(steps)):
            dt = steps[k]["time_s"] - steps[k - 1]["time_s"]
            tau = steps[k]["relaxation_time_s"]
            assert steps[k]["quasi_static"] == (dt >= tau)
            a, b, om = np.array(tips[k - 1]), np.array(tips[k]), 1.0 / (zeta * tau)
            rhs = lambda s, y: np.concatenate([y[2:], -2 * zeta * om * y[2:] - om**2 * (y[:2] - a - (b - a) * s / dt)])
            sol = solve_ivp(rhs, (0.0, dt), q, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
            s = np.linspace(0.0, dt, 4001)
            y = sol.sol(s)
            lags.append(float(np.max(np.hypot(y[0] - a[0] - (b[0] - a[0]) * s / dt, y[1] - a[1] - (b[1] - a[1]) * s / dt))))
            q = sol.y[:, -1]
            # (the code samples 32 times a period: a peak between samples is at most 1 − cos(π/32) = 0.5 % higher)
            assert steps[k]["tip_lag"] == pytest.approx(lags[-1], rel=6e-3, abs=1e-10)
        assert qs["largest_tip_lag"] == max(s["tip_lag"] for s in steps) == pytest.approx(max(lags), rel=6e-3)
        assert qs["largest_tip_lag_m"] == pytest.approx(qs["largest_tip_lag"] * L, rel=1e-12)
    # the second leg: steps of 0.54 s (coarse, longer than τ ≈ 0.39 s) or 0.27 s (fine, shorter)
    assert len(fine["quasi_static"]["too_fast"]) > len(coarse["quasi_static"]["too_fast"])
    second = [max(s["tip_lag"] for s in d["schedule"][d["waypoint_index"][0] + 1:]) for d in (coarse, fine)]
    # the lag converges as the steps refine (p* piecewise linear: its kinks ring a little): 8, 16, 32, 64
    # substeps give 0.0037, 0.0043, 0.0042, 0.0040 rod lengths
    assert second[1] == pytest.approx(second[0], rel=0.2)
