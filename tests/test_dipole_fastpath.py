"""The fast path for energies that read positions (point dipole, distributed loads).

The reduced Hessian of a positional energy is assembled from its structure, Φᵀ K Φ
(:mod:`actuator_design.reduced.positional`), with the field entering through its jet (closed forms
for the point dipole). References: the bench's independent dipole reference (general shooting with
the internal force as state, DOP853 — :func:`actuator_design.benchmarks.problems._dipole_reference`),
the symbolic Hessian of the whole transcribed energy (automatic differentiation: a second method),
automatic differentiation of the dipole field against its closed-form jet, and quadratic
convergence of Newton's method (only the exact Hessian gives it). No timings here.
"""
import math
import shutil

import casadi as ca
import numpy as np
import pytest

from actuator_design.benchmarks.problems import PROBLEMS, _dipole_reference
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.physics.fields import DipoleFieldModel, FieldModel
from actuator_design.physics.registry import build_terms
from actuator_design.physics.terms import EnergyTerm
from actuator_design.model.profiles import constant_profile, expression_profile
from actuator_design.reduced.positional import positional_hessian
from actuator_design.model.scene import DipoleField, Scene, UniformField
from actuator_design.equilibrium.solver import get_solver
from actuator_design.transcription import make_transcription
from jit_check import jit_matches_vm

FAST = SolverOptions(elements=1, degree=12, method="fast")
DIPOLE = DipoleField(x0=0.5, y0=0.8, moment_angle=0.5 * math.pi)


def _tip(x, y, angle):
    return np.array([x, y, angle])


def test_fast_dipole_path_matches_the_independent_shooting_reference():
    """Cold and warm fast solves of the bench's dipole problem, each against its own reference
    (the tip to 1e-8, the accuracy the bench's target asks for at degree 12)."""
    prob = PROBLEMS["dipole"]
    sv = get_solver(prob.scene, FAST)
    assert sv.kernel.structured
    r = solve(prob.scene, FAST, initial=prob.guess(sv.transcription.nodes))
    assert r.success and r.message.startswith("fast Newton") and r.stable
    ref = _dipole_reference(prob.scene).tip
    assert np.max(np.abs(_tip(r.tip["x"], r.tip["y"], r.tip["angle"]) - ref)) <= 1e-8
    z = r.z
    for eps in (3e-3, -4e-3):  # warm re-solves as in the bench
        scene = prob.perturb(prob.scene, eps)
        raw = sv.solve_fast(z, sv.parameter_vector(scene))
        assert raw.converged, raw.message
        z = raw.z
        _, th1, x1, y1 = sv.summary(z, sv.parameter_vector(scene))
        ref = _dipole_reference(scene).tip
        assert np.max(np.abs(_tip(x1, y1, th1) - ref)) <= 1e-8


SCENES = {
    "dipole with loads": Scene(field=DIPOLE, h=0.3, h_pos=0.1, tip_force=(0.2, -0.4), tip_moment=0.3,
                               distributed_load=(0.1, -0.5)),
    "hard-magnetic dipole": Scene(field=DIPOLE, h=0.1, h_r=0.4, magnetization=constant_profile(0.3),
                                  tip_force=None),
    "graded dipole": Scene(field=DIPOLE, h=0.2, h_pos=0.05, fibres=expression_profile("0.3*s"),
                           stiffness=expression_profile("1 - 0.3*s"), tip_force=None),
    "uniform field, weight": Scene(field=UniformField(phi=0.6), h=1.0, distributed_load=(0.0, -1.0),
                                   tip_force=(0.0, 0.3)),
}
RESOLUTIONS = {"lgl 1x8": SolverOptions(elements=1, degree=8),
               "lgl 3x5": SolverOptions(elements=3, degree=5),
               "lgl graded": SolverOptions(elements=2, degree=6, clamp_levels=2),
               "midpoint 20": SolverOptions(transcription="midpoint", elements=20)}


@pytest.mark.parametrize("scene_name", list(SCENES))
@pytest.mark.parametrize("res_name", list(RESOLUTIONS))
def test_structured_gradient_and_hessian_equal_the_symbolic_ones(scene_name, res_name):
    """Φᵀ K Φ and Φᵀ ∇F against the automatic differentiation of the whole transcribed energy."""
    sc = SCENES[scene_name]
    sv = get_solver(sc, RESOLUTIONS[res_name])
    k = sv.kernel
    assert k.structured and k.kind == "dense"
    P = sv.parameter_vector(sc)
    u = 0.3 * np.sin(2.0 * sv.transcription.nodes[1:])
    k.set_params(P)
    k.evaluate(u)
    _, g_ref, H_ref = sv.f_grad_hess(u, P)
    g_ref, H_ref = np.asarray(g_ref).ravel(), np.asarray(H_ref)
    np.testing.assert_allclose(k.g, g_ref, rtol=0, atol=1e-13 * max(1.0, np.abs(g_ref).max()))
    np.testing.assert_allclose(k.hessian_dense(), H_ref, rtol=0, atol=1e-13 * np.abs(H_ref).max())


