"""``design --target-shape`` on a physical scene: its figure and the scene's units (issue 21 items 2-3).

The target points are the independent shooting solution at (h, φ) = (1.3, 1.1) written in mm for
a 20 mm strip; the field the design reports in mT must be the one THEORY §5 gives for h = 1.3,
h² = μ0 χ̄ H² A ℓ² / (2 E I), computed here from the strip's dimensions.
"""
import csv
import json
import math

import pytest

from actuator_design.cli.main import main
from actuator_design.reference.shooting import ShootingParams, solve_shooting

L_MM, W_MM, T_MM, E_PA, CHI = 20.0, 5.0, 0.5, 1e6, 0.5
MU0 = 4e-7 * math.pi
CONFIG = f"""\
name: shape strip
scene:
  type: physical
  rod: {{length: {L_MM} mm, width: {W_MM} mm, thickness: {T_MM} mm, youngs_modulus: 1 MPa}}
  magnetics: {{chi_bar: {CHI}}}
  field: {{type: uniform, magnitude: 15 mT, angle: 60 deg}}
"""


def _field_mT_of(h):
    ell, w, t = L_MM * 1e-3, W_MM * 1e-3, T_MM * 1e-3
    bend = E_PA * w * t ** 3 / 12.0
    H = h / math.sqrt(MU0 * CHI * w * t * ell ** 2 / (2.0 * bend))
    return MU0 * H * 1e3


def test_shape_design_in_mm_and_mT_with_figure(tmp_path, capsys):
    ref = solve_shooting(ShootingParams(h=1.3, phi=1.1), 1.0)
    assert ref.converged
    s = [0.25, 0.5, 0.75, 1.0]
    pts = tmp_path / "shape_mm.csv"
    pts.write_text("s,x,y\n" + "\n".join(f"{v!r},{ref.x(v) * L_MM!r},{ref.y(v) * L_MM!r}" for v in s) + "\n")
    cfg = tmp_path / "strip.yaml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    code = main(["design", str(cfg), "--target-shape", str(pts), "--target-units", "mm",
                 "--vary", "h,phi", "--out", str(out)])
    captured = capsys.readouterr()
    text = captured.out
    assert code == 0, captured.err
    assert "mT" in text and "mm" in text and " N" in text
    d = json.loads((out / "design.json").read_text())
    assert d["design"]["h"] == pytest.approx(1.3, abs=1e-6)  # dimensionless keys kept
    phys = d["physical"]
    assert phys["length_unit"] == "mm"
    assert phys["field_mT"] == pytest.approx(_field_mT_of(1.3), rel=1e-6)
    assert phys["field_angle_deg"] == pytest.approx(math.degrees(1.1), abs=1e-5)
    assert phys["rms_error"] == pytest.approx(d["shape"]["rms_error"] * L_MM, rel=1e-9, abs=1e-12)
    with open(out / "shape_fit.csv", newline="") as fh:
        rows = [r for r in csv.reader(fh) if not r[0].startswith("#")]
    header, body = rows[0], rows[1:]
    assert {"x_target_mm", "y_fitted_mm"} <= set(header)
    i, j = header.index("x_target"), header.index("x_target_mm")
    for r in body:
        assert float(r[j]) == pytest.approx(float(r[i]) * L_MM, rel=1e-12)
    assert (out / "shape_fit.png").read_bytes()[:4] == b"\x89PNG"


def test_dimensionless_shape_design_has_no_physical_block(tmp_path):
    ref = solve_shooting(ShootingParams(h=1.3, phi=1.1), 1.0)
    pts = tmp_path / "shape.csv"
    pts.write_text("s,x,y\n" + "\n".join(f"{v!r},{ref.x(v)!r},{ref.y(v)!r}" for v in (0.5, 1.0)) + "\n")
    out = tmp_path / "out"
    assert main(["design", "--target-shape", str(pts), "--vary", "h,phi", "--out", str(out), "--json"]) == 0
    d = json.loads((out / "design.json").read_text())
    assert "physical" not in d
    header = (out / "shape_fit.csv").read_text().splitlines()[0]
    assert header == "s,x_target,y_target,x_fitted,y_fitted"
    assert (out / "shape_fit.png").exists()
