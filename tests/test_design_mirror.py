"""Symmetry of the search (issue 17 item 3): the planar rod is invariant under the reflection
y → −y (θ, φ, α, β, θ0, p, q_y, m → their negatives), so a target and its mirror get mirror designs,
and a target whose mirror is designed is designed.

References: the reflection itself is checked against the forward solver (a mirrored scene's
equilibrium is the mirror image of the scene's, a symmetry of the model); designs are compared
mirror to mirror and re-checked by independent forward solves."""
import math
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.inverse.design import design
from actuator_design.inverse.mirror import mirror_scene
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import expression_profile
from actuator_design.model.scene import Scene, UniformField, default_scene


def test_the_reflection_of_a_scene_is_the_reflection_of_its_equilibrium():
    sc = Scene(field=UniformField(phi=1.1), h=1.7, fibres=expression_profile("0.3 + 0.4*s"),
               tip_force=(0.2, -0.7), tip_moment=0.3, distributed_load=(0.1, 0.4), theta0=0.2)
    m = mirror_scene(sc)
    back = mirror_scene(m)  # an involution: the same scene (the expression is -(-(...)))
    s_ = np.linspace(0, 1, 11)
    np.testing.assert_array_equal(back.fibres(s_), sc.fibres(s_))
    assert replace(back, fibres=sc.fibres) == sc
    a, b = solve(sc, SolverOptions()), solve(m, SolverOptions())
    assert a.success and b.success
    np.testing.assert_allclose(b.theta, -a.theta, atol=1e-9)
    assert (b.tip["x"], b.tip["y"]) == pytest.approx((a.tip["x"], -a.tip["y"]), abs=1e-10)


def test_a_non_uniform_field_has_no_mirror_here():
    from actuator_design.model.scene import DipoleField
    assert mirror_scene(Scene(field=DipoleField(), h=1.0)) is None


@pytest.mark.parametrize("target", [(0.651138, 0.546369), (0.821037, 0.219996)])
def test_mirror_targets_get_mirror_designs(target):
    """Issue 17: (0.5, 0.5) was designed and (0.5, −0.5) was not (exit 3). These two pairs of the
    design benchmark's grid give the same design on both OpenBLAS kernels tried (Haswell and the
    default); (0.5, 0.5) itself does not yet (the choice among its optima hangs on round-off), so
    it is not what this test of the symmetry rests on."""
    up, down = design(target), design((target[0], -target[1]))
    assert up.success, up.message
    assert down.success, down.message
    assert "found by symmetry" in down.message and "found by symmetry" not in up.message
    assert down.design["h"] == pytest.approx(up.design["h"], rel=1e-8)
    assert down.design["phi"] == pytest.approx(-up.design["phi"], abs=1e-8)
    np.testing.assert_allclose(down.design["alpha"]["legendre_coefficients"],
                               -np.asarray(up.design["alpha"]["legendre_coefficients"]), atol=1e-8)
    # the user's own problem was verified: its reported state is an equilibrium at its target
    assert (down.achieved["x"], down.achieved["y"]) == pytest.approx((target[0], -target[1]), abs=1e-9)
    # the report is made again on each problem by branch following, which is not exactly
    # equivariant (its steps and corner search; measured: 0.4 % on the second pair)
    assert down.robustness.holds == up.robustness.holds
    assert down.robustness.robustness.worst_tip_error == pytest.approx(up.robustness.robustness.worst_tip_error,
                                                                       rel=1e-2)
    assert down.schedule[-1]["h"] == pytest.approx(up.schedule[-1]["h"], rel=1e-8)
    assert all(math.isfinite(q["phi"]) for q in down.schedule)


def test_every_declared_mirror_factor_leaves_the_energy_invariant():
    """Symmetry check of the parameters' ``mirror`` factors (THEORY §4–5, §9): for any shape θ(s),
    the energy of the scene at θ equals the energy of its mirror scene at −θ, every term a mirror is
    built for present (uniform field, fibre and magnetisation profiles, tip force and moment,
    distributed load, clamp angle; the χ̂ term is a constant in a uniform field). Flipping any one
    declared factor makes this fail (checked by hand for fx and h_r)."""
    from actuator_design.equilibrium.options import SolverOptions
    from actuator_design.equilibrium.solver import get_solver
    from actuator_design.model.profiles import constant_profile
    from actuator_design.model.scene import UniformField

    sc = Scene(field=UniformField(phi=0.7), h=1.3, h_pos=0.4, fibres=expression_profile("0.3 + 0.2*s"),
               magnetization=expression_profile("0.5*s*s"), h_r=0.8, tip_force=(0.3, -1.1), tip_moment=0.6,
               distributed_load=(0.2, 0.4), theta0=0.25, stiffness=constant_profile(1.0))
    m = mirror_scene(sc)
    solver = get_solver(sc, SolverOptions())
    assert get_solver(m, SolverOptions()) is solver  # the same structure
    rng = np.random.default_rng(7)
    for _ in range(3):
        z = np.concatenate([[sc.theta0], rng.normal(scale=0.8, size=solver.transcription.nodes.size - 1)])
        e = float(solver.f_energy(z, solver.parameter_vector(sc)))
        e_m = float(solver.f_energy(-z, solver.parameter_vector(m)))
        assert e_m == pytest.approx(e, rel=1e-13, abs=1e-13)
