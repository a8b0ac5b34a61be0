"""Tangent tip stiffness against independent references: THEORY §6's s(h), a transverse-field
linearisation derived here, finite differences of independent solves, and Maxwell–Betti
reciprocity (the compliance is the inverse of a Hessian, hence symmetric)."""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from actuator_design.analysis.stiffness import stiffness_field_curve, tip_stiffness
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reference.closed_forms import lowload_stiffness
from actuator_design.reference.shooting import ShootingParams, solve_shooting
from actuator_design.model.scene import default_scene

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.mark.parametrize("h", [0.0, 0.3, 1.0, 2.0, 4.0])
def test_vertical_stiffness_matches_lowload_closed_form(h):
    st = tip_stiffness(default_scene(h=h, phi=0.0, p=0.0))
    assert st.equilibrium.success and st.equilibrium.stable
    assert st.vertical == pytest.approx(lowload_stiffness(h), rel=1e-8)


def transverse_lowload(h):
    """φ = π/2, p → 0: θ'' + 2h²θ + p = 0, θ(0) = 0, θ'(1) = 0 (THEORY §5 linearised) gives
    θ = (p/k²)(cos ks + tan k sin ks − 1), k = √2 h, and v1 = ∫θ = (p/k²)(tan k/k − 1), so
    s⊥ = k²/(tan k/k − 1) (→ 3 as h → 0, → 0 at h_crit = π/(2√2) where the rod buckles)."""
    k = math.sqrt(2.0) * h
    return k * k / (math.tan(k) / k - 1.0)


@pytest.mark.parametrize("h", [0.4, 0.8, 1.05])
def test_vertical_stiffness_transverse_field_matches_linearisation(h):
    st = tip_stiffness(default_scene(h=h, phi=0.5 * math.pi, p=0.0))
    assert st.vertical == pytest.approx(transverse_lowload(h), rel=1e-8)


def loaded_scene():
    sc = default_scene(h=1.1, phi=0.7, p=1.3, alpha=0.2)
    return replace(sc, tip_force=(-0.4, 1.3), tip_moment=0.25)


def test_compliance_matches_finite_differences_of_independent_solves():
    """Second method: perturb each load, re-solve (tight Newton), central differences with one
    Richardson step (truncation O(d⁴), rounding ~ tol/d)."""
    opts = SolverOptions(tol=1e-11)  # the residual's rounding floor here is a few 1e-12
    sc = loaded_scene()
    st = tip_stiffness(sc, opts)
    base = st.equilibrium
    assert base.success and base.stable and not st.companion
    newton = replace(opts, method="newton", ensure_stable=False)

    def tip_at(name, delta):
        fx, fy = sc.tip_force
        m = sc.tip_moment
        if name == "fx":
            fx += delta
        elif name == "fy":
            fy += delta
        else:
            m += delta
        r = solve(replace(sc, tip_force=(fx, fy), tip_moment=m), newton, initial=base)
        assert r.success, r.message
        return np.array([r.tip["x"], r.tip["y"], r.tip["angle"]])

    fd = np.zeros((3, 3))
    d = 2e-3
    for j, name in enumerate(("fx", "fy", "m_tip")):
        D1 = (tip_at(name, d) - tip_at(name, -d)) / (2 * d)
        D2 = (tip_at(name, 2 * d) - tip_at(name, -2 * d)) / (4 * d)
        fd[:, j] = (4 * D1 - D2) / 3
    assert np.max(np.abs(fd - st.compliance)) < 1e-7 * np.max(np.abs(st.compliance))


def test_compliance_is_symmetric_maxwell_betti():
    st = tip_stiffness(loaded_scene())
    C = st.compliance
    assert abs(C[0, 1]) > 1e-3 and abs(C[1, 2]) > 1e-3  # genuinely coupled entries
    assert np.max(np.abs(C - C.T)) < 1e-11 * np.max(np.abs(C))
    assert st.symmetry_error < 1e-11
    assert np.allclose(st.stiffness @ C, np.eye(3), atol=1e-9)
    assert np.all(np.linalg.eigvalsh(0.5 * (C + C.T)) > 0)  # stable: positive definite


