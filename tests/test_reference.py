"""Tests of actuator_design.reference (closed forms of THEORY §6, shooting, Jacobi test of §7).

Every check compares against an independent reference:

* s(h): the naive formula where it is accurate, and 80-digit ``decimal`` arithmetic (plus mpmath
  when it is importable);
* s(h) against the shooting solver (central difference of y(1) in p);
* the transverse mode (elliptic functions) against the shooting solver and against adaptive
  quadrature of cos θ, sin θ (this verifies the derivation of u1 and v1 for modes 1, 2, 3);
* the field-free cantilever elastica against an elliptic-integral reference written in this file
  (first integral + ``scipy.integrate.quad``), independent of the shooting code;
* the Sturm/Jacobi Morse index against the exact spectrum for constant Q and against a
  finite-difference eigenvalue computation, and on equilibria whose stability is known;
* the second-variation coefficient Q against finite differences of the energy functional.
"""
import math
from decimal import MAX_EMAX, MIN_EMIN, Decimal, localcontext

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.linalg import eigh_tridiagonal
from scipy.optimize import brentq

from actuator_design.reference.closed_forms import (
    critical_field_transverse,
    lowload_stiffness,
    transverse_mode,
)
from actuator_design.reference.shooting import (
    ShootingParams,
    energy_functional,
    jacobi_coefficient,
    jacobi_morse_index,
    shoot,
    solve_shooting,
    sturm_morse_index,
)

SQ2 = math.sqrt(2.0)
H_CRIT1 = math.pi / (2 * SQ2)
H_CRIT2 = 3 * math.pi / (2 * SQ2)


# ----------------------------------------------------------------------------- low-load stiffness


def naive_stiffness(h):
    h = np.asarray(h, dtype=float)
    return 4 * h**3 / (2 * h - SQ2 * np.tanh(SQ2 * h))


def decimal_stiffness(h: float) -> float:
    """s(h) = 4h³/(2h − √2 tanh(√2 h)) in 80-digit decimal arithmetic (h converted exactly)."""
    with localcontext() as ctx:
        ctx.prec = 80
        ctx.Emax = MAX_EMAX
        ctx.Emin = MIN_EMIN
        H = Decimal(h)
        r2 = Decimal(2).sqrt()
        e = (-2 * r2 * H).exp()  # e^{−2k} ∈ (0, 1]
        tanh = (1 - e) / (1 + e)
        return float(4 * H**3 / (2 * H - r2 * tanh))


LISTED_H = [1e-8, 1e-4, 1e-2, 0.1, 0.3, 1.0, 10.0, 100.0, 1e4, 1e8]


def test_lowload_stiffness_matches_naive_formula_where_accurate():
    h = np.linspace(0.5, 5.0, 301)
    s = lowload_stiffness(h)
    np.testing.assert_allclose(s, naive_stiffness(h), rtol=1e-12, atol=0)


@pytest.mark.parametrize("h", LISTED_H)
def test_lowload_stiffness_high_precision(h):
    ref = decimal_stiffness(h)
    assert abs(lowload_stiffness(h) / ref - 1) < 1e-14


def test_lowload_stiffness_mpmath():
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 60
    for h in LISTED_H:
        H = mpmath.mpf(h)
        ref = 4 * H**3 / (2 * H - mpmath.sqrt(2) * mpmath.tanh(mpmath.sqrt(2) * H))
        assert abs(lowload_stiffness(h) / float(ref) - 1) < 1e-14


def test_lowload_stiffness_dense_sweep_high_precision():
    # covers both sides of the series/direct switch at k = √2 h = 1.5 (h ≈ 1.0607)
    hs = np.concatenate([np.logspace(-9, 9, 181), np.linspace(0.9, 1.2, 61)])
    s = lowload_stiffness(hs)
    ref = np.array([decimal_stiffness(float(v)) for v in hs])
    assert np.max(np.abs(s / ref - 1)) < 1e-14


def test_lowload_stiffness_limits_and_finiteness():
    assert lowload_stiffness(0.0) == 3.0
    assert isinstance(lowload_stiffness(0.0), float)
    hs = np.concatenate([[0.0, 5e-324, 1e-300], np.logspace(-200, 150, 351)])
    s = lowload_stiffness(hs)
    assert s.shape == hs.shape
    assert np.all(np.isfinite(s))
    assert np.all(s >= 3.0)
    assert np.all(np.diff(s) >= 0)  # stiffness grows with the field
    # large h: s ≈ k²/(1 − 1/k), k = √2 h
    k = SQ2 * 1e12
    assert abs(lowload_stiffness(1e12) / (k * k / (1 - 1 / k)) - 1) < 1e-15
    assert lowload_stiffness(np.zeros((2, 3))).shape == (2, 3)
    with pytest.raises(ValueError):
        lowload_stiffness(-1.0)


