"""The reduced system and its toolkit (actuator_design.reduced) against independent references.

References: the fold load p_crit^(1) of the field-free cantilever by the independent shooting
solver (r = 0 and ∂r/∂γ = 0, ∂r/∂γ from its variational equation), central finite differences of
the reduced gradient and tip map (second-order convergence), and dense LAPACK solves and
eigendecompositions for the banded linear algebra.
"""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reduced import (bordered_solve, inertia, locate_fold, lowest_eigenpairs,
                                     null_vector, reduced_system, signed_distance_to_singularity)
from actuator_design.reduced.linalg import (banded_negatives, ldl_negatives, lowest_eigenpair,
                                            lowest_eigenpair_banded)
from actuator_design.reference.shooting import ShootingParams, shoot
from actuator_design.model.scene import default_scene
from actuator_design.equilibrium.solver import get_solver
from fold_problems import reference_fold


@pytest.fixture(scope="module")
def elastica():
    scene = default_scene(h=0.0, p=0.0)
    solver = get_solver(scene, SolverOptions())
    return solver, solver.parameter_vector(scene)


def test_moore_spence_fold_of_the_elastica_matches_shooting(elastica):
    """p_crit^(1) of the field-free cantilever: Moore–Spence Newton from a guess 0.3 off in p and
    0.1 off in θ'(0) lands on the shooting fold (10.32516073958…), with H v = 0 there."""
    solver, P = elastica
    p1, g1 = reference_fold(10.3, -2.8)
    guess = shoot(g1 + 0.1, ShootingParams(fy=p1 + 0.3))
    nodes = solver.transcription.nodes
    u0 = np.array([guess.theta(s) for s in nodes[1:]])
    system = reduced_system(solver, ["p"])
    fold = locate_fold(system, P, u0, p1 + 0.3, tol=1e-10)
    assert fold.converged
    assert fold.lam == pytest.approx(p1, abs=1e-7)
    assert fold.lam == pytest.approx(10.32516073958, abs=1e-7)
    g, H, _ = system.evaluator(P)(fold.u, fold.lam)
    assert np.max(np.abs(g / system.mass)) <= 1e-10
    assert np.max(np.abs(H @ fold.v)) < 1e-8 * np.max(np.abs(H))


def test_parameter_derivative_and_tip_jacobian_converge_at_second_order():
    """g_λ, ∂tip/∂u and ∂tip/∂λ against central differences: halving the difference step divides
    the error by ≈ 4 (second order), so the derivatives are exact up to rounding."""
    scene = default_scene(h=1.3, phi=1.0, p=0.7)
    solver = get_solver(scene, SolverOptions())
    P = solver.parameter_vector(scene)
    system = reduced_system(solver, ["h2"])
    rng = np.random.default_rng(0)
    u, du = 0.3 * rng.standard_normal(system.n), rng.standard_normal(system.n)
    lam = 1.69
    ev = system.evaluator(P)
    gl = ev(u, lam)[2].copy()
    _, Ju, Jl = (np.asarray(a, float) for a in system.f_tip(u, lam, P))

    def tip(uu, ll):
        return np.asarray(system.f_tip(uu, ll, P)[0], float).ravel()

    errs = []
    for d in (2e-2, 1e-2):
        fd_g = (ev(u, lam + d)[0].copy() - ev(u, lam - d)[0].copy()) / (2 * d)
        fd_u = (tip(u + d * du, lam) - tip(u - d * du, lam)) / (2 * d)
        fd_l = (tip(u, lam + d) - tip(u, lam - d)) / (2 * d)
        errs.append([np.max(np.abs(fd_g - gl)), np.max(np.abs(fd_u - Ju @ du)),
                     np.max(np.abs(fd_l - Jl.ravel()))])
    for coarse, fine in zip(*errs):
        assert fine < 1e-9 or 3.0 < coarse / fine < 5.0


def test_bordered_solve_banded_equals_dense():
    """Block elimination with a banded LU against the assembled dense LU (n = 300, bandwidth 2)."""
    rng = np.random.default_rng(1)
    n, bw = 300, 2
    A = np.zeros((n, n))
    for off in range(-bw, bw + 1):
        A += np.diag(rng.standard_normal(n - abs(off)), off)
    A += 6 * np.eye(n)
    B, C, D = rng.standard_normal((n, 1)), rng.standard_normal((n, 1)), np.array([[0.3]])
    r = rng.standard_normal(n + 1)
    dense = np.linalg.solve(np.block([[A, B], [C.T, D]]), r)
    assert np.max(np.abs(bordered_solve(A, B, C, D, r, bandwidth=bw) - dense)) < 1e-10
    assert np.max(np.abs(bordered_solve(A, B, C, D, r) - dense)) < 1e-12


