"""Every shipped config validates and solves; physical scenes reduce to THEORY §5's groups.

The invariance test is a symmetry of the model: rescaling lengths, modulus, field and load so that
h and p are unchanged must give the same dimensionless equilibrium, and physical lengths that
scale with ℓ.
"""
import copy
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design.config import load_scene
from actuator_design.equilibrium.pipeline import solve
from actuator_design.physics.fields import check_current_free, field_model

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.yaml"))


def test_there_are_configs():
    assert len(CONFIGS) >= 5


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.stem)
def test_every_config_validates_and_solves(path):
    scene, options, raw = load_scene(path)
    if scene.field is not None and scene.field.kind == "expression":
        fm = field_model(scene.field)
        check_current_free(fm, fm.parameter_values(scene.field), name="scene.field")
    r = solve(scene, options)
    assert r.success, r.message
    assert r.stable
    assert np.all(np.isfinite(r.theta))
    assert r.el_residual < 1e-6


BASE = {
    "scene": {
        "type": "physical",
        "rod": {"length": "30 mm", "width": "6 mm", "thickness": "1.5 mm", "youngs_modulus": "1.5 MPa"},
        "magnetics": {"chi_bar": 0.8},
        "field": {"type": "uniform", "magnitude": "12 kA/m", "angle": "70 deg"},
        "loads": {"tip_force": {"x": "0 N", "y": "-2 mN"}},
        "fibres": "15 deg",
    }
}


def _rescaled(lam, mu):
    """ℓ, w, t → λ·(ℓ, w, t); E → μE. Then h² ∝ H²ℓ²/(E t²) is kept by H → H √μ, and
    p ∝ P ℓ²/(E w t³) by P → P μ λ²."""
    cfg = copy.deepcopy(BASE)
    rod = cfg["scene"]["rod"]
    rod["length"] = f"{30 * lam} mm"
    rod["width"] = f"{6 * lam} mm"
    rod["thickness"] = f"{1.5 * lam} mm"
    rod["youngs_modulus"] = f"{1.5 * mu} MPa"
    cfg["scene"]["field"]["magnitude"] = f"{12 * math.sqrt(mu)} kA/m"
    cfg["scene"]["loads"]["tip_force"]["y"] = f"{-2 * mu * lam**2} mN"
    return cfg


def test_h_from_physical_inputs_by_hand():
    """h² = μ0 χ̄ H² A ℓ² / (2 B) with B = E w t³/12 (THEORY §5, with its factor 2)."""
    scene, _, _ = load_scene(BASE)
    mu0 = 4e-7 * math.pi
    A, I, ell = 6e-3 * 1.5e-3, 6e-3 * 1.5e-3**3 / 12, 30e-3
    B = 1.5e6 * I
    assert scene.h**2 == pytest.approx(mu0 * 0.8 * 12e3**2 * A * ell**2 / (2 * B), rel=1e-12)
    assert scene.p == pytest.approx(-2e-3 * ell**2 / B, rel=1e-12)


@pytest.mark.parametrize("lam,mu", [(2.0, 3.0), (1e-3, 1e-3), (30.0, 400.0)])
def test_dimensional_dimensionless_invariance(lam, mu):
    s0, opts, _ = load_scene(BASE)
    s1, _, _ = load_scene(_rescaled(lam, mu))
    assert s1.h == pytest.approx(s0.h, rel=1e-12)
    assert s1.p == pytest.approx(s0.p, rel=1e-12)
    r0, r1 = solve(s0, opts), solve(s1, opts)
    np.testing.assert_allclose(r1.theta, r0.theta, atol=1e-10)
    p0, p1 = r0.physical(), r1.physical()
    assert p1["tip_x_m"] == pytest.approx(lam * p0["tip_x_m"], rel=1e-9)
    assert p1["tip_y_m"] == pytest.approx(lam * p0["tip_y_m"], rel=1e-9)
    # forces scale like B/ℓ² = μ λ² (the clamp balances the tip force)
    np.testing.assert_allclose(p1["clamp_force_N"], np.array(p0["clamp_force_N"]) * mu * lam**2, rtol=1e-9)