@pytest.mark.parametrize("h", [0.5, 1.0, 2.0])
def test_lowload_stiffness_against_shooting(h):
    dp = 1e-4
    tips = []
    for p in (dp, -dp):
        sol = solve_shooting(ShootingParams(h=h, phi=0.0, fy=p), gamma_guess=0.0)
        assert sol.converged
        tips.append(sol.tip_y)
    dydp = (tips[0] - tips[1]) / (2 * dp)
    assert abs(dydp * lowload_stiffness(h) - 1) < 1e-6


# ------------------------------------------------------------------------- transverse field


TRANSVERSE_CASES = [(1.2, 1), (1.5, 1), (3.0, 1), (4.0, 2)]


@pytest.mark.parametrize("h,m", TRANSVERSE_CASES)
def test_transverse_mode_against_shooting(h, m):
    tm = transverse_mode(h, m)
    sol = solve_shooting(ShootingParams(h=h, phi=math.pi / 2), gamma_guess=tm.gamma)
    assert sol.converged
    x1, y1, th1 = sol.tip
    assert abs(sol.gamma - tm.gamma) < 1e-9
    assert abs(abs(th1) - tm.beta) < 1e-9
    assert abs(th1 - tm.theta1) < 1e-9
    assert abs((x1 - 1) - tm.u1) < 1e-9
    assert abs(y1 - tm.v1) < 1e-9
    assert tm.v1 > 0
    # the closed-form shape θ(s), θ'(s) along the rod
    s = np.linspace(0, 1, 41)
    np.testing.assert_allclose(tm.theta(s), sol.theta(s), rtol=0, atol=1e-9)
    np.testing.assert_allclose(tm.dtheta(s), sol.dtheta(s), rtol=0, atol=1e-8)
    # energy by quadrature of the closed form vs the shooting solution
    e_closed = energy_functional(tm.theta, tm.dtheta, sol.params)
    assert abs(sol.energy - e_closed) < 1e-10
    assert sol.energy < 0.0  # below the straight rod (Ê = 0 for φ = π/2)


@pytest.mark.parametrize("h,m", [(1.5, 1), (4.0, 2), (6.0, 3), (20.0, 1)])
def test_transverse_mode_tip_formulas_by_quadrature(h, m):
    """x(1) = ∫cos θ = π/(2K) (no factor 2m−1) and y(1) = ∫ sin θ = ln(cos β/(1−sin β))/((2m−1)K)."""
    tm = transverse_mode(h, m)
    # split at the quarter periods s = jK/w, where θ has its extrema
    pts = [j * tm.K / tm.w for j in range(1, 2 * m - 1)]
    kw = dict(points=pts or None, epsabs=1e-13, epsrel=1e-13, limit=400)
    x1 = quad(lambda s: math.cos(tm.theta(s)), 0, 1, **kw)[0]
    y1 = quad(lambda s: math.sin(tm.theta(s)), 0, 1, **kw)[0]
    assert abs(x1 - 1 - tm.u1) < 1e-11
    assert abs(x1 - math.pi / (2 * tm.K)) < 1e-11
    assert abs(x1 - critical_field_transverse(m) / h) < 1e-11  # x(1) = h_crit^(m)/h
    assert abs(y1 - tm.v1) < 1e-11
    if tm.beta_complement > 1e-3:  # THEORY's printed form is 0/0 in floating point as β → π/2
        v1_formula = math.log(math.cos(tm.beta) / (1 - math.sin(tm.beta))) / ((2 * m - 1) * tm.K)
        assert abs(v1_formula - tm.v1) < 1e-12
    # boundary values of the closed-form shape
    assert tm.theta(0.0) == 0.0
    assert abs(tm.theta(1.0) - (-1) ** (m - 1) * tm.beta) < 1e-12
    assert abs(tm.dtheta(1.0)) < 1e-9 * tm.w


