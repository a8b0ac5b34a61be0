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


def test_two_terms_with_a_two_fold_torque_are_both_integrated():
    """A plug-in second easy axis k sin 2(θ − δ) beside the field's h² sin 2(θ − φ): the scan's
    residual r(γ) = θ'(1) is the one of θ'' = h² sin 2(θ − φ) + k sin 2(θ − δ), integrated here by a
    separate RK4 (a summed amplitude with one angle would be wrong)."""
    from actuator_design.analysis.shooting_scan import ShootingProblem
    from actuator_design.physics.parameter import plugin_parameter
    from actuator_design.physics.registration import register_term, unregister_term
    from actuator_design.physics.term_protocol import EnergyTerm, ShootingPart

    delta, k = 0.6, 1.0

    class SecondAxis(EnergyTerm):
        name = "toy_second_axis"
        scalar_params = ("k_toy_axis",)
        parameters = (plugin_parameter("toy_second_axis", "k_toy_axis", "second axis", "B0/l", lower=0.0),)

        def density(self, kin, P):
            return -P["k_toy_axis"] * ca.cos(kin.theta - delta) ** 2

        @classmethod
        def shooting_part(cls, scene):
            kk = scene.term_values(cls.name)["k_toy_axis"]
            return ShootingPart(twofold=kk, twofold_angle=lambda s: np.full_like(np.asarray(s, float), -2 * delta),
                                torque=kk, jacobi=2 * kk, potential_max=kk, spread=kk)

    register_term(SecondAxis, replace=True)
    try:
        scene = Scene(field=UniformField(phi=0.2), h=1.0, tip_force=None).with_term(SecondAxis.name, k_toy_axis=k)
        gammas = np.array([-0.5, 0.3, 0.8])
        got = ShootingProblem(scene, 400).residual(gammas)
    finally:
        unregister_term(SecondAxis.name)

    def reference(gamma, n=4000):
        f = lambda y: np.array([y[1], np.sin(2 * (y[0] - 0.2)) + k * np.sin(2 * (y[0] - delta))])  # noqa: E731
        y, ds = np.array([0.0, gamma]), 1.0 / n
        for _ in range(n):
            k1 = f(y)
            k2 = f(y + ds / 2 * k1)
            k3 = f(y + ds / 2 * k2)
            k4 = f(y + ds * k3)
            y = y + ds / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return y[1]

    assert got == pytest.approx([reference(g) for g in gammas], rel=1e-9, abs=1e-10)
