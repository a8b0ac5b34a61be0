"""Particle magnetics of the magneto-elastic composite (THEORY §2).

The particles are prolate spheroids (axis ratio r = a/b >= 1) of a linear, unsaturated,
paramagnetic or soft-magnetic material, embedded dilutely in an elastic matrix. This module gives

* the demagnetising factors N∥, N⊥ of the spheroid,
* the particle susceptibilities χ (orientational, anisotropic part) and χ̃ (isotropic part),
* the effective composite susceptibilities χ̄ = ν χ and χ̂ = ν χ̃,
* a check that warns (:class:`ModelAssumptionWarning`) when a scene leaves the model's assumptions.

All susceptibilities and demagnetising factors are dimensionless (SI); fields are in A/m.
"""
from __future__ import annotations

import warnings

import numpy as np

__all__ = [
    "demagnetising_factors",
    "particle_susceptibilities",
    "effective_susceptibilities",
    "ModelAssumptionWarning",
    "check_assumptions",
]

# Below this value of e² the sphere series is used, above it the closed form (THEORY §2).
# At e² = 0.5 the closed form loses ~6 ulp to cancellation in artanh(e) − e, and the series
# (terms ~ x^k / (4k²)) is below 1e-18 after _SERIES_TERMS terms.
_SWITCH_E2 = 0.5
_SERIES_TERMS = 50
_K = np.arange(1, _SERIES_TERMS + 1, dtype=float)
# δ(x) = N∥ − 1/3 = Σ_{k≥1} c_k x^k with c_k = −2/((2k+1)(2k+3)), x = e²; highest power first.
_DELTA_COEFFS = (-2.0 / ((2 * _K + 1) * (2 * _K + 3)))[::-1]
_THIRD = 1.0 / 3.0


def _as_float_array(value, name):
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number or array of real numbers, got {value!r}") from None


def _scalar_or_array(x):
    return x[()] if x.ndim == 0 else x


def demagnetising_factors(axis_ratio):
    """Demagnetising factors of a prolate spheroid (THEORY §2).

    Parameters
    ----------
    axis_ratio : float or array_like
        Axis ratio r = a/b >= 1 of the spheroid (long semi-axis a over short semi-axis b),
        dimensionless, finite. r = 1 is a sphere.

    Returns
    -------
    N_par, N_perp : float or ndarray
        Demagnetising factors along and across the long axis (dimensionless, N∥ + 2 N⊥ = 1).
        Scalars for scalar input, arrays of the input shape otherwise.

    Raises
    ------
    ValueError
        If any ``axis_ratio`` is < 1, NaN or infinite.

    Notes
    -----
    With e = √(1 − 1/r²) (THEORY §2), N∥ = (1 − e²)/e³ · (artanh e − e), N⊥ = (1 − N∥)/2.

    * Near the sphere (e² < 0.5) the closed form cancels catastrophically; there
      (1 − e²)/e³ (artanh e − e) = (1 − e²) Σ_{k≥1} e^{2k−2}/(2k+1), which rearranges to
      N∥ = 1/3 + δ, N⊥ = 1/3 − δ/2 with δ = −2 Σ_{k≥1} e^{2k}/((2k+1)(2k+3)).
      At r = 1 both are exactly the float 1/3.
    * Otherwise the closed form with artanh e = ½ ln((1+e)/(1−e)) = ln((1+e) r)
      (since 1 − e = (1/r²)/(1+e)), which stays finite as r → ∞.
    """
    r = _as_float_array(axis_ratio, "axis_ratio")
    if not np.all(np.isfinite(r) & (r >= 1.0)):
        raise ValueError(
            f"axis_ratio must be finite and >= 1 (prolate spheroid, r = a/b in [1, inf)), got {axis_ratio!r}"
        )
    q = 1.0 / r
    # e² = 1 − 1/r² = ((r − 1)/r)((r + 1)/r): exact-ish near r = 1, no overflow for large r.
    e2 = ((r - 1.0) * q) * ((r + 1.0) * q)
    n_par = np.empty_like(r)
    n_perp = np.empty_like(r)

    near = e2 < _SWITCH_E2
    delta = np.polyval(_DELTA_COEFFS, e2[near]) * e2[near]  # series in e² (THEORY §2, r → 1)
    n_par[near] = _THIRD + delta
    n_perp[near] = _THIRD - 0.5 * delta

    far = ~near
    e = np.sqrt(e2[far])
    artanh_e = np.log((1.0 + e) * r[far])  # = artanh(e), stable for e → 1
    qf = q[far]
    n_par[far] = qf * (qf * (artanh_e - e)) / e**3  # (1 − e²) = 1/r²
    n_perp[far] = 0.5 * (1.0 - n_par[far])
    return _scalar_or_array(n_par), _scalar_or_array(n_perp)


def _check_positive(value, name):
    x = _as_float_array(value, name)
    if not np.all(x > 0):  # NaN fails too; +inf (ideal soft magnet) is allowed
        raise ValueError(
            f"{name} must be > 0 (paramagnetic/soft-magnetic particle model; inf allowed), got {value!r}"
        )
    return x