def test_transverse_mode_raises_below_critical_field():
    assert critical_field_transverse(1) == pytest.approx(H_CRIT1, rel=1e-15)
    assert critical_field_transverse(2) == pytest.approx(H_CRIT2, rel=1e-15)
    for h, m in [(1.0, 1), (H_CRIT1, 1), (0.0, 1), (3.0, 2), (H_CRIT2, 2), (5.0, 3)]:
        with pytest.raises(ValueError, match="h_crit"):
            transverse_mode(h, m)
    with pytest.raises(ValueError):
        transverse_mode(2.0, 0)
    # just above the bifurcation: small β ~ amplitude of the pitchfork
    tm = transverse_mode(H_CRIT1 * (1 + 1e-10), 1)
    assert 0 < tm.beta < 1e-4


def test_transverse_mode_beta_monotone_and_large_h():
    hs = [1.2, 1.5, 2.0, 3.0, 5.0, 10.0, 20.0, 30.0, 100.0]
    modes = [transverse_mode(h) for h in hs]
    betas = np.array([t.beta for t in modes])
    comps = np.array([t.beta_complement for t in modes])
    assert np.all(np.isfinite(betas)) and np.all(betas <= math.pi / 2)
    assert np.all(betas[hs.index(1.2): hs.index(20.0) + 1] < math.pi / 2)
    assert np.all(np.diff(betas) >= 0) and np.all(np.diff(betas[:7]) > 0)
    # π/2 − β (resolved beyond the rounding of β itself) is positive and strictly decreasing
    assert np.all(comps > 0) and np.all(np.diff(comps) < 0)
    # asymptote: cos β = k' = 4 exp(−K), K = √2 h  ⇒  π/2 − β ≈ 4 exp(−√2 h)
    t30 = modes[hs.index(30.0)]
    assert abs(t30.beta_complement / (4 * math.exp(-SQ2 * 30.0)) - 1) < 1e-10
    assert abs(t30.u1 - (H_CRIT1 / 30.0 - 1)) < 1e-15
    assert np.isfinite(t30.v1) and 0 < t30.v1 < 1


# --------------------------------------------------------------- field-free elastica (h = 0)


def elastica_reference(p):
    """Cantilever elastica θ'' + p cos θ = 0, θ(0) = 0, θ'(1) = 0 (mode 1), by quadrature.

    First integral ½θ'² + p sin θ = p sin β with β = θ(1) ∈ (0, π/2); θ increases
    monotonically, so ds = dθ/√(2p(sin β − sin θ)) and
        1 = ∫₀^β dθ/√(2p(sin β − sin θ)),   x(1) = √(2 sin β / p),
        y(1) = ∫₀^β sin θ dθ/√(2p(sin β − sin θ)).
    The (β − θ)^(−1/2) singularity is handled by quad's algebraic weight; the rest is smooth:
    sin β − sin θ = 2 cos((β+θ)/2) sin((β−θ)/2).
    """

    def smooth(th, beta):
        d = beta - th
        if d == 0.0:
            return 1.0 / math.sqrt(math.cos(beta))
        return math.sqrt(d / (2 * math.cos(0.5 * (beta + th)) * math.sin(0.5 * d)))

    kw = dict(weight="alg", wvar=(0.0, -0.5), epsabs=0.0, epsrel=1e-13, limit=200)

    def length(beta):
        return quad(smooth, 0.0, beta, args=(beta,), **kw)[0] / math.sqrt(2 * p)

    beta = brentq(lambda b: length(b) - 1.0, 1e-9, math.pi / 2 - 1e-9, xtol=1e-15, rtol=1e-15)
    x1 = math.sqrt(2 * math.sin(beta) / p)
    y1 = quad(lambda th: math.sin(th) * smooth(th, beta), 0.0, beta, **kw)[0] / math.sqrt(2 * p)
    return beta, x1, y1


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
@pytest.mark.parametrize("p", [0.5, 2.0, 5.0])
def test_field_free_elastica(p):
    beta, x1, y1 = elastica_reference(p)
    sol = solve_shooting(ShootingParams(h=0.0, phi=0.0, fy=p), gamma_guess=p)  # linear-theory guess
    assert sol.converged
    X, Y, A = sol.tip
    assert abs(A - beta) < 1e-8
    assert abs(X - x1) < 1e-8
    assert abs(Y - y1) < 1e-8
    assert abs(sol.gamma - math.sqrt(2 * p * math.sin(beta))) < 1e-8  # first integral at s = 0
    assert jacobi_morse_index(sol).index == 0  # mode 1 is stable (below p_crit)


# ------------------------------------------------------------------------------- Jacobi test


def expected_index_constant(c):
    return sum(1 for k in range(1, 100) if (k - 0.5) * math.pi < c)