def test_hessian_at_a_new_point_does_not_reuse_an_old_gradient():
    """The kernel reuses a gradient only at the same point and parameters."""
    sc = SCENES["dipole with loads"]
    sv = get_solver(sc, RESOLUTIONS["lgl 1x8"])
    k = sv.kernel
    P = sv.parameter_vector(sc)
    u1, u2 = 0.1 * sv.transcription.nodes[1:], 0.4 * sv.transcription.nodes[1:] ** 2
    k.set_params(P)
    k.evaluate(u1, hessian=False)
    k.evaluate(u2, hessian=True)
    np.testing.assert_allclose(k.g, np.asarray(sv.f_grad_hess(u2, P)[1]).ravel(), atol=1e-13)
    k.evaluate(u2, hessian=False)
    P2 = sv.parameter_vector(Scene(field=DIPOLE, h=0.35, h_pos=0.1, tip_force=(0.2, -0.4), tip_moment=0.3,
                                   distributed_load=(0.1, -0.5)))
    k.set_params(P2)
    k.evaluate(u2, hessian=True)
    np.testing.assert_allclose(k.g, np.asarray(sv.f_grad_hess(u2, P2)[1]).ravel(), atol=1e-13)


def test_dipole_jet_closed_forms_equal_automatic_differentiation():
    model = DipoleFieldModel()
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    P = {name: ca.SX.sym(name) for name in model.params}
    args = [x, y, *P.values()]

    def function(jet):
        h, J, T = jet
        return ca.Function("jet", args, [h, J, T[0], T[1]])

    closed, auto = function(model.jet(x, y, P)), function(FieldModel.jet(model, x, y, P))
    for point in ([0.3, 0.1, 0.5, 0.8, 0.5 * math.pi], [0.9, -0.2, 0.5, 0.8, 0.3],
                  [0.45, 0.7, 0.5, 0.8, -2.0], [1.0, 0.0, 1.2, -0.3, 0.0]):
        for a, b in zip(closed(*point), auto(*point)):
            a, b = np.asarray(a), np.asarray(b)
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


def test_newton_with_the_structured_hessian_converges_quadratically():
    """Plain Newton steps with the kernel's Hessian: r_{k+1} ≤ C r_k² (the exact Hessian)."""
    sc = Scene(field=DIPOLE, h=0.12, h_pos=0.06, tip_force=(0.1, -0.2), tip_moment=0.1,
               distributed_load=(0.0, -0.3))
    sv = get_solver(sc, RESOLUTIONS["lgl 3x5"])
    k = sv.kernel
    P = sv.parameter_vector(sc)
    r = solve(sc, RESOLUTIONS["lgl 3x5"], solver=sv)
    assert r.success and r.stable
    u = r.z[1:] + 0.05
    k.set_params(P)
    res = [k.evaluate(u)]
    for _ in range(4):
        u = u - k.newton_step()
        res.append(k.evaluate(u))
    assert res[4] < 1e-12
    # r_{k+1}/r_k² stays bounded (≈ 0.15 here) while r falls from 1e-2 to 1e-10; an approximate
    # Hessian (linear convergence, r_{k+1} ≈ c r_k) would make it grow like c/r_k (> 100)
    assert max(res[k + 1] / res[k] ** 2 for k in (1, 2)) < 1.0


@pytest.mark.slow  # compiles C code (seconds)
@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler")
def test_jit_positional_kernel_gives_the_same_numbers():
    assert jit_matches_vm(SCENES["dipole with loads"]).kernel.structured


class _ShiftedFieldTerm(EnergyTerm):
    """A test term that reads the dipole field 0.1 beside the rod (not at the point itself)."""

    name = "test_shifted_field"

    def __init__(self, field):
        self.field = field
        self.scalar_params = ("h",) + field.params

    def density(self, kin, P):
        hx, hy = self.field.value(kin.x + 0.1, kin.y, P)
        return -0.3 * (hx * ca.cos(kin.theta) + hy * ca.sin(kin.theta)) ** 2


class _CoupledTerm(EnergyTerm):
    """A test term whose density at a point reads every point (not a pointwise density)."""

    name = "test_coupled"

    def density(self, kin, P):
        return 0.1 * kin.y * ca.sum1(kin.x)


def _structured_against_symbolic(terms, opts):
    tr = make_transcription(opts)
    de = tr.transcribe(terms)
    P = de.params
    ph = positional_hessian(tr, terms, de.layout, P, ca.Function("E", [de.z, P], [de.energy]))
    if ph is None:
        return None
    n = tr.nodes.size - 1
    u, p = 0.3 * np.sin(2.0 * tr.nodes[1:]), np.zeros(de.layout.size)
    sc = SCENES["dipole with loads"]
    for name, sl in de.layout.slices.items():
        p[sl] = {"h": sc.h, "h_pos": sc.h_pos, "dipole_x0": DIPOLE.x0, "dipole_y0": DIPOLE.y0,
                 "dipole_angle": DIPOLE.moment_angle, "b": 1.0}.get(name, 0.1)
    H = np.zeros((n, n))
    ph.bind(u.copy(), p, H)()
    zr = ca.SX.sym("u", n)
    Er = ca.substitute(de.energy, de.z, ca.vertcat(P[de.layout.slices["theta0"]], zr))
    H_ref = np.asarray(ca.Function("H", [zr, P], [ca.hessian(Er, zr)[0]])(u, p))
    return H, H_ref


def test_a_term_reading_the_field_elsewhere_is_differentiated_automatically():
    sc = SCENES["dipole with loads"]
    terms = build_terms(sc)
    terms.append(_ShiftedFieldTerm(DipoleFieldModel()))
    H, H_ref = _structured_against_symbolic(terms, RESOLUTIONS["lgl 1x8"])
    np.testing.assert_allclose(H, H_ref, rtol=0, atol=1e-13 * np.abs(H_ref).max())


def test_a_density_that_couples_points_is_refused():
    terms = build_terms(SCENES["dipole with loads"]) + [_CoupledTerm()]
    assert _structured_against_symbolic(terms, RESOLUTIONS["lgl 1x8"]) is None