def particle_susceptibilities(chi_par, chi_perp, axis_ratio):
    """Particle susceptibilities χ and χ̃ (THEORY §2, paper eq. 2-13).

    Parameters
    ----------
    chi_par, chi_perp : float or array_like
        Intrinsic susceptibilities of the particle material along / across the particle axis,
        dimensionless, > 0. ``float('inf')`` models an ideal soft-magnetic particle.
    axis_ratio : float or array_like
        Axis ratio r = a/b >= 1 of the prolate spheroidal particle, dimensionless.

    Returns
    -------
    chi, chi_tilde : float or ndarray
        χ = (1/χ∥ + N∥)⁻¹ − (1/χ⊥ + N⊥)⁻¹ (orientational part; 0 for isotropic spheres) and
        χ̃ = (1/χ⊥ + N⊥)⁻¹ (isotropic part), both dimensionless.

    Raises
    ------
    ValueError
        If ``chi_par`` or ``chi_perp`` is not > 0 (or NaN), or ``axis_ratio`` is invalid.

    Notes
    -----
    For χ → ∞, 1/χ = 0 and (1/χ + N)⁻¹ → 1/N (shape-limited magnetisation).
    """
    cpar = _check_positive(chi_par, "chi_par")
    cperp = _check_positive(chi_perp, "chi_perp")
    n_par, n_perp = demagnetising_factors(axis_ratio)
    along = 1.0 / (1.0 / cpar + n_par)   # 1/inf = 0 gives the soft-magnetic limit 1/N∥
    chi_tilde = 1.0 / (1.0 / cperp + n_perp)
    chi = along - chi_tilde
    return _scalar_or_array(np.asarray(chi)), _scalar_or_array(np.asarray(chi_tilde))


def effective_susceptibilities(chi_par, chi_perp, axis_ratio, volume_fraction):
    """Effective composite susceptibilities χ̄ = ν χ and χ̂ = ν χ̃ (THEORY §2).

    Parameters
    ----------
    chi_par, chi_perp : float or array_like
        Particle material susceptibilities along / across the particle axis, dimensionless, > 0.
    axis_ratio : float or array_like
        Particle axis ratio r = a/b >= 1, dimensionless.
    volume_fraction : float or array_like
        Particle volume fraction ν, dimensionless, 0 < ν < 1.

    Returns
    -------
    chi_bar, chi_hat : float or ndarray
        χ̄ = ν χ and χ̂ = ν χ̃, dimensionless.

    Raises
    ------
    ValueError
        If ``volume_fraction`` is not in (0, 1), or another argument is invalid.
    """
    nu = _as_float_array(volume_fraction, "volume_fraction")
    if not np.all((nu > 0) & (nu < 1)):
        raise ValueError(f"volume_fraction must satisfy 0 < volume_fraction < 1, got {volume_fraction!r}")
    chi, chi_tilde = particle_susceptibilities(chi_par, chi_perp, axis_ratio)
    return _scalar_or_array(np.asarray(nu * chi)), _scalar_or_array(np.asarray(nu * chi_tilde))


class ModelAssumptionWarning(UserWarning):
    """A scene leaves an assumption of the magnetic model (THEORY §2)."""


def check_assumptions(volume_fraction=None, field=None, saturation_field=None, dilute_limit=0.1):
    """Warn when a scene leaves the assumptions of the particle model (THEORY §2).

    Parameters
    ----------
    volume_fraction : float or array_like, optional
        Particle volume fraction ν (dimensionless). Checked against ``dilute_limit``.
    field : float or array_like, optional
        Applied field magnitude H in A/m (the largest ``|field|`` is used).
    saturation_field : float, optional
        Field in A/m above which the particle magnetisation is no longer linear. The field check
        runs only when both ``field`` and ``saturation_field`` are given.
    dilute_limit : float, default 0.1
        Largest volume fraction (dimensionless) treated as dilute.

    Returns
    -------
    list of str
        One message per violated assumption (empty if none); each is also issued with
        ``warnings.warn(message, ModelAssumptionWarning)``.
    """
    messages = []
    if volume_fraction is not None:
        nu = float(np.max(_as_float_array(volume_fraction, "volume_fraction")))
        if nu > dilute_limit:
            messages.append(
                f"volume_fraction = {nu:g} (dimensionless) exceeds the dilute limit {dilute_limit:g}: "
                "the dilute model neglects particle interactions (error O(nu))"
            )
    if field is not None and saturation_field is not None:
        h = float(np.max(np.abs(_as_float_array(field, "field"))))
        if h > saturation_field:
            messages.append(
                f"field = {h:g} A/m exceeds saturation_field = {saturation_field:g} A/m: "
                "the linear (unsaturated) magnetisation assumption no longer holds"
            )
    for message in messages:
        warnings.warn(message, ModelAssumptionWarning, stacklevel=2)
    return messages
