"""Tests of actuator_design.physics.magnetic_composite against independent references (THEORY §2).

References used: the general ellipsoid demagnetising integral (scipy quad), a 60-digit
evaluation of the closed form with ``decimal``, the sphere and slender-body asymptotes, and
hand-computed susceptibilities.
"""
import math
import warnings
from decimal import Decimal, getcontext

import numpy as np
import pytest
from scipy.integrate import quad

from actuator_design.physics import magnetic_composite as magnetics
from actuator_design.physics.magnetic_composite import (
    ModelAssumptionWarning,
    check_assumptions,
    demagnetising_factors,
    effective_susceptibilities,
    particle_susceptibilities,
)

RATIOS = [1.0, 1 + 1e-12, 1 + 1e-8, 1.001, 1.2, 1.4, 1.5, 2.0, 3.0, 5.0, 10.0, 50.0, 1e3, 1e4, 1e6, 1e12]


def quad_n_par(r):
    """N_a = (a b c / 2) ∫_0^∞ ds / ((s + a²) √((s+a²)(s+b²)(s+c²))), a = r, b = c = 1.

    Substituting s = exp(u) − 1 and splitting at s = a² resolves both scales s ~ 1 and s ~ r².
    """
    a2 = r * r

    def integrand(u):
        s = np.expm1(u)
        return np.exp(u) / ((s + a2) * np.sqrt((s + a2) * (s + 1.0) * (s + 1.0)))

    u1 = math.log1p(a2)
    opts = dict(epsabs=0.0, epsrel=1e-13, limit=200)
    total = quad(integrand, 0.0, u1, **opts)[0] + quad(integrand, u1, u1 + 80.0, **opts)[0]
    return r / 2.0 * total


def decimal_n_par(r, digits=60):
    """Closed form N∥ = (1 − e²)/e³ (artanh e − e) in 60-digit decimal arithmetic (r > 1)."""
    getcontext().prec = digits
    rd = Decimal(r)  # exact value of the float
    e2 = 1 - 1 / (rd * rd)
    e = e2.sqrt()
    artanh = ((1 + e) / (1 - e)).ln() / 2
    return float((1 - e2) / (e2 * e) * (artanh - e))


# ---------------------------------------------------------------- demagnetising factors
@pytest.mark.parametrize("r", RATIOS)
def test_factors_sum_to_one(r):
    n_par, n_perp = demagnetising_factors(r)
    assert n_par + 2 * n_perp == pytest.approx(1.0, rel=1e-15, abs=0)
    assert 0 < n_par <= 1 / 3 <= n_perp <= 0.5 or (r == 1.0 and n_perp == n_par)


def test_sphere_is_exactly_one_third():
    n_par, n_perp = demagnetising_factors(1.0)
    assert n_par == 1 / 3 and n_perp == 1 / 3


def test_near_sphere_first_order_expansion():
    # N∥ = 1/3 − (4/15)(r − 1) + O((r − 1)²), N⊥ = 1/3 + (2/15)(r − 1) + O((r − 1)²)
    for d in (1e-12, 1e-9):
        n_par, n_perp = demagnetising_factors(1.0 + d)
        assert n_par == pytest.approx(1 / 3 - 4 / 15 * d, rel=1e-14)
        assert n_perp == pytest.approx(1 / 3 + 2 / 15 * d, rel=1e-14)


@pytest.mark.parametrize("r", [1.0, 1.001, 1.5, 2.0, 5.0, 50.0, 1e4])
def test_against_ellipsoid_integral(r):
    n_par, n_perp = demagnetising_factors(r)
    assert n_par == pytest.approx(quad_n_par(r), rel=1e-10)
    # N⊥ from the same integral with the roles of the axes swapped: a = b = 1 (across), c = r
    def integrand_perp(u):
        s = np.expm1(u)
        return np.exp(u) / ((s + 1.0) * np.sqrt((s + 1.0) * (s + 1.0) * (s + r * r)))

    u1 = math.log1p(r * r)
    opts = dict(epsabs=0.0, epsrel=1e-13, limit=200)
    ref_perp = r / 2 * (quad(integrand_perp, 0, u1, **opts)[0] + quad(integrand_perp, u1, u1 + 80, **opts)[0])
    assert n_perp == pytest.approx(ref_perp, rel=1e-10)


