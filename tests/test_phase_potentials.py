"""Each term's part of the phase portrait's first integral (``EnergyTerm.phase_potential``) on a
hand-built state: H = ½ b θ'² + Σ V(θ) is conserved exactly when every V is minus the term's energy
per unit length as a function of θ alone (bθ'' = −V'(θ) and bθ'' = W'(θ) from the energy), so
V + W must be constant in θ. W is the term's own CasADi density; a tip force's work −f·r(1) is
written along the rod by evaluating its tip energy at r = (cos θ, sin θ) (r' = the tangent).
"""
import casadi as ca
import numpy as np
import pytest

from actuator_design.model.profiles import constant_profile, expression_profile
from actuator_design.model.scene import DipoleField, Scene, UniformField
from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.physics.registry import registered_terms, term_class
from actuator_design.physics.term_protocol import EnergyTerm

THETA = np.linspace(-7.0, 7.0, 57)
SCENE = Scene(field=UniformField(phi=0.7), h=1.3, fibres=constant_profile(0.4), tip_force=(-0.4, 1.1),
              tip_moment=0.9, distributed_load=(0.0, 0.0), h_r=2.5, magnetization=constant_profile(-0.6))


def _energy_per_length(cls, scene):
    """W(θ) of the term on the grid THETA (κ = 0, the scene's constant profiles)."""
    term = cls.from_scene(scene)
    th = ca.SX(ca.DM(THETA))
    fields = {"b": 1.0, "alpha": float(scene.fibres.value), "beta": float(scene.magnetization.value),
              "arclength": 0.5}
    kin = PlanarKinematics(th, ca.SX.zeros(THETA.size), {k: ca.SX(v) for k, v in fields.items()},
                           positions=(ca.SX.zeros(THETA.size), ca.SX.zeros(THETA.size)))
    P = {k: ca.SX(v) for k, v in term.values(scene).items()}
    W = term.density(kin, P)
    if W is None and term.tip(PlanarTip(th, ca.cos(th), ca.sin(th)), P) is not None and cls.end_moment(scene) == 0:
        W = term.tip(PlanarTip(th, ca.cos(th), ca.sin(th)), P)  # a dead tip force: −f·(cos θ, sin θ) per length
    return np.zeros_like(THETA) if W is None else np.asarray(ca.evalf(ca.SX(W)), float).ravel()


DECLARING = [c for c in registered_terms() if c.phase_potential.__func__ is not EnergyTerm.phase_potential.__func__]


@pytest.mark.parametrize("cls", DECLARING, ids=lambda c: c.name)
def test_each_terms_potential_is_minus_its_energy_per_length_up_to_a_constant(cls):
    assert cls.present(SCENE)
    V = cls.phase_potential(SCENE)(THETA)
    W = _energy_per_length(cls, SCENE)
    if cls.end_moment(SCENE):  # a tip moment sets the end line, not H
        assert np.all(V == 0.0)
        return
    total = V + W
    assert np.ptp(total) <= 1e-13 * max(1.0, np.max(np.abs(W))), cls.name


def test_the_built_in_terms_declare_a_potential_and_the_plug_ins_do_not():
    names = {c.name for c in DECLARING}
    assert names == {"bending", "field_orientation", "tip_force", "tip_moment", "distributed_load", "hard_magnetic"}


@pytest.mark.parametrize("name, scene, key", [
    ("bending", Scene(stiffness=expression_profile("1 + s")), "stiffness"),
    ("field_orientation", Scene(field=UniformField(), h=1.0, fibres=expression_profile("0.2*s")), "fibres"),
    ("field_orientation", Scene(field=DipoleField(), h=1.0), "field"),
    ("distributed_load", Scene(distributed_load=(0.0, -1.0)), "distributed_load"),
    ("hard_magnetic", Scene(field=UniformField(), h_r=1.0, magnetization=expression_profile("s")), "magnetization"),
])
def test_a_term_names_what_makes_the_equation_depend_on_s(name, scene, key):
    with pytest.raises(ValueError, match=f"^{key}: phase portraits need"):
        term_class(name).phase_potential(scene)
