"""Design for a target shape (issue 9 item 2): points along the centreline, least squares.

The reference shape comes from the independent shooting solver at a known field (h, φ) = (1.3, 1.1);
the design must give that field back and pass through the points."""
import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.inverse.shape import design_shape, read_shape_points
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import default_scene
from actuator_design.reference.shooting import ShootingParams, solve_shooting

S = np.array([0.25, 0.5, 0.75, 1.0])


@pytest.fixture(scope="module")
def points():
    ref = solve_shooting(ShootingParams(h=1.3, phi=1.1), 1.0)
    assert ref.converged and ref.tip_y > 0.1  # the deflected state of this field
    return np.column_stack([S, [ref.x(v) for v in S], [ref.y(v) for v in S]]).astype(float)


def test_shape_recovers_the_field_of_a_shooting_shape(points):
    res = design_shape(points, vary=["h", "phi"])
    assert res.success and res.verified and res.stable
    assert res.design["h"] == pytest.approx(1.3, abs=1e-7)
    assert res.design["phi"] == pytest.approx(1.1, abs=1e-7)
    assert res.rms_error < 1e-8


def test_cli_shape_and_bad_files(points, tmp_path):
    f = tmp_path / "shape.csv"
    f.write_text("s,x,y\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in points) + "\n")
    exe = [sys.executable, "-m", "actuator_design.cli.main", "design"]
    p = subprocess.run(exe + ["--target-shape", str(f), "--vary", "h,phi", "--json"], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["success"] and d["shape"]["rms_error"] < 1e-8 and len(d["shape"]["points"]) == 4
    bad = tmp_path / "bad.csv"
    for text, words in (("x,y,s\n1,2,3\n", "header must be s,x,y"),
                        ("s,x,y\n0.5,0.6,0\n", "farther than the arc length"),
                        ("s,x,y\n1.5,0.1,0\n", "s must lie in (0, 1]")):
        bad.write_text(text)
        p = subprocess.run(exe + ["--target-shape", str(bad)], capture_output=True, text=True, timeout=120)
        assert p.returncode == 2 and words in p.stderr and not p.stdout


def test_read_shape_points_sorts_and_scales():
    pts = read_shape_points("s,x,y\n1,0.5,0.5\n0.5,0.25,0.1\n", scale=0.5)
    assert pts[:, 0].tolist() == [0.5, 1.0] and pts[1, 1] == pytest.approx(0.25)


def test_shape_of_a_soft_and_hard_rod_moves_the_remanent_group_with_the_field():
    """One field acts through h and h_r together (h_r ∝ H, THEORY §9): the shape fit varies h with
    h_r moved in proportion, as the forward scene it reports does (the one design map; before, the fit
    held h_r at the base value and landed on another field). Reference: shooting at h = 1.2 with
    h_r = 1.5 · 1.2/0.8, the base scene's ratio."""
    base = default_scene(h=0.8, phi=2.0944, alpha=0.349)
    base = replace(base, h_r=1.5, magnetization=constant_profile(0.0), tip_force=(0.0, -0.3))
    ref = solve_shooting(ShootingParams(h=1.2, phi=2.0944, alpha=0.349, h_r=2.25, fy=-0.3), 1.0)
    assert ref.converged
    pts = np.column_stack([S, [ref.x(v) for v in S], [ref.y(v) for v in S]]).astype(float)
    res = design_shape(pts, base, vary=["h"])
    assert res.success and res.verified and res.stable, res.message
    assert res.design["h"] == pytest.approx(1.2, abs=1e-6)
    assert res.design_scene.h_r == pytest.approx(2.25, abs=1e-5)
    assert res.rms_error < 1e-6
