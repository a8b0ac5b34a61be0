"""Identifiability: which combinations of parameters the data determine.

When the column-normalised weighted Jacobian J has a singular value below ``identifiability_tol``
times the largest, a combination of parameters is not determined by the data (e.g. a field-only
data set determines χ̄ and E only through h² ∝ χ̄/E, THEORY §5; a hard-magnetic rod's M_r and E only
through h_r ∝ M_r/E, THEORY §9). The fit then holds the parameter
the null direction leans on most at its initial value, fits the others, and reports the
identifiable combination (e.g. ``chi_bar * youngs_modulus^-1``): for log-scale parameters p_i, p_j and null
direction v (in log coordinates), p_i · p_j^(−v_i/v_j) is constant along v.
"""
from __future__ import annotations

from typing import List

import numpy as np

from actuator_design.model.units import registry
from actuator_design.calibration.parameters import PARAMETERS, unit_of
from actuator_design.physics.magnetics_block import MagneticSummary

__all__ = ["null_direction", "choose_held", "identifiability_message", "combinations",
           "combination_value", "ZERO_SENSITIVITY"]

#: A column of the weighted Jacobian (residuals in units of σ per unit of the fitted coordinate:
#: log p, or p for linear parameters) with rms below this carries no information: an e-fold change
#: of the parameter moves the residuals by less than this many σ. Rounding noise of an exactly
#: zero sensitivity (e.g. a straight rod in a transverse field, THEORY §6) is far below it.
ZERO_SENSITIVITY = 1e-9




def null_direction(J: np.ndarray, tol: float):
    """A direction in the fitted coordinates that the data do not determine, or None.

    Parameters
    ----------
    J : ndarray, shape (m, k)
        Weighted Jacobian of the residuals with respect to the free fitted coordinates.
    tol : float
        Relative singular value (of the column-normalised J) below which a direction is null.

    Returns
    -------
    (vec, rel, colnorm) or None
        ``vec``: unit null vector, shape (k,); ``rel``: its relative singular value (0 for a
        column without information, then ``vec`` selects the last such column); ``colnorm``:
        column norms, shape (k,), with columns without information set to 0.
    """
    if J.shape[1] == 0:
        return None
    colnorm = np.linalg.norm(J, axis=0)
    zero = colnorm <= ZERO_SENSITIVITY * np.sqrt(max(J.shape[0], 1))
    if np.any(zero):
        v = np.zeros(J.shape[1])
        v[np.flatnonzero(zero)[-1]] = 1.0
        return v, 0.0, np.where(zero, 0.0, colnorm)
    _, s, Vt = np.linalg.svd(J / colnorm, full_matrices=False)
    rel = s[-1] / s[0]
    if rel >= tol:
        return None
    return Vt[-1] / colnorm / np.linalg.norm(Vt[-1] / colnorm), float(rel), colnorm


def choose_held(vec: np.ndarray, colnorm: np.ndarray) -> int:
    """Index (among free) of the parameter to hold: the last with a leading null component."""
    weight = np.abs(vec) * np.where(colnorm > 0, colnorm, 1.0)
    big = np.flatnonzero(weight >= 0.5 * weight.max())
    return int(big[-1])


def identifiability_message(names, free, vec, j, rel, is_log, problem,
                            combined: bool = True) -> str:
    """One line: which parameters the null direction ``vec`` involves, and which one is held."""
    big = np.abs(vec) > 1e-6 * np.max(np.abs(vec))
    involved = [names[free[a]] for a in range(len(free)) if big[a]]
    if len(involved) == 1:
        what = f"the data carry no information on {involved[0]}"
    else:
        what = (f"{' and '.join(involved)} are not identifiable separately from these data "
                f"(relative singular value {rel:.1e}")
        for slot, text in MagneticSummary.POWER_LAWS.items():  # power laws on one field group (lens exponents)
            if all(PARAMETERS[n].exponent(slot) for n in involved):
                what += f"; they enter only through the field group {text}"
                break
        what += ")"
    held = f"{names[j]} is held at {problem.initial[names[j]]:g} {unit_of(names[j])}".rstrip()
    if not combined:
        return f"{what}: {held}"
    return f"{what}: {held} and the identifiable combination is fitted"


def combinations(names, free, vec, j, is_log, theta) -> List[dict]:
    """Combinations invariant along the null direction, one per free parameter involved."""
    a_j = free.index(j)
    out = []
    for a, i in enumerate(free):
        if i == j or abs(vec[a]) <= 1e-6 * np.max(np.abs(vec)):
            continue
        if not (is_log[i] and is_log[j]):
            continue  # linear mixtures are reported in the warning only
        expo = -vec[a] / vec[a_j]
        e = round(expo * 6) / 6 if abs(expo * 6 - round(expo * 6)) < 1e-3 else expo
        e_txt = f"{e:g}" if float(e).is_integer() else f"{e:.4g}"
        unit = combined_unit(unit_of(names[i]), unit_of(names[j]), e)
        out.append({"name": f"{names[i]} * {names[j]}^{e_txt}", "parameters": [names[i], names[j]],
                    "exponents": [1.0, float(e)], "unit": unit, "_free": i})
    return out


def combined_unit(u1: str, u2: str, e: float) -> str:
    """Unit of u1 · u2^e, for display."""
    try:
        ureg = registry()
        u = ureg.Unit(u1 or "dimensionless") * ureg.Unit(u2 or "dimensionless") ** e
        return "" if u.dimensionless else f"{u:~P}"
    except Exception:  # noqa: BLE001 - a unit string for display only
        return f"{u1} {u2}^{e:g}".strip()


def combination_value(c: dict, params: dict) -> float:
    """Value of combination ``c`` at the parameter values ``params`` (name → {"value": …})."""
    (n1, n2), (e1, e2) = c["parameters"], c["exponents"]
    return params[n1]["value"] ** e1 * params[n2]["value"] ** e2