@pytest.mark.parametrize("r", [1 + 1e-12, 1 + 1e-6, 1.01, 1.3, 1.41, 1.42, 1.6, 3.0, 30.0, 1e5, 1e9, 1e12])
def test_against_high_precision_closed_form(r):
    n_par, _ = demagnetising_factors(r)
    assert n_par == pytest.approx(decimal_n_par(r), rel=2e-14)


def test_continuity_and_monotonicity_at_series_switch():
    r_switch = 1.0 / math.sqrt(1.0 - magnetics._SWITCH_E2)  # where e² reaches the switch value
    r = r_switch * (1.0 + 1e-10 * np.arange(-20, 21))
    n_par, n_perp = demagnetising_factors(r)
    e2 = 1 - 1 / r**2
    assert np.any(e2 < magnetics._SWITCH_E2) and np.any(e2 > magnetics._SWITCH_E2)  # both branches used
    assert np.all(np.diff(n_par) < 0) and np.all(np.diff(n_perp) > 0)
    # equal steps in r give equal steps in N (curvature is negligible here): the step across the
    # switch differs from the others only by rounding, i.e. the two branches agree to ~1e-14
    steps = np.diff(n_par)
    np.testing.assert_allclose(steps, np.median(steps), rtol=0, atol=1e-14 * n_par[20])
    np.testing.assert_allclose(n_par, [decimal_n_par(x) for x in r], rtol=1e-14, atol=0)


def test_monotone_decreasing_over_wide_range():
    r = np.geomspace(1.0, 1e12, 400)
    n_par, n_perp = demagnetising_factors(r)
    assert n_par.shape == r.shape
    assert np.all(np.diff(n_par) < 0) and np.all(np.diff(n_perp) >= 0)  # N⊥ rounds to 0.5 at huge r