def test_lowest_eigenpairs_banded_and_dense_agree_with_eigh_and_inertia_counts():
    """Banded and dense storage give the full eigendecomposition's smallest pairs; the LDLᵀ
    inertia counts the negative eigenvalues of an indefinite matrix."""
    n = 200
    main = 2.0 + 0.01 * np.arange(n) - 0.05 * (np.arange(n) < 3)
    off = -np.ones(n - 1)
    H = np.diag(main) + np.diag(off, 1) + np.diag(off, -1) - 0.1 * np.eye(n)
    m = np.full(n, 0.5)
    rows, cols = np.nonzero(H)
    ref_w, ref_V = np.linalg.eigh(H / 0.5)
    for banded in (True, False):
        lam, v = lowest_eigenpairs(rows, cols, H[rows, cols], 1 / m, 3, banded, 1)
        assert np.max(np.abs(lam - ref_w[:3])) < 1e-10
        assert abs(abs(v @ ref_V[:, 0]) - 1.0) < 1e-8
    neg, lowest = inertia(H - 0.2 * np.eye(n))
    w = np.linalg.eigvalsh(H - 0.2 * np.eye(n))
    assert neg == int(np.sum(w < 0)) and lowest == pytest.approx(w[0], abs=1e-12)
    assert neg > 0


def _random_band(rng, n, bw, shift):
    """A random symmetric band matrix (bandwidth bw) plus shift·I: SPD or indefinite."""
    A = shift * np.eye(n)
    for k in range(bw + 1):
        d = rng.standard_normal(n - k)
        A += np.diag(d, k) + (np.diag(d, -k) if k else 0.0)
    return A


def test_partial_spectra_agree_with_the_full_eigendecomposition():
    """LDLᵀ inertia, the warm-started certified smallest eigenpair (from a perturbed, a random and
    no start), the signed distance to singularity and the null vector of (H, M), each against
    numpy's full ``eigh`` on random banded SPD and indefinite matrices."""
    rng = np.random.default_rng(7)
    for trial in range(120):
        n = int(rng.integers(2, 70))
        A = _random_band(rng, n, int(rng.integers(1, n)), rng.uniform(-4.0, 6.0))
        w, V = np.linalg.eigh(A)
        scale = max(1.0, float(np.abs(w).max()))
        assert ldl_negatives(A) == int(np.sum(w < 0))
        for start in (V[:, 0] + 0.1 * rng.standard_normal(n), rng.standard_normal(n), None):
            mu, v, definite = lowest_eigenpair(A, start)
            assert mu == pytest.approx(w[0], abs=1e-11 * scale)
            assert np.linalg.norm(A @ v - mu * v) < 1e-9 * scale and abs(np.linalg.norm(v) - 1) < 1e-12
            assert not definite or w[0] > 0
        idx, lowest, signed = signed_distance_to_singularity(A)
        assert idx == int(np.sum(w < -1e-9 * max(1.0, abs(w[0]))))
        assert lowest == pytest.approx(w[0], abs=1e-11 * scale)
        assert signed == pytest.approx((-1) ** int(np.sum(w < 0)) * np.min(np.abs(w)), abs=1e-11 * scale)
        m = rng.uniform(0.2, 2.0, n)
        s = 1 / np.sqrt(m)
        wm, Vm = np.linalg.eigh(s[:, None] * A * s[None, :])
        k = int(np.argmin(np.abs(wm)))
        if n > 1 and np.sort(np.abs(wm))[1] - abs(wm[k]) < 1e-6:
            continue  # two eigenvalues equally close to zero: the null vector is not unique
        ref = s * Vm[:, k]
        v = null_vector(A, m)
        assert v @ (m * v) == pytest.approx(1.0, abs=1e-12)
        assert abs(v @ (m * ref)) / np.sqrt(ref @ (m * ref)) == pytest.approx(1.0, abs=1e-8)


def test_certified_smallest_eigenpair_is_not_fooled_by_a_higher_eigenvector():
    """Started on the eigenvector of the second eigenvalue (as after two eigenvalues cross along a
    branch), Rayleigh-quotient iteration stays there; the Cholesky certificate rejects it and the
    smallest pair is returned."""
    rng = np.random.default_rng(3)
    A = _random_band(rng, 30, 4, 1.0)
    w, V = np.linalg.eigh(A)
    mu, v, _ = lowest_eigenpair(A, V[:, 1])
    assert mu == pytest.approx(w[0], abs=1e-11 * np.abs(w).max())
    assert abs(v @ V[:, 0]) == pytest.approx(1.0, abs=1e-8)


