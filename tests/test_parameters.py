"""The parameter lens and the kinematics the terms read."""
import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from actuator_design import parameters as lens
from actuator_design.options import SolverOptions
from actuator_design.physics.kinematics import PlanarKinematics
from actuator_design.physics.terms import build_terms
from actuator_design.scene import DipoleField, Scene, default_scene
from actuator_design.solver import get_solver


def test_every_parameter_round_trips_and_adds_its_term():
    bare = Scene(field=None, tip_force=None)
    for name, p in lens.parameters().items():
        if name == "phi" or p.per_point:
            sc = lens.set_value(default_scene(), name, 0.3)
        elif name == "h_pos":
            sc = lens.set_value(replace(default_scene(h=1.0), field=DipoleField()), name, 0.3)
        else:
            sc = lens.set_value(bare, name, 0.3)
        assert lens.get_value(sc, name) == pytest.approx(0.3)
        if p.term is not None:  # the term the parameter needs is now built
            assert p.term in [t.name for t in build_terms(sc)]


def test_unknown_names_list_the_allowed_ones_and_ranges_are_named():
    with pytest.raises(ValueError, match=r"unknown parameter 'bogus' \(allowed: h, h2, phi"):
        lens.parameter("bogus")
    with pytest.raises(ValueError, match=r"^h_pos: must be >= 0, got -1$"):
        lens.set_value(default_scene(), "h_pos", -1)
    with pytest.raises(ValueError, match=r"^qx: must be finite"):
        lens.set_value(default_scene(), "qx", math.nan)


def test_slot_transform_h2_is_the_square_of_h():
    p = lens.parameter("h2")
    assert p.slot == "h" and p.to_slot(2.25) == pytest.approx(1.5)
    lam = ca.SX.sym("lam")
    assert float(ca.Function("f", [lam], [p.slot_expr(lam) ** 2])(3.7)) == pytest.approx(3.7, abs=1e-15)


def test_field_ramp_keeps_h_pos_over_h_because_both_scale_with_H():
    """THEORY §5: h ∝ H and h_pos ∝ H, so h_pos/h (a material ratio) is invariant on a field ramp,
    whichever name (h or h2 ∝ H²) sets the magnitude."""
    sc = replace(default_scene(h=0.8), field=DipoleField(), h_pos=0.2)
    for name, v, h_new in (("h", 0.4, 0.4), ("h2", 0.16, 0.4), ("h", 1.6, 1.6)):
        out = lens.apply_values(sc, {name: v})
        assert out.h == pytest.approx(h_new) and out.h_pos / out.h == pytest.approx(0.25)
    with pytest.raises(ValueError, match="give either h or h2, not both"):
        lens.apply_values(sc, {"h": 1.0, "h2": 1.0})


def test_residual_scale_is_derived_from_the_terms():
    sc = default_scene(h=3.0, p=-20.0)
    sv = get_solver(sc, SolverOptions(elements=1, degree=6))
    assert sv.residual_scale(sv.parameter_vector(sc)) == pytest.approx(20.0)  # |p| > h² = 9
    sc2 = default_scene(h=5.0, p=-20.0)
    assert sv.residual_scale(sv.parameter_vector(sc2)) == pytest.approx(25.0)


def test_positions_are_built_only_when_a_term_reads_them():
    opts = SolverOptions(elements=1, degree=6)
    uniform = get_solver(default_scene(h=1.0, p=1.0), opts)
    loaded = get_solver(replace(default_scene(h=1.0), distributed_load=(0.0, -1.0)), opts)
    assert not uniform.discrete.uses_positions and loaded.discrete.uses_positions


def test_directors_are_orthonormal_and_rotate_by_a_quarter_turn():
    th = ca.SX.sym("th")
    kin = PlanarKinematics(th, ca.SX.sym("k"), {})
    (t1, t2), (n1, n2) = kin.tangent, kin.normal
    f = ca.Function("f", [th], [t1 * n1 + t2 * n2, t1**2 + t2**2, t1 * n2 - t2 * n1])
    for v in np.linspace(-3, 3, 7):
        dot, norm, cross = (float(x) for x in f(v))
        assert abs(dot) < 1e-15 and norm == pytest.approx(1.0) and cross == pytest.approx(1.0)
    with pytest.raises(RuntimeError, match="no positions"):
        kin.position