def test_slender_asymptote_and_no_overflow():
    r = 1e6
    n_par, _ = demagnetising_factors(r)
    assert n_par == pytest.approx((math.log(2 * r) - 1) / r**2, rel=1e-5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow / invalid-value RuntimeWarning
        n_par, n_perp = demagnetising_factors(1e12)
    assert np.isfinite(n_par) and np.isfinite(n_perp) and n_par > 0
    assert n_par == pytest.approx((math.log(2e12) - 1) / 1e24, rel=1e-10)
    assert n_perp == pytest.approx(0.5, rel=1e-15)


def test_scalar_and_array_inputs():
    n_par, n_perp = demagnetising_factors(2.0)
    assert np.ndim(n_par) == 0 and np.ndim(n_perp) == 0
    arr = np.array([[1.0, 2.0], [5.0, 1e4]])
    a_par, a_perp = demagnetising_factors(arr)
    assert a_par.shape == (2, 2) and a_perp.shape == (2, 2)
    for i in np.ndindex(arr.shape):
        assert a_par[i] == pytest.approx(quad_n_par(arr[i]), rel=1e-10)


@pytest.mark.parametrize("bad", [0.5, 0.0, -2.0, float("nan"), float("inf"), [2.0, 0.9]])
def test_invalid_axis_ratio(bad):
    with pytest.raises(ValueError, match="axis_ratio") as info:
        demagnetising_factors(bad)
    assert ">= 1" in str(info.value)


# ---------------------------------------------------------------- susceptibilities
def test_isotropic_sphere_has_no_orientational_coupling():
    for c in (0.1, 1.0, 7.5, 1e6, float("inf")):
        chi, chi_tilde = particle_susceptibilities(c, c, 1.0)
        assert chi == 0.0  # exactly (THEORY §2)
        assert chi_tilde == pytest.approx(1 / (1 / c + 1 / 3), rel=1e-15)


@pytest.mark.parametrize("r", [1.001, 1.5, 3.0, 50.0, 1e6])
@pytest.mark.parametrize("c", [0.5, 10.0, float("inf")])
def test_elongated_isotropic_particles_align(r, c):
    chi, chi_tilde = particle_susceptibilities(c, c, r)
    assert chi > 0 and chi_tilde > 0


def test_hand_computed_sphere_values():
    # χ∥ = 2, χ⊥ = 1, r = 1: χ = (1/2 + 1/3)⁻¹ − (1 + 1/3)⁻¹ = 6/5 − 3/4 = 9/20, χ̃ = 3/4
    chi, chi_tilde = particle_susceptibilities(2.0, 1.0, 1.0)
    assert chi == pytest.approx(0.45, rel=1e-15)
    assert chi_tilde == pytest.approx(0.75, rel=1e-15)
    chi_bar, chi_hat = effective_susceptibilities(2.0, 1.0, 1.0, 0.05)
    assert chi_bar == pytest.approx(0.05 * 0.45, rel=1e-15)
    assert chi_hat == pytest.approx(0.05 * 0.75, rel=1e-15)


def test_ideal_soft_magnetic_sphere():
    chi, chi_tilde = particle_susceptibilities(float("inf"), float("inf"), 1.0)
    assert chi_tilde == 3.0 and chi == 0.0


def test_ideal_soft_magnetic_elongated_matches_integral():
    # χ → ∞: χ = 1/N∥ − 1/N⊥ with N from the ellipsoid integral, N⊥ = (1 − N∥)/2
    r = 5.0
    n_ref = quad_n_par(r)
    chi, chi_tilde = particle_susceptibilities(np.inf, np.inf, r)
    assert chi == pytest.approx(1 / n_ref - 2 / (1 - n_ref), rel=1e-10)
    assert chi_tilde == pytest.approx(2 / (1 - n_ref), rel=1e-10)


def test_large_finite_chi_approaches_soft_limit():
    chi_inf, tilde_inf = particle_susceptibilities(np.inf, np.inf, 2.0)
    chi_big, tilde_big = particle_susceptibilities(1e12, 1e12, 2.0)
    assert chi_big == pytest.approx(chi_inf, rel=1e-10)
    assert tilde_big == pytest.approx(tilde_inf, rel=1e-10)


def test_susceptibilities_broadcast_arrays():
    r = np.array([1.0, 2.0, 5.0])
    chi, chi_tilde = particle_susceptibilities(3.0, 3.0, r)
    assert chi.shape == (3,) and chi[0] == 0.0 and np.all(chi[1:] > 0)


@pytest.mark.parametrize("name, args", [
    ("chi_par", (-1.0, 1.0, 2.0)),
    ("chi_par", (0.0, 1.0, 2.0)),
    ("chi_par", (float("nan"), 1.0, 2.0)),
    ("chi_perp", (1.0, -0.3, 2.0)),
    ("chi_perp", (1.0, [1.0, -1.0], 2.0)),
    ("axis_ratio", (1.0, 1.0, 0.5)),
])
def test_invalid_susceptibility_inputs(name, args):
    with pytest.raises(ValueError, match=name):
        particle_susceptibilities(*args)


@pytest.mark.parametrize("nu", [0.0, 1.0, -0.1, 1.5, float("nan")])
def test_invalid_volume_fraction(nu):
    with pytest.raises(ValueError, match="volume_fraction"):
        effective_susceptibilities(1.0, 1.0, 2.0, nu)


# ---------------------------------------------------------------- model assumptions
def test_dense_particles_warn():
    with pytest.warns(ModelAssumptionWarning, match=r"volume_fraction = 0\.3.*0\.1"):
        messages = check_assumptions(volume_fraction=0.3)
    assert len(messages) == 1 and "interactions" in messages[0]


def test_custom_dilute_limit():
    with pytest.warns(ModelAssumptionWarning, match="0.05"):
        check_assumptions(volume_fraction=0.08, dilute_limit=0.05)


def test_saturated_field_warns_with_units():
    with pytest.warns(ModelAssumptionWarning) as record:
        messages = check_assumptions(field=5e4, saturation_field=2e4)
    assert len(record) == 1 and len(messages) == 1
    msg = messages[0]
    assert "field = 50000 A/m" in msg and "saturation_field = 20000 A/m" in msg and "linear" in msg


def test_both_violations_reported():
    with pytest.warns(ModelAssumptionWarning) as record:
        messages = check_assumptions(volume_fraction=0.2, field=-3e5, saturation_field=1e5)
    assert len(messages) == 2 and len(record) == 2


def test_no_warning_inside_assumptions():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_assumptions(volume_fraction=0.05, field=1e4, saturation_field=2e4) == []
        assert check_assumptions(volume_fraction=0.1) == []  # the limit itself is allowed
        assert check_assumptions(field=1e9) == []  # no saturation field given: nothing to check
        assert check_assumptions() == []