@pytest.mark.parametrize("c", [0.3, 1.0, 1.5, 1.7, 3.0, 4.6, 6.0, 8.5, 12.0])
def test_sturm_index_constant_q(c):
    """Q = −c²: eigenvalues of −η'' − c²η, η(0) = 0, η'(1) = 0 are ((k − ½)π)² − c²."""
    res = sturm_morse_index(lambda s: -c * c)
    assert res.index == expected_index_constant(c)
    assert not res.degenerate
    assert res.zeros_moment == res.index  # here the "zeros of bη'" rule holds


@pytest.mark.parametrize("k", [1, 2])
def test_sturm_index_degenerate(k):
    c = (k - 0.5) * math.pi
    res = sturm_morse_index(lambda s: -c * c)
    assert res.degenerate and res.index == k - 1 and not res.stable


def fd_eigenvalues(Q, b=lambda s: 1.0 + 0.0 * s, n=3000, count=4):
    """Lowest eigenvalues of −(bη')' + Qη = λη, η(0) = 0, bη'(1) = 0 (finite differences)."""
    hh = 1.0 / n
    s = np.arange(1, n + 1) * hh
    bm = b(s - 0.5 * hh)
    bp = np.append(b(s[:-1] + 0.5 * hh), 0.0)  # natural condition at s = 1
    d = (bm + bp) / hh**2 + Q(s)
    e = -bm[1:] / hh**2
    mass = np.ones(n)
    mass[-1] = 0.5  # half cell at the free end
    d[-1] = bm[-1] / hh**2 + 0.5 * Q(s[-1])
    sc = 1.0 / np.sqrt(mass)
    return eigh_tridiagonal(d * sc * sc, e * sc[:-1] * sc[1:], eigvals_only=True,
                            select="i", select_range=(0, count - 1))


def test_sturm_index_vs_finite_differences_when_moment_rule_fails():
    """bη' can vanish twice in (0, 1) while the index is 0: the Prüfer count is the right one."""

    def Q(s, c=2.2, a=0.8, q_plus=50.0, eps=0.01):
        sm = 0.5 * (1 + np.tanh((np.asarray(s) - a) / eps))
        return -c * c * (1 - sm) + q_plus * sm

    res = sturm_morse_index(lambda s: float(Q(s)))
    lam = fd_eigenvalues(Q)
    assert res.zeros_moment == 2
    assert res.index == int(np.sum(lam < 0)) == 0
    # and a graded stiffness with negative Q (index ≥ 2)
    bfun = lambda s: 1.0 + 0.8 * np.asarray(s)  # noqa: E731
    Q2 = lambda s: -40.0 + 10.0 * np.asarray(s)  # noqa: E731
    res2 = sturm_morse_index(lambda s: float(Q2(s)), b=lambda s: float(bfun(s)))
    lam2 = fd_eigenvalues(Q2, bfun)
    assert np.min(np.abs(lam2)) > 0.5  # far from degenerate
    assert res2.index == int(np.sum(lam2 < 0)) >= 1


@pytest.mark.parametrize("h,expected", [(0.5, 0), (1.0, 0), (1.2, 1), (2.0, 1), (3.0, 1), (4.0, 2)])
def test_jacobi_straight_rod_transverse_field(h, expected):
    params = ShootingParams(h=h, phi=math.pi / 2)
    straight = shoot(0.0, params)
    assert straight.converged and np.all(straight.theta(np.linspace(0, 1, 11)) == 0.0)
    res = jacobi_morse_index(straight)
    assert res.index == expected
    assert not res.degenerate
    assert res.index == expected_index_constant(SQ2 * h)  # Q = −2h² on the straight rod


@pytest.mark.parametrize("h,m,expected", [(1.5, 1, 0), (3.0, 1, 0), (4.0, 2, 1)])
def test_jacobi_buckled_modes(h, m, expected):
    tm = transverse_mode(h, m)
    sol = solve_shooting(ShootingParams(h=h, phi=math.pi / 2), gamma_guess=tm.gamma)
    assert sol.converged
    res = jacobi_morse_index(sol)
    assert res.index == expected and not res.degenerate
    assert res.stable == (expected == 0)


# ------------------------------------------------------- energy and second variation


def general_params():
    return ShootingParams(h=1.3, phi=0.7, fx=0.4, fy=-0.8, m=0.3, qx=0.2, qy=-0.5, theta0=0.1,
                          alpha=lambda s: 0.3 * np.asarray(s), b=lambda s: 1.0 + 0.5 * np.asarray(s))


