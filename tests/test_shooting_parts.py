"""Each term's part of the shooting scan's moment equation (``EnergyTerm.shooting_part``) against its
own energy, on a hand-built state (THEORY §5, §7, §9).

The scan integrates M' = h² sin 2(θ + α − φ) − n_y cos θ + n_x sin θ. A term local in θ (the
field, a remanent torque) must give M' = ∂W/∂θ, W its CasADi energy per unit length; a dead load
must give the internal force it transmits, n(s) = −∫ₛ¹ ∂W/∂r ds' − ∂T/∂r(1) (T its tip energy).
"""
import casadi as ca
import numpy as np
import pytest

from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.physics.registry import declaring, term_class

THETA = np.array([-2.0, -0.3, 0.4, 1.7, 3.0])
S = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
SCENE = Scene(field=UniformField(phi=0.7), h=1.3, fibres=constant_profile(0.4), tip_force=(-0.4, 1.1),
              tip_moment=0.9, distributed_load=(0.3, -2.0), h_r=2.5, magnetization=constant_profile(-0.6))


def _term(name):
    cls = term_class(name)
    assert cls.present(SCENE)
    term = cls.from_scene(SCENE)
    return cls, term, {k: ca.SX(v) for k, v in term.values(SCENE).items()}


def _kin(th, x, y):
    fields = {"b": 1.0, "alpha": float(SCENE.fibres.value), "beta": float(SCENE.magnetization.value),
              "arclength": 0.5}
    return PlanarKinematics(th, ca.SX.zeros(th.shape[0]), {k: ca.SX(v) for k, v in fields.items()},
                            positions=(x, y))


def _torque_of_part(part, theta, s):
    out = part.twofold * np.sin(2 * theta + part.twofold_angle(s)) if part.twofold_angle is not None else 0.0
    if part.force is not None and not part.dead:
        nx, ny = part.force(s)
        out = out - ny * np.cos(theta) + nx * np.sin(theta)
    return out + np.zeros_like(theta)


@pytest.mark.parametrize("name", ["field_orientation", "hard_magnetic"])
def test_a_local_terms_moment_is_the_derivative_of_its_energy(name):
    cls, term, P = _term(name)
    th = ca.SX.sym("th", THETA.size)
    W = term.density(_kin(th, ca.SX.zeros(THETA.size), ca.SX.zeros(THETA.size)), P)
    dW = ca.Function("dW", [th], [ca.jacobian(ca.sum1(W), th)])(THETA)
    part = cls.shooting_part(SCENE)
    assert _torque_of_part(part, THETA, S) == pytest.approx(np.asarray(dW, float).ravel(), rel=1e-13, abs=1e-13)


@pytest.mark.parametrize("name", ["tip_force", "distributed_load"])
def test_a_dead_loads_force_is_the_force_it_transmits(name):
    cls, term, P = _term(name)
    part = cls.shooting_part(SCENE)
    assert part.dead and part.force is not None
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    W = term.density(_kin(ca.SX(0.1), x, y), P)
    T = term.tip(PlanarTip(ca.SX(0.1), x, y), P)
    grad = lambda e: np.zeros(2) if e is None else np.asarray(ca.evalf(ca.substitute(  # noqa: E731
        ca.gradient(e, ca.vertcat(x, y)), ca.vertcat(x, y), ca.DM([0.2, 0.3]))), float).ravel()
    per_length, at_tip = grad(W), grad(T)  # both constant in the position for these terms
    for s in S:
        n = -(1.0 - s) * per_length - at_tip
        got = np.array(part.force(np.array(s)), float).ravel()
        assert got == pytest.approx(n, rel=1e-14, abs=1e-15)


def test_every_declaring_term_is_checked_here_or_carries_no_equation():
    checked = {"field_orientation", "hard_magnetic", "tip_force", "distributed_load"}
    no_equation = {"bending", "tip_moment"}  # b(s) and the end moment are the scan's own
    assert set(declaring("shooting_part")) == checked | no_equation
    for name in no_equation:
        part = term_class(name).shooting_part(SCENE)
        assert part.force is None and part.twofold == 0.0 and part.torque == 0.0
