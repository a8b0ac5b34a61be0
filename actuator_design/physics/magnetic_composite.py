"""Particle magnetics of the magneto-elastic composite (THEORY §2).

The particles are prolate spheroids (axis ratio r = a/b >= 1) of a linear, unsaturated,
paramagnetic or soft-magnetic material, embedded dilutely in an elastic matrix. This module gives

* the demagnetising factors N∥, N⊥ of the spheroid,
* the particle susceptibilities χ (orientational, anisotropic part) and χ̃ (isotropic part),
* the effective composite susceptibilities χ̄ = ν χ and χ̂ = ν χ̃,
* a check that warns (:class:`ModelAssumptionWarning`) when a scene leaves the model's assumptions,
* the body's own shape anisotropy (THEORY §10): the composite tensor combined with the demagnetisation
  of the rod's cross-section, and the check of the magnetisation against saturation (THEORY §11),
* presets of common fillers (:data:`MATERIALS`; their sources are listed with them).

All susceptibilities and demagnetising factors are dimensionless (SI); fields are in A/m.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Dict, Optional

import numpy as np

__all__ = [
    "demagnetising_factors",
    "particle_susceptibilities",
    "effective_susceptibilities",
    "ModelAssumptionWarning",
    "check_assumptions",
    "composite_tensor",
    "transverse_demagnetizing_factor",
    "BodySusceptibility",
    "body_susceptibility",
    "check_saturation",
    "Material",
    "MATERIALS",
    "material",
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


# -- THEORY §10: the body's own shape anisotropy ------------------------------------------------------
def composite_tensor(chi_par, chi_perp, axis_ratio, volume_fraction) -> np.ndarray:
    """Composite susceptibility tensor in the fibre frame (THEORY §10), shape (2, 2).

    χ_c = ν diag((1/χ∥ + N∥)⁻¹, (1/χ⊥ + N⊥)⁻¹) (along, across the particle axis), dimensionless:
    diag(χ̄ + χ̂, χ̂) of :func:`effective_susceptibilities`.
    """
    chi_bar, chi_hat = effective_susceptibilities(chi_par, chi_perp, axis_ratio, volume_fraction)
    return np.diag([float(chi_bar) + float(chi_hat), float(chi_hat)])


def transverse_demagnetizing_factor(width: float, thickness: float) -> float:
    """N_t = w/(w + t) of a rectangular section in the bending plane (THEORY §10).

    Elliptic-cylinder approximation: ``width`` w out of the bending plane, ``thickness`` t in it
    (both in m, > 0). A wide thin strip (w ≫ t) has N_t → 1.
    """
    w, t = float(width), float(thickness)
    if not (w > 0 and t > 0 and math.isfinite(w) and math.isfinite(t)):
        raise ValueError(f"width and thickness must be finite and > 0, got {width!r}, {thickness!r}")
    return w / (w + t)


@dataclass(frozen=True)
class BodySusceptibility:
    """The body's effective susceptibility χ_eff = χ_c (I + N χ_c)⁻¹ (THEORY §10).

    Attributes
    ----------
    tensor : ndarray, shape (2, 2)
        χ_eff in the rod frame (tangent, in-plane normal), symmetric, dimensionless.
    chi_bar : float
        λ_max − λ_min: the orientational susceptibility of THEORY §4.
    chi_hat : float
        λ_min: the isotropic part.
    fibre_angle : float
        Angle of the eigenvector of λ_max to the tangent, rad, in (−π/2, π/2] (the effective fibre
        angle; the given fibre angle when χ_eff is isotropic).
    demagnetizing_factor : float
        N_t used (the axial factor is 0, a slender rod).
    """

    tensor: np.ndarray
    chi_bar: float
    chi_hat: float
    fibre_angle: float
    demagnetizing_factor: float

    @property
    def chi_max(self) -> float:
        """λ_max = χ̄ + χ̂: the largest magnetisation per unit field, |M| ≤ λ_max |H|."""
        return self.chi_bar + self.chi_hat


def body_susceptibility(chi_fibre_frame, fibre_angle: float, demagnetizing_factor: float) -> BodySusceptibility:
    """Combine the composite tensor with the demagnetisation of the body (THEORY §10).

    Parameters
    ----------
    chi_fibre_frame : array_like, shape (2, 2)
        χ_c in the fibre frame (:func:`composite_tensor`), dimensionless, symmetric positive
        semi-definite.
    fibre_angle : float
        α, rad: the fibre frame is rotated by α from the rod frame.
    demagnetizing_factor : float
        N_t ∈ [0, 1] across the rod in the bending plane; N = diag(0, N_t).

    Returns
    -------
    BodySusceptibility
    """
    n_t = float(demagnetizing_factor)
    if not 0.0 <= n_t <= 1.0:
        raise ValueError(f"demagnetizing_factor must be in [0, 1], got {demagnetizing_factor!r}")
    c, s = math.cos(fibre_angle), math.sin(fibre_angle)
    rot = np.array([[c, -s], [s, c]])
    chi_c = rot @ np.asarray(chi_fibre_frame, float) @ rot.T
    n = np.diag([0.0, n_t])
    chi_eff = chi_c @ np.linalg.inv(np.eye(2) + n @ chi_c)
    chi_eff = 0.5 * (chi_eff + chi_eff.T)  # symmetric in exact arithmetic: remove round-off
    lam, vec = np.linalg.eigh(chi_eff)
    lo, hi = float(lam[0]), float(lam[1])
    if hi - lo <= 1e-14 * max(abs(hi), 1e-300):
        angle = float(fibre_angle)
    else:
        v = vec[:, 1]
        angle = math.atan2(v[1], v[0])
        if angle <= -0.5 * math.pi:
            angle += math.pi
        elif angle > 0.5 * math.pi:
            angle -= math.pi
    return BodySusceptibility(chi_eff, max(hi - lo, 0.0), lo, angle, n_t)


# -- THEORY §11: saturation ------------------------------------------------------------------------
def check_saturation(chi_max: float, field: float, volume_fraction: float, saturation_magnetization: float,
                     what: str = "filler"):
    """Warn when the linear magnetisation |χ_eff H| ≤ χ_max H exceeds the saturation ν M_s.

    Parameters
    ----------
    chi_max : float
        Largest eigenvalue of χ_eff (dimensionless).
    field : float
        Largest applied field magnitude on the rod, A/m.
    volume_fraction : float
        ν, dimensionless.
    saturation_magnetization : float
        M_s of the filler, A/m.
    what : str
        Name of the filler for the message.

    Returns
    -------
    str or None
        The message (also issued as a :class:`ModelAssumptionWarning`), or None.
    """
    m_lin = float(chi_max) * float(field)
    m_sat = float(volume_fraction) * float(saturation_magnetization)
    if not m_lin > m_sat:
        return None
    msg = (f"magnetisation |chi_eff H| = {m_lin:.4g} A/m exceeds the saturation of the composite "
           f"nu M_s = {m_sat:.4g} A/m ({what}): the linear law overestimates the coupling (THEORY §11)")
    warnings.warn(msg, ModelAssumptionWarning, stacklevel=2)
    return msg


# -- filler presets ---------------------------------------------------------------------------------
# Material presets for common magnetic fillers (THEORY §2, §9, §11).
#
# Each preset gives the filler's intrinsic (particle) susceptibility, its saturation magnetisation
# M_s and, for hard magnets, its remanent magnetisation M_r, all per unit volume of the *particle*
# (SI: dimensionless and A/m). The composite's values follow with the volume fraction ν (THEORY §2:
# χ̄ = ν χ, saturation ν M_s; §9: M_r,composite = ν M_r). The values are typical room-temperature
# handbook values; a supplier's datasheet for the actual powder is better, and overrides them
# (give ``chi_par``/``chi_perp``/``saturation_magnetization`` next to ``material``).
#
# Sources
# -------
# * iron (carbonyl iron powder, ≥ 97 % Fe): μ0 M_s = 2.15 T, M_s = 1.71 MA/m — J. M. D. Coey,
#   *Magnetism and Magnetic Materials*, Cambridge University Press (2010), table 8.1 (Fe);
#   intrinsic susceptibility of soft iron ≫ 100 (taken as 1000: any value ≫ 1/N gives the
#   shape-limited particle response 1/N, THEORY §2) — Jolly, Carlson & Muñoz, Smart Mater. Struct.
#   5, 607 (1996), who model carbonyl-iron MR elastomers this way.
# * magnetite (Fe3O4): M_s = 0.48 MA/m — Coey (2010), table 11.2; initial susceptibility of
#   multidomain magnetite ≈ 3 (SI, volume) — Dunlop & Özdemir, *Rock Magnetism*, Cambridge (1997),
#   §5.
# * NdFeB (isotropic melt-spun powder, e.g. Magnequench MQFP-B, the filler of Kim et al., Nature 558,
#   274 (2018)): remanence B_r ≈ 0.9 T, M_r ≈ 0.72 MA/m — Magnequench MQFP-B datasheet;
#   μ0 M_s = 1.61 T, M_s = 1.28 MA/m (Nd2Fe14B) — Coey (2010), table 11.4. Susceptibility about the
#   remanent state (recoil permeability ≈ 1.05–1.2): χ ≈ 0.1, small: the hard rod's coupling is the
#   remanent torque of THEORY §9.

@dataclass(frozen=True)
class Material:
    """A magnetic filler (per unit volume of particle material).

    Attributes
    ----------
    name : str
    susceptibility : float
        Intrinsic (isotropic) susceptibility χ of the particle material, dimensionless.
    saturation_magnetization : float
        M_s, A/m.
    remanence : float or None
        M_r, A/m, for hard magnets (None for soft ones).
    source : str
        Where the values come from (see the comment above the presets).
    """

    name: str
    susceptibility: float
    saturation_magnetization: float
    remanence: Optional[float] = None
    source: str = ""


MATERIALS: Dict[str, Material] = {
    "carbonyl_iron": Material("carbonyl iron", 1000.0, 1.71e6, None,
                              "Coey 2010 table 8.1 (Fe); Jolly et al. 1996"),
    "magnetite": Material("magnetite", 3.0, 4.8e5, None,
                          "Coey 2010 table 11.2; Dunlop & Ozdemir 1997 §5"),
    "ndfeb": Material("NdFeB (MQFP-B)", 0.1, 1.28e6, 7.2e5,
                      "Magnequench MQFP-B datasheet; Coey 2010 table 11.4; Kim et al. 2018"),
}


def material(name: str) -> Material:
    """The preset ``name``; ValueError listing the presets otherwise."""
    try:
        return MATERIALS[name]
    except KeyError:
        raise ValueError(f"unknown material {name!r} (allowed: {', '.join(MATERIALS)})") from None