def test_banded_smallest_eigenpair_and_negative_count_agree_with_eigh():
    """The band-storage smallest eigenpair (warm, cold and from the second eigenvector) and the
    count of negative eigenvalues against numpy's full ``eigh`` (n = 64..150, bandwidth < n/4)."""
    rng = np.random.default_rng(11)
    for trial in range(20):
        n = int(rng.integers(64, 150))
        bw = int(rng.integers(1, n // 4))
        A = _random_band(rng, n, bw, rng.uniform(-4.0, 6.0))
        a = np.zeros((bw + 1, n))
        for k in range(bw + 1):  # LAPACK upper band storage a[bw + i − j, j] = A_ij
            a[bw - k, k:] = np.diagonal(A, k)
        w, V = np.linalg.eigh(A)
        scale = float(np.abs(w).max())
        for start in (V[:, 0] + 0.05 * rng.standard_normal(n), None, V[:, 1]):
            mu, v, definite = lowest_eigenpair_banded(a, start)
            assert mu == pytest.approx(w[0], abs=1e-10 * scale)
            assert np.linalg.norm(A @ v - mu * v) < 1e-8 * scale
            assert not definite or w[0] > 0
        assert banded_negatives(a) == int(np.sum(w < 0))


def test_moore_spence_jacobian_by_blocks_converges_at_second_order():
    """The fold system's Jacobian (assembled by blocks: H, ∂g/∂λ, ∂(Hv)/∂u as the Hessian of v·g,
    ∂(Hv)/∂λ, H, cᵀM) against central differences of F itself in every direction (u, λ, v):
    halving the step divides the error by ≈ 4, on a scene with a fibre layout and a tip load."""
    scene = default_scene(h=1.3, phi=1.0, p=0.7, alpha=0.4)
    solver = get_solver(scene, SolverOptions(elements=6))
    P = solver.parameter_vector(scene)
    system = reduced_system(solver, ["h", "phi"])
    n = system.n
    rng = np.random.default_rng(1)
    u, v, c = 0.3 * rng.standard_normal(n), rng.standard_normal(n), rng.standard_normal(n)
    lam = np.array([1.3, 1.0])
    X = np.concatenate([u, lam[:1], v])
    dX = rng.standard_normal(2 * n + 1)

    def F(x):
        return np.asarray(system.f_fold(x[:n], np.array([x[n], lam[1]]), x[n + 1:], c, P)[0], float).ravel()

    J = np.asarray(system.f_fold(u, lam, v, c, P)[1], float)
    errs = [np.max(np.abs((F(X + d * dX) - F(X - d * dX)) / (2 * d) - J @ dX)) for d in (2e-2, 1e-2)]
    assert errs[1] < 1e-9 or 3.0 < errs[0] / errs[1] < 5.0
    assert np.max(np.abs(J[2 * n, n + 1:] - system.mass * c)) == 0.0


@pytest.mark.parametrize("names, lam", [(["h"], [0.4]), (["h2"], [0.2]), (["h", "h_pos"], [0.4, 0.2]),
                                        (["theta0"], [0.3])])
def test_the_kernel_evaluator_equals_the_symbolic_system(names, lam):
    """In a position-reading energy (a point dipole with loads) the continuation's (g, H, G_λ) come
    from the solver's structured kernel; they equal the symbolic reduced system's (automatic
    differentiation of the whole reduced energy: a second method) to round-off, in every lens."""
    from actuator_design.reduced.system import KernelSystemEvaluator, SystemEvaluator, reduced_system
    from actuator_design.model.scene import DipoleField, Scene

    scene = Scene(field=DipoleField(x0=0.5, y0=0.8, moment_angle=0.5 * math.pi), h=0.3, h_pos=0.1,
                  tip_force=(0.2, -0.4), tip_moment=0.3, distributed_load=(0.1, -0.5))
    sv = get_solver(scene, SolverOptions(elements=1, degree=8))
    P = sv.parameter_vector(scene)
    system = reduced_system(sv, names)
    fast = system.evaluator(P)
    assert isinstance(fast, KernelSystemEvaluator)
    u = 0.3 * np.sin(2 * sv.transcription.nodes[1:])
    g1, H1, l1 = (np.array(v) for v in fast(u, lam))
    g2, H2, l2 = (np.array(v) for v in SystemEvaluator(system.f_system, P)(u, lam))
    assert l1.shape == l2.shape
    np.testing.assert_allclose(g1, g2, rtol=0, atol=1e-12 * np.abs(g2).max())
    np.testing.assert_allclose(H1, H2, rtol=0, atol=1e-12 * np.abs(H2).max())
    np.testing.assert_allclose(l1, l2, rtol=0, atol=1e-12 * max(np.abs(l2).max(), 1.0))
