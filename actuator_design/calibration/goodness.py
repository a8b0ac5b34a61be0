"""Does the fitted model explain the data? The χ² test of the residuals, and parameters at bounds.

With the uncertainty σ of every measured column given, the weighted residuals of a model that
explains the data are standard normal, and χ² = Σ w_i (r_i/σ)² follows the χ² distribution with
m − k degrees of freedom (m residuals, k fitted parameters). The fit fails the test when
P(χ²_{m−k} ≥ χ²) < ``min_p_value`` (:data:`actuator_design.config.studies.fit.DEFAULT_MIN_P_VALUE`; see :mod:`.limits`).
Without given uncertainties σ is estimated from the residuals themselves and the test cannot be
made (it is reported as not tested).

A fitted parameter that ends on one of its bounds is an optimum of the bounded problem only: the
data pull it further, so the fit is not a success either.
"""
from __future__ import annotations

import math

from typing import Dict, List, Optional

import numpy as np
import scipy.stats

__all__ = ["chi_square_test", "bound_failures", "chi_square_message", "bound_message"]


def chi_square_test(r: np.ndarray, n_fitted: int, sigma_given: bool,
                    min_p_value: float) -> Dict[str, object]:
    """The χ² goodness-of-fit test of the weighted residuals ``r`` (in units of σ).

    Parameters
    ----------
    r : ndarray, shape (m,)
        Weighted residuals √w (model − data)/σ.
    n_fitted : int
        Number of fitted parameters k.
    sigma_given : bool
        Every measured column's σ was given (else the test is not made).
    min_p_value : float
        Smallest accepted probability of a χ² at least this large for a model that explains the
        data.

    Returns
    -------
    dict
        ``tested``, ``passed`` (None when not tested), ``chi2``, ``dof``, ``chi2_reduced``,
        ``p_value``, ``min_p_value``, ``threshold`` (the largest accepted reduced χ²), ``rule``
        and, when not tested, ``reason``.
    """
    m = int(r.size)
    dof = m - int(n_fitted)
    chi2 = float(r @ r)
    out: Dict[str, object] = {
        "tested": False, "passed": None, "chi2": chi2, "dof": dof,
        "chi2_reduced": chi2 / dof if dof > 0 else None, "p_value": None,
        "min_p_value": float(min_p_value), "threshold": None,
        "rule": "fails when P(chi2 with dof degrees of freedom >= chi2) < min_p_value, with the "
                "residuals weighted by the given uncertainties (study.uncertainty)"}
    if not sigma_given:
        out["reason"] = ("no uncertainty given for every measured column (study.uncertainty): "
                         "the scatter is estimated from the residuals themselves")
        return out
    if dof <= 0:
        out["reason"] = f"no residual degrees of freedom ({m} residuals, {n_fitted} parameters)"
        return out
    p_value = float(scipy.stats.chi2.sf(chi2, dof))
    out.update(tested=True, passed=bool(p_value >= min_p_value), p_value=p_value,
               threshold=float(scipy.stats.chi2.isf(min_p_value, dof) / dof))
    return out


def chi_square_message(test: Dict[str, object], rms: Dict[str, float], units: Dict[str, str],
                       sigma: Dict[str, float], hint: Optional[str] = None) -> str:
    """One clause for the fit's message: the model does not explain the data, by how much."""
    scatter = ", ".join(f"{o} rms {v:.4g} {units[o]} against σ = {sigma[o]:.4g} {units[o]}"
                        .replace("  ", " ") for o, v in rms.items())
    text = (f"the model does not explain the data: reduced chi-square {test['chi2_reduced']:.4g} "
            f"over {test['dof']} degrees of freedom, above {test['threshold']:.4g} (p = "
            f"{test['p_value']:.3g} < {test['min_p_value']:g}; {scatter}); check the units in the "
            "data header, the stated uncertainties, the parameter bounds and the scene")
    return text + (f" ({hint})" if hint else "")


def bound_failures(params: Dict[str, dict]) -> List[dict]:
    """The fitted parameters that end on a bound: [{"name", "side", "bound", "value", "unit"}]."""
    out = []
    for name, p in params.items():
        if p["fitted"] and p.get("at_bound"):
            side = p.get("bound_side") or "lower"
            bound = p["bounds"][0 if side == "lower" else 1]
            out.append({"name": name, "side": side, "bound": bound, "value": p["value"],
                        "unit": p["unit"]})
    return out


def bound_message(failures: List[dict]) -> str:
    """One clause for the fit's message naming each parameter at a bound and which bound."""
    def shown(v, unit):  # angles also in degrees, the unit configs give them in (as the report)
        text = f"{v:.6g}{(' ' + unit) if unit else ''}"
        return text + (f" ({math.degrees(v):.6g} deg)" if unit == "rad" else "")

    parts = [f"{f['name']} = {shown(f['value'], f['unit'])} is at its {f['side']} bound "
             f"{shown(f['bound'], f['unit'])}" for f in failures]
    return ("at a bound: " + "; ".join(parts) + " (the data pull beyond it: the interval is not "
            "valid; widen the bounds or check the data and the scene)")
