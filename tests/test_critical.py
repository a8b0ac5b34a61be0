"""Critical values directly (continuation.critical) against independent references.

References: the fold loads of the cantilever by the independent shooting solver (r = 0 and
∂r/∂γ = 0, ∂r/∂γ from its variational equation), at h² = 0 and along the critical curve
p_crit(h²) for φ = 0; the pitchforks h_crit^(m) and the counts 2m + 1 of THEORY §6.
"""
import math

import numpy as np
import pytest

from actuator_design.analysis import registry
from actuator_design.continuation.follow import Continuation
from actuator_design.continuation.critical import critical_points, fold_curve, locate_fold
from actuator_design.reference.closed_forms import critical_field_transverse
from actuator_design.model.scene import default_scene
from fold_problems import reference_fold


@pytest.fixture(scope="module")
def elastica_critical():
    return critical_points(default_scene(h=0.0, p=0.0), "p", (0.0, 60.0))


def test_all_folds_of_the_elastica_window(elastica_critical):
    """Exactly two folds in p ∈ [0, 60], at the shooting values, with 1 → 3 → 5 equilibria."""
    r = elastica_critical
    assert not r.branch_points
    assert len(r.folds) == 2
    p1, _ = reference_fold(10.3, -2.8)
    p2, _ = reference_fold(51.0, -3.7)
    assert r.folds[0]["value"] == pytest.approx(p1, abs=1e-7)
    assert r.folds[1]["value"] == pytest.approx(p2, abs=1e-6)
    assert (r.folds[0]["equilibria_below"], r.folds[0]["equilibria_above"]) == (1, 3)
    assert (r.folds[1]["equilibria_below"], r.folds[1]["equilibria_above"]) == (3, 5)
    for d in r.folds:
        assert {"value", "tip_angle", "equilibria_below", "equilibria_above"} <= set(d)


def test_moore_spence_newton_from_a_rough_guess(elastica_critical):
    """The augmented system (G = 0, H v = 0, cᵀMv = 1) converges from a point 0.3 away in p."""
    cp = elastica_critical.fold_points[0]
    cont = Continuation(default_scene(h=0.0, p=0.0), "p")
    z, lam, v, ok = locate_fold(cont, cp.z * 1.02, cp.value + 0.3)
    assert ok
    p1, _ = reference_fold(10.3, -2.8)
    assert lam == pytest.approx(p1, abs=1e-7)
    _, H, _ = cont.ev(z[1:], lam)
    assert np.max(np.abs(H @ v)) < 1e-8 * np.max(np.abs(H))


