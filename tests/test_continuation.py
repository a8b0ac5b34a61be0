"""Pseudo-arclength continuation (continuation.follow) against independent references.

References: the pitchforks h_crit^(m) = (2m−1)π/(2√2) and the elliptic first mode of THEORY §6
(``reference.closed_forms``), the elastica's fold loads computed here by the independent shooting
solver (a fold of the BVP in p is where r(γ, p) = 0 and ∂r/∂γ = 0, ∂r/∂γ from the variational
equation of ``reference.shooting``), and the symmetry α ↔ −φ of a uniform field with constant
fibres (only θ + α − φ enters the energy).
"""
import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from actuator_design.continuation.follow import (Continuation, continue_branch, get_param,
                                                   set_param)
from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.reference.shooting import ShootingParams, shoot
from actuator_design.model.scene import default_scene


def reference_fold(p_guess, gamma_guess, h=0.0):
    """Fold load of the cantilever (φ = 0) by shooting: solve r = 0, ∂r/∂γ = 0 for (γ, p)."""
    def F(x):
        s = shoot(x[0], ShootingParams(h=h, fy=x[1]), variational=True)
        return [s.residual, s.dresidual]
    sol, info, ier, msg = fsolve(F, [gamma_guess, p_guess], xtol=1e-13, full_output=True)
    assert ier == 1, msg
    return sol[1], sol[0]


@pytest.fixture(scope="module")
def transverse_branch():
    return continue_branch(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0, 4.0, switch=True)


def test_straight_branch_branch_points_at_critical_fields(transverse_branch):
    br = transverse_branch.branch
    assert br.status == "left_window" and br.lam[-1] == pytest.approx(4.0)
    vals = [cp.value for cp in br.branch_points]
    assert len(vals) == 2 and not br.folds
    for m, v in enumerate(vals, start=1):
        assert v == pytest.approx(critical_field_transverse(m), abs=1e-8)
    # the straight rod gains one unstable direction at each (Sturm: index = #modes below h)
    assert [(cp.morse_before, cp.morse_after) for cp in br.branch_points] == [(0, 1), (1, 2)]
    assert np.all(np.abs(br.tips[:, 0]) < 1e-12)


def test_switching_onto_mode_one_follows_the_elliptic_solution(transverse_branch):
    first = [b for b in transverse_branch.secondary if "1.1107" in b.origin]
    assert len(first) == 2  # the two mirror halves of the pitchfork
    for b in first:
        assert b.lam[-1] == pytest.approx(4.0) and np.all(b.morse_index == 0)
        beta = np.array([transverse_mode(h, 1).beta for h in b.lam])
        assert np.max(np.abs(np.abs(b.tip_angle) - beta)) < 1e-8
        assert np.all(np.sign(b.tip_angle) == np.sign(b.tip_angle[0]))
    assert np.sign(first[0].tip_angle[0]) != np.sign(first[1].tip_angle[0])
    second = [b for b in transverse_branch.secondary if "3.332" in b.origin]
    for b in second:  # mode 2: Morse index 1, tip angle |θ(1)| = β of mode 2
        assert np.all(b.morse_index == 1)
        beta2 = np.array([transverse_mode(h, 2).beta for h in b.lam])
        assert np.max(np.abs(np.abs(b.tip_angle) - beta2)) < 1e-7


def test_h2_parametrisation_branch_points():
    """In h² the pitchforks sit at h_crit²; the field enters as (√λ)² = λ exactly."""
    br = continue_branch(default_scene(h=0.0, phi=math.pi / 2), "h2", 0.0, 12.0).branch
    vals = [cp.value for cp in br.branch_points]
    assert vals == pytest.approx([critical_field_transverse(1) ** 2, critical_field_transverse(2) ** 2],
                                 abs=1e-8)


@pytest.fixture(scope="module")
def elastica_folds():
    """Folds of the field-free elastica in p found by continuing the p = 55 equilibria."""
    scene = default_scene(h=0.0, p=55.0)
    folds = []
    for e in find_equilibria(scene).equilibria:
        folds += continue_branch(scene, "p", 55.0, 0.0, initial=e.result, window=(0.0, 70.0)).branch.folds
    return folds


def test_elastica_fold_loads_against_shooting(elastica_folds):
    """p_crit^(1) and p_crit^(2) (THEORY §6: ≈ 10.3 and ≈ 51; the paper quotes 10.33 and 50.97).
    Our values, by both methods: 10.32516074, 51.00114643 — the paper's 50.97 is off by 0.03."""
    vals = sorted(f.value for f in elastica_folds)
    vals = [v for k, v in enumerate(vals) if k == 0 or v - vals[k - 1] > 1e-6]
    assert len(vals) == 2
    p1, g1 = reference_fold(10.3, -2.8)
    p2, g2 = reference_fold(51.0, -3.7)
    assert vals[0] == pytest.approx(p1, abs=1e-7)
    assert vals[1] == pytest.approx(p2, abs=1e-6)
    assert p1 == pytest.approx(10.3252, abs=1e-4) and p2 == pytest.approx(51.0011, abs=1e-4)
    for f in elastica_folds:  # a fold changes the Morse index by one
        assert abs(f.morse_before - f.morse_after) == 1 and f.located


def test_fold_equilibria_have_the_reference_tip_angle(elastica_folds):
    p1, g1 = reference_fold(10.3, -2.8)
    f = min(elastica_folds, key=lambda c: c.value)
    assert f.tip["angle"] == pytest.approx(shoot(g1, ShootingParams(fy=p1)).tip_angle, abs=1e-5)


def test_alpha_and_phi_continuations_agree_by_symmetry():
    """With constant fibres only θ + α − φ enters: continuing α from 0 to a traces the same tip
    angles as continuing φ from φ0 down to φ0 − a."""
    base = default_scene(h=1.5, phi=math.pi / 2, p=0.0)
    ba = continue_branch(base, "alpha", 0.0, 0.6, ds_max=0.05).branch
    bp = continue_branch(base, "phi", math.pi / 2, math.pi / 2 - 0.6, ds_max=0.05).branch
    ta = np.interp(0.3, ba.lam, ba.tip_angle)
    tp = np.interp(math.pi / 2 - 0.3, bp.lam[::-1], bp.tip_angle[::-1])
    assert ta == pytest.approx(tp, abs=1e-4)  # linear interpolation error of both branches
    c = Continuation(base, "alpha")
    x = c.start(0.3)
    cp = Continuation(base, "phi")
    y = cp.start(math.pi / 2 - 0.3, initial=np.append(base.theta0, x[:-1]))
    assert np.max(np.abs(x[:-1] - y[:-1])) < 1e-9


def test_parameter_mapping_round_trips_and_rejects_bad_names():
    sc = default_scene(h=1.0, phi=0.2, p=3.0, alpha=0.1)
    for name, v in [("h", 2.0), ("h2", 4.0), ("phi", 0.5), ("p", -1.0), ("fx", 0.7), ("m_tip", 0.2),
                    ("qx", 0.1), ("qy", -0.3), ("alpha", 0.4), ("theta0", 0.05)]:
        assert get_param(set_param(sc, name, v), name) == pytest.approx(v)
    assert set_param(sc, "h2", 4.0).h == pytest.approx(2.0)
    with pytest.raises(ValueError, match="unknown continuation parameter"):
        set_param(sc, "bogus", 1.0)
    with pytest.raises(ValueError, match="h2"):
        set_param(sc, "h2", -1.0)
