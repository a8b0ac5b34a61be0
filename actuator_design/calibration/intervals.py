"""Confidence intervals of fitted parameters, identifiable combinations and derived quantities.

With weighted residuals r (m of them) and Jacobian J (in the fitted coordinates x: log p for
positive parameters, p otherwise) at the optimum, cov_x = s² (JᵀJ)⁻¹ with s² = |r|²/(m − k).
Intervals are t-intervals with m − k degrees of freedom, taken in x, so that those of positive
parameters stay positive: p·exp(±t σ_x).
"""
from __future__ import annotations

import math
from typing import Dict, List

import numpy as np

from actuator_design.calibration.identifiability import combination_value
from actuator_design.calibration.parameters import PARAMETERS, group_exponent, unit_of
from actuator_design.physics.parameters import field_groups
from actuator_design.physics.registry import term_class

__all__ = ["safe_exp", "parameter_entries", "combination_intervals", "natural_covariance",
           "derived_quantities"]


def safe_exp(x: float) -> float:
    """exp without OverflowError (an unbounded interval is +inf)."""
    with np.errstate(over="ignore"):
        return float(np.exp(x))


def parameter_entries(names, theta, initial, bounds, free, is_log, sd_x, tq,
                      active=None) -> Dict[str, dict]:
    """name → {"value", "unit", "initial", "bounds", "fitted", "scale", "description", "std",
    "ci", "at_bound", "bound_side"} in SI units; ``sd_x``: standard deviations of the free x,
    shape (k,); ``active``: the optimiser's active bounds of the free x (−1 lower, +1 upper,
    0 none), shape (k,), or None. ``bound_side`` is "lower", "upper" or None."""
    params = {}
    for i, n in enumerate(names):
        lo_b, hi_b = bounds[i]
        entry = {"value": float(theta[i]), "unit": unit_of(n), "initial": float(initial[n]),
                 "bounds": [float(lo_b), float(hi_b)], "fitted": i in free,
                 "scale": "log" if is_log[i] else "linear",
                 "description": PARAMETERS[n].description}
        if i in free:
            a = free.index(i)
            if is_log[i]:
                lo = theta[i] * safe_exp(-tq * sd_x[a])
                hi = theta[i] * safe_exp(tq * sd_x[a])
                std = theta[i] * sd_x[a]
            else:
                lo, hi, std = theta[i] - tq * sd_x[a], theta[i] + tq * sd_x[a], sd_x[a]
            mask = 0 if active is None else int(active[a])
            at_lo = mask < 0 or bool(np.isclose(theta[i], lo_b, rtol=1e-9, atol=0))
            at_hi = mask > 0 or bool(np.isclose(theta[i], hi_b, rtol=1e-9, atol=0))
            entry.update(std=float(std), ci=[float(lo), float(hi)], at_bound=at_lo or at_hi,
                         bound_side="lower" if at_lo else ("upper" if at_hi else None))
        else:
            entry.update(std=None, ci=None, at_bound=False, bound_side=None)
        params[n] = entry
    return params


def combination_intervals(combos: List[dict], params: Dict[str, dict], free, sd_x, tq) -> None:
    """Fill "value", "ci" and "std" of each identifiable combination (held parameter fixed, so
    the combination's log varies as the free parameter's log); removes the private "_free"."""
    for c in combos:
        i_free = c.pop("_free")
        c["value"] = float(combination_value(c, params))
        if i_free in free:
            a = free.index(i_free)
            c["ci"] = [float(c["value"] * safe_exp(-tq * sd_x[a])),
                       float(c["value"] * safe_exp(tq * sd_x[a]))]
            c["std"] = float(c["value"] * sd_x[a])
        else:
            c["ci"], c["std"] = None, None


def natural_covariance(cov_x: np.ndarray, theta_free: np.ndarray, is_log_free: np.ndarray):
    """Covariance and correlation of the free parameters in natural units, shapes (k, k)
    (first order: dp = p dx for log-scale parameters)."""
    scale = np.where(is_log_free, theta_free, 1.0)
    cov = cov_x * scale[:, None] * scale[None, :]
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    return cov, np.where(np.isfinite(corr), corr, 0.0)


def _log_interval(value: float, exponents: np.ndarray, cov_x: np.ndarray, tq: float) -> dict:
    """value, std and t-interval of a power law of the fitted parameters with the given log
    exponents (first order in the log coordinates of the free parameters)."""
    sd = float(math.sqrt(max(exponents @ cov_x @ exponents, 0.0))) if exponents.size else 0.0
    return {"value": value, "std": value * sd,
            "ci": [value * safe_exp(-tq * sd), value * safe_exp(tq * sd)]}


def derived_quantities(problem, theta, free, cov_x, tq) -> Dict[str, dict]:
    """Physical scenes: each group the field drives per unit field, c_g = g/H (``<g>_per_field``:
    h/H = √(μ0 χ̄ A ℓ²/(2B)), THEORY §5; h_r/H = μ0 M_r A ℓ²/B of a remanent rod, §9), with its
    interval from the lens exponents, for every such group whose term the scene has (the field
    magnitude's h is left out when it is 0 on a rod with a remanent term: a purely remanent rod has
    no soft-magnetic coefficient); and for a rod without a remanent term in a transverse field, the
    field of THEORY §6's buckling threshold."""
    if problem.kind != "physical" or problem.scene.field is None:
        return {}
    names, scene = problem.names, problem.scene
    coefs = problem.field_coefficients(dict(zip(names, theta)))
    shown = {p.name: (p, f) for p, f in field_groups()
             if p.name in coefs and p.term is not None and term_class(p.term).present(scene)}
    remanent = any(p.remanent_field for p, _ in shown.values())  # (a remanent term, M_r fitted or not)
    out = {}
    for name, (p, f) in shown.items():
        if p.field_magnitude and remanent and coefs[name] == 0.0:
            continue
        # d log c / d log(value): the lens exponents (½ for χ̄ in h, 1 for M_r in h_r, −½ or −1 for E)
        g = np.array([group_exponent(names[i], p.slot) for i in free])
        out[f"{name}_per_field"] = {**_log_interval(float(coefs[name]), g, cov_x, tq),
                                    "unit": "m/A" if f == 1 else f"(m/A)^{f}",
                                    "description": problem.material.FORMULAS[name]}
    # the transverse buckling threshold of THEORY §6 exists for a rod without remanence only (a
    # remanent torque bends the rod at any field)
    coef = float(coefs.get("h", 0.0))
    if abs(math.cos(scene.phi)) < 1e-9 and coef > 0 and not remanent:
        hc = math.pi / (2.0 * math.sqrt(2.0))  # THEORY §6, transverse buckling threshold
        g = np.array([group_exponent(names[i], "h") for i in free])
        sd = float(math.sqrt(max(g @ cov_x @ g, 0.0))) if g.size else 0.0
        out["transverse_critical_field"] = {
            "value": hc / coef, "unit": "A/m", "std": hc / coef * sd,
            "ci": [hc / coef * safe_exp(-tq * sd), hc / coef * safe_exp(tq * sd)],
            "description": "H at which h = h_crit = pi/(2 sqrt 2) (phi = 90 deg, THEORY §6)"}
    return out