def test_fold_curve_against_shooting(elastica_critical):
    """p_crit^(1)(h²) continued in h² ∈ [0, 20] matches the shooting fold at h² = 10 and 20."""
    cp = elastica_critical.fold_points[0]
    fc = fold_curve(default_scene(h=0.0, p=0.0), "p", "h2", cp.z, cp.value, (0.0, 20.0))
    assert fc.mu[0] == pytest.approx(0.0) and fc.mu[-1] == pytest.approx(20.0)
    # the field lowers the critical load overall (paper, Fig. pmin_vs_chi) — though not
    # monotonically: p_crit^(1) first rises slightly, to ≈ 10.329 near h² ≈ 0.25 (checked below)
    assert fc.lam[-1] < fc.lam[0] - 4
    k = int(np.argmax(fc.lam))
    assert 0 < fc.mu[k] < 1 and fc.lam[k] > fc.lam[0] + 1e-3
    p_ref, _ = reference_fold(fc.lam[k], fc.gamma[k], h=math.sqrt(fc.mu[k]))
    assert fc.lam[k] == pytest.approx(p_ref, abs=1e-7)
    for k in (len(fc.mu) // 2, len(fc.mu) - 1):  # the shooting fold nearest to this one
        p_ref, g_ref = reference_fold(fc.lam[k], fc.gamma[k], h=math.sqrt(fc.mu[k]))
        assert fc.lam[k] == pytest.approx(p_ref, abs=1e-7)
        assert fc.gamma[k] == pytest.approx(g_ref, abs=1e-3)


def test_transverse_window_over_all_branches():
    """φ = π/2, h ∈ [0, 4]: the two pitchforks (closed form) with 1 → 3 → 5 equilibria; the
    mirror branches through them are not reported as extra points."""
    r = critical_points(default_scene(h=0.0, phi=math.pi / 2), "h", (0.0, 4.0), n_samples=3)
    assert not r.folds
    assert len(r.branch_points) == 2
    for m, d in enumerate(r.branch_points, start=1):
        assert d["value"] == pytest.approx(critical_field_transverse(m), abs=1e-8)
        assert abs(d["tip_angle"]) < 1e-10
        assert (d["equilibria_below"], d["equilibria_above"]) == (2 * m - 1, 2 * m + 1)
    assert registry.get("critical")  # registered


def test_a_branch_stopped_inside_the_window_leaves_the_list_incomplete():
    """With too few points per branch the fold at p ≈ 51 lies beyond where the branches stop: the
    list of critical points is then not complete and says why (before: complete with one fold)."""
    r = critical_points(default_scene(h=0.0, p=0.0), "p", (0.0, 60.0), max_points=15, n_samples=2)
    assert not r.complete
    assert any("stopped inside the window" in why for why in r.incomplete_reasons), r.incomplete_reasons


def test_critical_points_in_a_window_whose_strong_end_grades_the_mesh():
    """p ∈ [0, 200]: the clamp layer √200 ≈ 14 grades the mesh of the solves at the strong samples;
    the branches are followed on the window's mesh, the sample states interpolated onto it (before:
    'operands could not be broadcast together with shapes (40,) (60,)'). Three folds, at the
    shooting values."""
    r = critical_points(default_scene(h=0.0, p=0.0), "p", (0.0, 200.0), n_samples=3)
    assert r.complete, r.incomplete_reasons
    refs = [reference_fold(10.3, -2.8)[0], reference_fold(51.0, -3.7)[0], reference_fold(119.6, -4.2)[0]]
    assert [d["value"] for d in r.folds] == pytest.approx(refs, abs=1e-6)


def test_fold_curves_from_a_window_whose_strong_end_grades_the_mesh():
    """critical_curves continues each fold of p ∈ [0, 200] in h² on the mesh its fold was found on
    (before: 'could not broadcast (60,) into (40,)'); at h² = 0 they start at the shooting folds."""
    from actuator_design.continuation.critical import critical_curves

    curves = critical_curves(default_scene(h=0.0, p=0.0), "p", "h2", (0.0, 200.0), (0.0, 2.0), n_starts=1)
    refs = [reference_fold(10.3, -2.8)[0], reference_fold(51.0, -3.7)[0], reference_fold(119.6, -4.2)[0]]
    assert len(curves) == 3
    for c, ref in zip(curves, refs):
        k = int(np.argmin(np.abs(c.mu)))
        assert c.mu[k] == 0.0 and c.lam[k] == pytest.approx(ref, abs=1e-5)


def test_folds_located_and_continued_on_a_strongly_graded_mesh():
    """Seven grading levels at the clamp: the stationarity of the Moore–Spence Newton stalls at the
    rounding floor of the small end elements (1–3e-10 > tol); it is accepted after a Newton step
    below 1e-9 rad (before: 'no fold of p near p = 10.3252'). The fold load is the shooting one."""
    from dataclasses import replace

    from actuator_design.equilibrium.options import SolverOptions

    opts = replace(SolverOptions(), clamp_levels=7)
    scene = default_scene(h=0.0, p=0.0)
    cr = critical_points(scene, "p", (0.0, 20.0), options=opts, n_samples=2)
    cp = cr.fold_points[0]
    curve = fold_curve(scene, "p", "h2", cp.z, cp.value, (0.0, 2.0), options=opts, lam_window=(0.0, 20.0))
    p1 = reference_fold(10.3, -2.8)[0]
    assert curve.status == "left_window" and curve.lam[0] == pytest.approx(p1, abs=1e-9)
    assert curve.mu[-1] == pytest.approx(2.0)


def test_an_imperfect_pitchfork_with_a_point_only_bracketed_is_not_complete():
    """φ = 90° with fibres at 0.57°: the imperfect pitchfork's folds are located (and accurate), but
    a step jumping between its disconnected branches leaves a 'branch point' only bracketed, perhaps
    none at all: the list says so and is not complete (it was, with exit 0)."""
    r = critical_points(default_scene(h=0.0, phi=math.pi / 2, alpha=0.01), "h", (0.0, 4.0), n_samples=3)
    d = r.to_dict()
    assert d["accurate"] and all(f["value_error"] is not None and f["value_error"] < 1e-8 for f in d["folds"])
    loose = [bp for bp in r.branch_point_objects if not bp.located]
    assert (not r.complete and not d["success"]) if loose else r.complete
    assert bool(loose) == any("only bracketed" in why for why in r.incomplete_reasons)