def test_vertical_stiffness_of_a_loaded_state_against_shooting_differences():
    """dp/dv1 at a bent state (h = 0.8, φ = 0, p = 2) from shooting solves at p ± δ."""
    st = tip_stiffness(default_scene(h=0.8, phi=0.0, p=2.0))
    d = 1e-4
    y = [solve_shooting(ShootingParams(h=0.8, fy=2.0 + s * d), 1.0).tip_y for s in (1, -1)]
    assert st.vertical == pytest.approx(2 * d / (y[0] - y[1]), rel=1e-7)


def test_companion_scene_is_reported_and_gives_the_same_stiffness():
    sc = replace(default_scene(h=1.0), tip_force=None)
    st = tip_stiffness(sc, moment=False)
    assert st.companion and any("companion" in n for n in st.notes)
    assert st.compliance.shape == (2, 2)
    assert st.vertical == pytest.approx(lowload_stiffness(1.0), rel=1e-8)


def test_stiffness_field_curve_overlays_lowload():
    h = np.linspace(0.0, 3.0, 7)
    curve = stiffness_field_curve(default_scene(h=0.0), None, h)
    assert curve.lowload_applies and np.all(curve.success)
    assert np.allclose(curve.vertical, lowload_stiffness(h), rtol=1e-8, atol=0)


def test_physical_stiffness_in_newtons_per_metre():
    """The paper's actuator (configs/paper_actuator_physical.yaml): B0 = E w t³/12, K = s · B0/ℓ³,
    with s⊥ the transverse linearisation at its tiny h (THEORY §6 notes h ≈ 1e-3)."""
    from actuator_design.config import load_scene

    scene, options, _ = load_scene(CONFIGS / "paper_actuator_physical.yaml")
    st = tip_stiffness(scene, options)
    B0 = 2.25e6 * 7e-3 * (3e-3) ** 3 / 12
    K = transverse_lowload(scene.h) * B0 / 27.5e-3 ** 3
    assert st.vertical_N_per_m == pytest.approx(K, rel=1e-8)
    assert st.vertical_N_per_m == pytest.approx(3 * B0 / 27.5e-3 ** 3, rel=1e-5)


def test_registered_analysis_returns_flat_row():
    from actuator_design.analysis.registry import get

    row = get("stiffness")(default_scene(h=2.0), SolverOptions())
    assert row["vertical_stiffness"] == pytest.approx(lowload_stiffness(2.0), rel=1e-8)
    assert row["success"] and row["stable"]


@pytest.mark.parametrize("extra, applies", [
    ({}, True),
    ({"distributed_load": (0.0, 0.0), "tip_moment": 0.0}, True),  # zero loads: no effect
    ({"terms": {"foundation": {"k_foundation": 5.0}}}, False),  # a plug-in term that stiffens the rod
    ({"h_r": 0.7, "magnetization": "0.3"}, False),  # remanent magnetisation
])
def test_the_closed_form_is_claimed_exact_exactly_when_the_computed_stiffness_is_it(extra, applies):
    """``StiffnessCurve.lowload_applies`` (THEORY §6's s(h) is exact for this scene): checked against
    the computed tangent stiffness of each scene at h = 1.5, which meets s(h) to 1e-6 exactly when
    the claim is made (a foundation or a remanent magnetisation moves it by far more)."""
    from actuator_design.model.profiles import constant_profile

    sc = default_scene(h=1.5)
    terms = extra.pop("terms", None)
    if terms:
        for name, values in terms.items():
            sc = sc.with_term(name, **values)
    if "magnetization" in extra:
        extra["magnetization"] = constant_profile(float(extra["magnetization"]))
    sc = replace(sc, **extra)
    curve = stiffness_field_curve(sc, h_values=[1.5])
    assert curve.success[0] and curve.lowload_applies is applies
    matches = bool(abs(curve.vertical[0] / float(lowload_stiffness(1.5)) - 1.0) < 1e-6)
    assert matches is applies, (curve.vertical[0], float(lowload_stiffness(1.5)))


def test_a_field_sweep_to_strong_fields_meets_the_closed_form():
    """h from 0 to 1000 on one mesh: graded for the strongest field, every point meets s(h) of
    THEORY §6 (before: the first point's ungraded mesh, +0.164 % at h = 1000 with success)."""
    h = np.linspace(0.0, 1000.0, 11)
    curve = stiffness_field_curve(default_scene(h=0.0), None, h)
    assert curve.success.all() and curve.stable.all()
    np.testing.assert_allclose(curve.vertical, lowload_stiffness(h), rtol=1e-9)
