"""The fast Newton path (``method="fast"``, :meth:`EquilibriumSolver.solve_fast`) and its kernel.

References: THEORY §6 closed forms (elliptic transverse mode, the elastica), the independent
shooting solver, numpy/LAPACK dense linear algebra for the banded and tridiagonal solves, and
second-order convergence of the midpoint rule. No timings here (see ``actuator-design bench``).
"""
import math
import shutil
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.benchmarks.floor import NumpyNewton
from actuator_design.benchmarks.problems import elastica_tip
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reference.closed_forms import transverse_mode
from actuator_design.reference.shooting import ShootingParams, solve_shooting
from actuator_design.model.scene import Scene, default_scene
from actuator_design.equilibrium.solver import get_solver
from jit_check import jit_matches_vm

FAST = SolverOptions(elements=1, degree=12, method="fast")


def _tip(r):
    return np.array([r.tip["x"], r.tip["y"], r.tip["angle"]])


def _transverse_ref(h):
    ref = transverse_mode(h, 1)
    return np.array([1 + ref.u1, ref.v1, ref.beta])


def test_fast_solve_matches_elliptic_closed_form_and_reports_stability():
    h = 1.5
    sc = default_scene(h=h, phi=math.pi / 2)
    nodes = get_solver(sc, FAST).transcription.nodes
    r = solve(sc, FAST, initial=0.8 * np.sin(0.5 * math.pi * nodes))
    assert r.success and r.message.startswith("fast Newton")
    assert np.max(np.abs(_tip(r) - _transverse_ref(h))) < 1e-9
    assert r.stable and r.morse_index == 0  # the verdict is kept on the fast path


def test_warm_resolves_follow_the_branch_against_shooting():
    """A sweep in p by warm fast re-solves: every point is the shooting equilibrium at that p."""
    sv = get_solver(default_scene(h=1.0, p=2.0), FAST)
    r = solve(default_scene(h=1.0, p=2.0), replace(FAST, method="ipopt"))
    z = r.z
    for p in np.linspace(2.0, 2.5, 6):
        P = sv.parameter_vector(default_scene(h=1.0, p=p))
        raw = sv.solve_fast(z, P)
        assert raw.converged, raw.message
        z = raw.z
        _, th1, x1, y1 = sv.summary(z, P)
        ref = solve_shooting(ShootingParams(h=1.0, fy=p), gamma_guess=1.0)
        assert ref.converged
        np.testing.assert_allclose([x1, y1, th1], ref.tip, atol=1e-9)


def test_fast_path_never_returns_a_wrong_answer_from_bad_starts():
    """From wild starting points the fast path either says it did not converge, or returns a true
    equilibrium: the shooting solution started from its θ'(0) ends at the same tip."""
    sc = default_scene(h=1.3, phi=1.0, p=0.7)
    sv = get_solver(sc, FAST)
    P = sv.parameter_vector(sc)
    rng = np.random.default_rng(7)
    n = sv.transcription.nodes.size
    outcomes = {True: 0, False: 0}
    params = ShootingParams(h=1.3, phi=1.0, fy=0.7)
    for trial in range(12):
        z0 = rng.normal(scale=3.0, size=n)
        raw = sv.solve_fast(z0, P)
        outcomes[raw.converged] += 1
        if not raw.converged:
            assert raw.status == "not_converged" and raw.message.startswith("fast Newton")
            continue
        assert np.all(np.isfinite(raw.z))
        r = solve(sc, replace(FAST, ensure_stable=False), initial=raw.z)
        ref = solve_shooting(params, gamma_guess=r.gamma)
        assert ref.converged
        np.testing.assert_allclose(_tip(r), ref.tip, atol=1e-7)
    bad = sv.solve_fast(np.full(n, np.nan), P)
    assert not bad.converged and "not finite" in bad.message


def test_fallback_is_reported_and_correct():
    """A start the full-step iteration cannot handle: solve() falls back and says so."""
    sc = default_scene(h=1.5, phi=math.pi / 2)
    n = get_solver(sc, FAST).transcription.nodes.size
    r = solve(sc, FAST, initial=np.linspace(0, 40.0, n))
    assert r.success
    if "fell back" in r.message:
        assert "fast Newton" in r.message
    ref = solve_shooting(ShootingParams(h=1.5, phi=math.pi / 2), gamma_guess=r.gamma)
    np.testing.assert_allclose(_tip(r), ref.tip, atol=1e-8)


@pytest.mark.parametrize("transcription,elements,degree,kind", [
    ("midpoint", 300, 10, "tridiagonal"), ("lgl", 16, 4, "banded"), ("lgl", 2, 10, "dense")])
def test_kernel_linear_algebra_matches_dense_numpy(transcription, elements, degree, kind):
    sc = default_scene(h=2.0, phi=0.7, p=0.4)
    sv = get_solver(sc, SolverOptions(transcription=transcription, elements=elements, degree=degree))
    k = sv.kernel
    assert k.kind == kind
    P = sv.parameter_vector(sc)
    z = 0.3 * np.sin(2.0 * sv.transcription.nodes)
    k.set_params(P)
    k.evaluate(z[1:])
    H = k.hessian_dense()
    _, g_ref, H_ref = sv.f_grad_hess(z[1:], P)
    np.testing.assert_allclose(H, np.asarray(H_ref), atol=1e-12 * np.abs(H).max())
    np.testing.assert_allclose(k.g, np.asarray(g_ref).ravel(), atol=1e-13)
    step = k.newton_step()
    np.testing.assert_allclose(step, np.linalg.solve(H, k.g), rtol=1e-9, atol=1e-12)
    lam, v = k.lowest_eigenpairs(3)
    Ms = np.sqrt(k.inv_mass)
    A = Ms[:, None] * H * Ms[None, :]
    lam_ref, V_ref = np.linalg.eigh(0.5 * (A + A.T))
    np.testing.assert_allclose(lam, lam_ref[:3], rtol=1e-8, atol=1e-8)
    assert abs(abs(v @ V_ref[:, 0]) - 1) < 1e-8


def test_numpy_floor_solves_the_same_system():
    """The benchmark's numpy Newton (the floor) reaches the closed-form elastica like the solver."""
    sc = Scene(field=None, tip_force=(0.0, 3.0))
    nn = NumpyNewton(1, 12)
    z, ok, _ = nn.solve(0.5 * nn.tr.nodes, nn.prepare(sc))
    assert ok
    thq = nn.G @ z
    tip = np.array([nn.w @ np.cos(thq), nn.w @ np.sin(thq), z[-1]])
    np.testing.assert_allclose(tip, elastica_tip(3.0), atol=1e-10)
    r = solve(sc, FAST, initial=0.5 * nn.tr.nodes)
    np.testing.assert_allclose(_tip(r), tip, atol=1e-10)


@pytest.mark.slow  # compiles C code (seconds)
@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler")
def test_jit_kernel_gives_the_same_numbers():
    jit_matches_vm(default_scene(h=1.2, phi=0.4, p=0.3))