def test_energy_stationary_and_second_variation_matches_Q():
    """(E) is stationary at the shooting solution, and its second difference is ∫bη'² + Qη²."""
    params = general_params()
    sol = solve_shooting(params, gamma_guess=0.0)
    assert sol.converged
    # M(1) = b(1)θ'(1) = m
    assert abs(sol.moment(1.0) - params.m) < 1e-10
    eta = lambda s: np.sin(2.0 * np.asarray(s)) + np.asarray(s) ** 2  # noqa: E731, η(0) = 0
    deta = lambda s: 2.0 * np.cos(2.0 * np.asarray(s)) + 2.0 * np.asarray(s)  # noqa: E731
    nodes = np.linspace(0, 1, 257)

    def E(eps):
        return energy_functional(lambda s: sol.theta(s) + eps * eta(s),
                                 lambda s: sol.dtheta(s) + eps * deta(s), params,
                                 breakpoints=nodes)

    e0 = E(0.0)
    assert abs(e0 - sol.energy) < 1e-11
    eps = 1e-4  # truncation O(eps²) ≈ 1e-8, round-off ≈ 1e-16/eps² ≈ 1e-8
    ep, em = E(eps), E(-eps)
    first = (ep - em) / (2 * eps)
    second = (ep + em - 2 * e0) / eps**2
    # Q[η] by quadrature with the coefficient of eq. (Q)
    xg, wg = np.polynomial.legendre.leggauss(40)
    s = 0.5 * (xg + 1)
    w = 0.5 * wg
    Qs = jacobi_coefficient(sol.theta(s), s, params)
    q_eta = np.dot(w, params.b(s) * deta(s) ** 2 + Qs * eta(s) ** 2)
    assert abs(first) < 1e-7
    assert abs(second - q_eta) < 1e-5 * max(1.0, abs(q_eta))
    # a non-equilibrium shot is not stationary (the test above has teeth)
    bad = shoot(sol.gamma + 0.1, params)
    e_bad = [energy_functional(lambda s, e=e: bad.theta(s) + e * eta(s),
                               lambda s, e=e: bad.dtheta(s) + e * deta(s), params,
                               breakpoints=nodes) for e in (eps, -eps)]
    assert abs((e_bad[0] - e_bad[1]) / (2 * eps)) > 1e-3


def test_energy_of_simple_configurations():
    # straight rod along the field axis: Ê = −h²; across it: Ê = 0 (THEORY §5)
    for phi, expected in [(0.0, -4.0), (math.pi / 2, 0.0)]:
        sol = shoot(0.0, ShootingParams(h=2.0, phi=phi))
        assert sol.converged
        assert abs(sol.energy - expected) < 1e-13
    # field-free, tip moment m: θ = m s, Ê = ½m² − m² = −½m²
    sol = solve_shooting(ShootingParams(m=0.7), gamma_guess=0.0)
    assert abs(sol.gamma - 0.7) < 1e-12 and abs(sol.energy + 0.5 * 0.49) < 1e-12


# ------------------------------------------------------------------------------- symmetry


def test_mirror_symmetry_transverse_field_is_exact():
    params = ShootingParams(h=1.5, phi=math.pi / 2)
    a, b = shoot(1.7, params), shoot(-1.7, params)
    assert np.array_equal(a.s_nodes, b.s_nodes)
    s = np.linspace(0, 1, 101)
    assert np.array_equal(b.theta(s), -a.theta(s))
    assert np.array_equal(b.moment(s), -a.moment(s))
    assert np.array_equal(b.x(s), a.x(s))
    assert np.array_equal(b.y(s), -a.y(s))
    assert b.residual == -a.residual
    assert b.energy == a.energy


def test_profiles_accepted_for_b_and_alpha():
    """``Profile`` objects (any callable of s) give the same equilibrium as the equivalent floats."""
    from actuator_design.model.profiles import constant_profile, table_profile

    as_float = ShootingParams(h=1.1, phi=0.4, fy=0.5, alpha=0.2, b=1.5)
    as_profile = ShootingParams(h=1.1, phi=0.4, fy=0.5, alpha=constant_profile(0.2),
                                b=table_profile([0.0, 1.0], [1.5, 1.5]))
    a = solve_shooting(as_float, 0.0)
    b = solve_shooting(as_profile, 0.0)
    assert a.converged and b.converged
    np.testing.assert_allclose(b.tip, a.tip, rtol=0, atol=1e-12)
    assert abs(a.energy - b.energy) < 1e-12
    assert jacobi_morse_index(a).index == jacobi_morse_index(b).index == 0
