"""Every energy term on a tiny hand-built state (PyElastica's per-term tests): three points with
given θ, θ', positions and material fields, and the free end; each term's density (or tip energy)
against its formula written out here (THEORY §4–5, §9; the shipped extra terms' docstrings).

A term the package registers without a case here fails the coverage test: adding a term means
adding its formula below.
"""
import casadi as ca
import numpy as np
import pytest

from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.model.profiles import constant_profile
from actuator_design.physics.registry import registered_terms, term_class
from actuator_design.model.scene import ExpressionField, Scene, UniformField

TH = np.array([0.1, -0.4, 1.2])  # θ, rad
KAPPA = np.array([0.5, -1.0, 2.0])  # θ', 1/ℓ
X, Y = np.array([0.2, 0.5, 0.7]), np.array([0.05, -0.1, 0.3])  # positions, ℓ
S = np.array([0.2, 0.55, 0.9])  # arc lengths
FIELDS = {"b": np.array([1.0, 0.8, 1.5]), "alpha": np.array([0.3, -0.2, 0.0]),
          "beta": np.array([0.0, 0.5, -1.0]), "arclength": S}
P = {"h": 1.3, "phi": 0.7, "h_pos": 0.6, "h_r": 2.5, "fx": -0.4, "fy": 1.1, "m_tip": 0.9, "qx": 0.3,
     "qy": -2.0, "theta0": 0.0, "k_foundation": 7.0, "q_root_x": 0.5, "q_root_y": -1.5, "q_tip_x": -0.2,
     "q_tip_y": 3.0}
TIP = (0.8, 0.9, 0.2)  # θ(1), x(1), y(1)
QUAD = ExpressionField("x", "-y")  # ĥ = (x, −y): divergence- and curl-free
AXIAL = constant_profile(0.0)  # β = 0 (its per-point values are FIELDS["beta"] here)

U_FIB = TH + FIELDS["alpha"]
U_MAG = TH + FIELDS["beta"]
CASES = {  # name: (scene that contains the term, expected density or None, expected tip energy or None)
    "bending": (Scene(field=None, tip_force=None), 0.5 * FIELDS["b"] * KAPPA ** 2, None),
    "field_orientation": (Scene(field=UniformField(phi=0.7), h=1.3, tip_force=None),
                          -1.3 ** 2 * np.cos(U_FIB - 0.7) ** 2, None),
    "field_orientation@quadrupole": (Scene(field=QUAD, h=1.3, tip_force=None),
                                     -1.3 ** 2 * (np.cos(U_FIB) * X - np.sin(U_FIB) * Y) ** 2, None),
    "field_position": (Scene(field=QUAD, h=1.3, h_pos=0.6, tip_force=None), -0.6 ** 2 * (X ** 2 + Y ** 2), None),
    "tip_force": (Scene(field=None, tip_force=(-0.4, 1.1)), None, -(-0.4 * 0.9 + 1.1 * 0.2)),
    "tip_moment": (Scene(field=None, tip_force=None, tip_moment=0.9), None, -0.9 * 0.8),
    "distributed_load": (Scene(field=None, tip_force=None, distributed_load=(0.3, -2.0)), -(0.3 * X - 2.0 * Y), None),
    "hard_magnetic": (Scene(field=UniformField(phi=0.7), h=0.0, h_r=2.5, tip_force=None, magnetization=AXIAL),
                      -2.5 * np.cos(U_MAG - 0.7), None),
    "hard_magnetic@quadrupole": (Scene(field=QUAD, h=0.0, h_r=2.5, tip_force=None, magnetization=AXIAL),
                                 -2.5 * (np.cos(U_MAG) * X - np.sin(U_MAG) * Y), None),
    "foundation": (Scene(field=None, tip_force=None).with_term("foundation", k_foundation=7.0), 0.5 * 7.0 * Y ** 2,
                   None),
    "tapered_load": (Scene(field=None, tip_force=None).with_term(
        "tapered_load", q_root_x=0.5, q_root_y=-1.5, q_tip_x=-0.2, q_tip_y=3.0),
        -(((1 - S) * 0.5 + S * -0.2) * X + ((1 - S) * -1.5 + S * 3.0) * Y), None),
}


def _value(expr):
    return None if expr is None else np.asarray(ca.evalf(ca.SX(expr)), float).ravel()


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_terms_energy_on_a_hand_built_state(case):
    scene, density, tip_energy = CASES[case]
    name = case.split("@")[0]
    cls = term_class(name)
    assert cls.present(scene)
    term = cls.from_scene(scene)
    kin = PlanarKinematics(ca.SX(ca.DM(TH)), ca.SX(ca.DM(KAPPA)), {k: ca.SX(ca.DM(v)) for k, v in FIELDS.items()},
                           positions=(ca.SX(ca.DM(X)), ca.SX(ca.DM(Y))))
    tip = PlanarTip(ca.SX(TIP[0]), ca.SX(TIP[1]), ca.SX(TIP[2]))
    params = {k: ca.SX(v) for k, v in P.items()}
    got_density, got_tip = _value(term.density(kin, params)), _value(term.tip(tip, params))
    if density is None:
        assert got_density is None
    else:
        assert got_density == pytest.approx(np.broadcast_to(density, (3,)), rel=1e-14, abs=1e-15)
    if tip_energy is None:
        assert got_tip is None
    else:
        assert float(got_tip[0]) == pytest.approx(tip_energy, rel=1e-14)
    # the values the NLP receives for the term's slots are the scene's
    for slot, v in term.values(scene).items():
        if slot in P:
            assert v == pytest.approx(P[slot]), slot


def test_every_term_the_package_registers_has_a_case():
    package = [c.name for c in registered_terms() if c.__module__.startswith("actuator_design.")]
    missing = sorted(set(package) - {c.split("@")[0] for c in CASES})
    assert not missing, f"terms without a hand-built test: {missing}"


def _numbers(value):
    if isinstance(value, dict):
        return [x for v in value.values() for x in _numbers(v)]
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _numbers(v)]
    return [value] if isinstance(value, (int, float)) and not isinstance(value, bool) else []


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_results_groups_report_every_value_the_terms_energy_uses(case):
    """``describe_groups`` asks every term what to report: each NLP value a present term reads
    (its ``values``) is among the numbers reported, so a result says what was solved."""
    from actuator_design.physics.registry import describe_groups
    scene = CASES[case][0]
    reported = _numbers(describe_groups(scene))
    term = term_class(case.split("@")[0]).from_scene(scene)
    for slot, value in term.values(scene).items():
        assert any(v == pytest.approx(value, abs=0) for v in reported), (slot, value, describe_groups(scene))
    assert describe_groups(scene)["theta0"] == scene.theta0
