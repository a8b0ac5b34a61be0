"""Hard-magnetic designs mean what they say (issue 17): the field is one field, so h_r ∝ H moves with
h ∝ H in the design; the NdFeB preset supplies its remanence; a hard-magnetic rod is designed with
its own physics (field, then magnetisation), never with a fibre layout.

Independent references: h_r by hand from THEORY §9 (μ0 ν M_r H A ℓ²/B0 with the preset's M_r), and
the tip of the shooting solver of ``actuator_design.reference`` at the *reported* field in mT (the
groups of a config written with that field), its own right-hand side and Legendre evaluation.
"""
import json
import math

import numpy as np
import pytest
import yaml

from actuator_design.cli.main import main
from actuator_design.config.model import load_config
from actuator_design.physics.magnetic_composite import MATERIALS
from actuator_design.reference.shooting import ShootingParams, shoot, solve_shooting

MU0 = 4e-7 * math.pi
ROD = {"length": "20 mm", "width": "5 mm", "thickness": "1 mm", "youngs_modulus": "1 MPa"}
NDFEB = {"particles": {"material": "ndfeb", "volume_fraction": 0.1}}


def strip(field_mT=10.0, angle_deg=90.0, magnetization="0 deg"):
    return {"scene": {"type": "physical", "rod": ROD, "magnetics": NDFEB, "magnetization": magnetization,
                      "field": {"type": "uniform", "magnitude": f"{field_mT!r} mT", "angle": f"{angle_deg!r} deg"}}}


def h_r_by_hand(field_mT):
    area, length, b0 = 5e-3 * 1e-3, 20e-3, 1e6 * 5e-3 * 1e-9 / 12
    m_r = 0.1 * MATERIALS["ndfeb"].remanence
    return MU0 * m_r * (field_mT * 1e-3 / MU0) * area * length ** 2 / b0


def test_the_ndfeb_preset_supplies_its_remanence():
    sc = load_config(strip()).to_scene()
    assert sc.h_r == pytest.approx(h_r_by_hand(10.0), rel=1e-12)
    assert sc.h > 0  # the composite's small susceptibility: a weak soft coupling beside it


def legendre(coefficients):
    c = np.asarray(coefficients, float)
    return lambda s: np.polynomial.legendre.legval(2 * np.asarray(s) - 1, c)


@pytest.mark.slow  # ~45 s: a whole design with its robustness box (benchmarks)
def test_a_hard_magnetic_design_reproduces_its_tip_at_the_reported_field(tmp_path, capsys):
    """The design's field in mT and angle, written into the user's config with the designed β(s),
    gives the reported tip by an independent shooting solve; h_r/h is the scene's at every field."""
    cfg = tmp_path / "ndfeb.yaml"
    cfg.write_text(yaml.safe_dump(strip()))
    assert main(["design", str(cfg), "--target-tip", "8,14", "--target-units", "mm", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["success"] and "alpha" not in d["vary"] and d["vary"][:2] == ["h", "phi"]
    base = load_config(strip()).to_scene()
    assert d["design"]["h_r"] / d["design"]["h"] == pytest.approx(base.h_r / base.h, rel=1e-9)
    mT = d["physical"]["field_mT"]
    assert d["design"]["h_r"] == pytest.approx(h_r_by_hand(mT), rel=1e-9)
    at = load_config(strip(field_mT=mT, angle_deg=math.degrees(d["design"]["phi"]))).to_scene()
    b = d["design"].get("magnetization", {}).get("legendre_coefficients", [0.0])
    params = ShootingParams(h=at.h, phi=at.phi, h_r=at.h_r, beta=legendre(b))
    # every equilibrium of the continuous rod at that field (sign changes of the free-end residual
    # over θ'(0)); the design's state must be one of them (one Newton start can land on another:
    # the rod has several, THEORY §8)
    span = 4.0 * (1.0 + at.h + at.h_r)
    grid = np.linspace(-span, span, 801)
    r = np.array([shoot(g, params).residual for g in grid])
    roots = [q for q in (solve_shooting(params, bracket=(grid[i], grid[i + 1]))
                         for i in range(grid.size - 1) if r[i] * r[i + 1] <= 0) if q.converged]
    tip_mm = np.array([d["physical"]["tip"]["x"], d["physical"]["tip"]["y"]])
    ref = min(roots, key=lambda q: np.hypot(*(20.0 * np.asarray(q.tip[:2]) - tip_mm)))
    assert ref.tip[0] * 20.0 == pytest.approx(d["physical"]["tip"]["x"], abs=1e-5)
    assert ref.tip[1] * 20.0 == pytest.approx(d["physical"]["tip"]["y"], abs=1e-5)
    assert math.hypot(d["physical"]["tip"]["x"] - 8.0, d["physical"]["tip"]["y"] - 14.0) < 1e-6


def test_a_rod_without_soft_coupling_has_no_h_to_vary(tmp_path, capsys):
    cfg = tmp_path / "hard.yaml"
    cfg.write_text("scene: {type: dimensionless, h: 0, phi: 1.5, h_r: 3.0}\n")
    assert main(["design", str(cfg), "--target-tip", "0.5,0.6", "--vary", "h,phi"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--vary h" in err[0] and "h_r" in err[0]
