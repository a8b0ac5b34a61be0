"""Text of a fit result: the JSON contract, the readable summary and the per-row CSV table."""
from __future__ import annotations

import math
from typing import Any, Dict

from .parameters import PARAMETERS
from .result import FitResult

__all__ = ["result_dict", "summary_text", "points_csv_text"]


def result_dict(result: FitResult) -> Dict[str, Any]:
    """The JSON contract of ``actuator-design fit --json`` (plain Python types and arrays)."""
    return {
        "success": bool(result.success), "status": result.status, "message": result.message,
        "name": result.name,
        "parameters": result.parameters, "confidence": result.confidence,
        "identifiable": bool(result.identifiable), "warnings": list(result.warnings),
        "combinations": result.combinations, "derived": result.derived,
        "fitted_parameters": list(result.fitted_names),
        "covariance": result.covariance.tolist(), "correlation": result.correlation.tolist(),
        "singular_values": result.singular_values.tolist(),
        "n_points": int(result.data.n), "n_residuals": int(result.residuals.size),
        "dof": int(result.dof), "s2": float(result.s2),
        "rms": result.rms, "units": dict(result.data.units),
        "sigma": {o: float(result.sigma[j]) for j, o in enumerate(result.outputs)},
        "data": {"source": result.data.source, "columns": dict(result.data.units),
                 "comments": list(result.data.comments)},
        "points": result.points, "optimizer": result.optimizer, "solver": result.solver,
        "goodness_of_fit": dict(result.goodness_of_fit),
    }



def summary_text(result: FitResult) -> str:
    """A readable multi-line report of ``result``."""
    pct = f"{100 * result.confidence:g}%"
    # a config named "fit: ..." (every shipped fit config is) is not printed as "fit: fit: ..."
    name = result.name[4:].lstrip() if result.name.lower().startswith("fit:") else result.name
    lines = [f"fit: {name}",
             f"  data        : {result.data.source}, {result.data.n} points, outputs "
             f"{', '.join(result.outputs)}",
             f"  status      : {result.status} ({'success' if result.success else 'FAILED'}) — "
             f"{result.message}",
             f"  parameters  : value [{pct} confidence interval]"]
    for name, p in result.parameters.items():
        unit = f" {p['unit']}" if p["unit"] else ""
        if not p["fitted"]:
            lines.append(f"    {name:<18s} = {p['value']:.6g}{unit}  (held: not identifiable)")
            continue
        extra = ""
        if PARAMETERS[name].dimension == "angle":
            extra = f"  ({math.degrees(p['value']):.4g} deg)"
        lines.append(f"    {name:<18s} = {p['value']:.6g}{unit} ± {p['std']:.2g}  "
                     f"[{p['ci'][0]:.6g}, {p['ci'][1]:.6g}]{extra}")
    for c in result.combinations:
        lines.append(f"    {c['name']:<18s} = {c['value']:.6g} {c['unit']}  "
                     f"[{c['ci'][0]:.6g}, {c['ci'][1]:.6g}]  (identifiable combination)")
    for name, dv in result.derived.items():
        lines.append(f"    {name:<18s} = {dv['value']:.6g} {dv['unit']}  "
                     f"[{dv['ci'][0]:.6g}, {dv['ci'][1]:.6g}]  (derived: {dv['description']})")
    rms = ", ".join(f"{o} {v:.4g} {result.data.units[o]}".rstrip() for o, v in result.rms.items())
    lines.append(f"  residuals   : rms {rms}; s² = {result.s2:.4g} (weighted), dof {result.dof}")
    lines.append(f"  goodness    : {_goodness_text(result.goodness_of_fit)}")
    n_unstable = sum(1 for p in result.points if not p["stable"])
    n_failed = sum(1 for p in result.points if not p["converged"])
    lines.append(f"  equilibria  : {result.data.n - n_failed} converged, "
                 f"{result.data.n - n_unstable} stable")
    for w in result.warnings:
        lines.append(f"  warning     : {w}")
    return "\n".join(lines)




def _goodness_text(gof: Dict[str, Any]) -> str:
    """One line on the χ² test."""
    if not gof:
        return "not tested"
    if not gof["tested"]:
        return f"not tested ({gof['reason']})"
    verdict = "passed" if gof["passed"] else "FAILED: the model does not explain the data"
    return (f"reduced chi-square {gof['chi2_reduced']:.4g}, dof {gof['dof']}, p = "
            f"{gof['p_value']:.3g} (fails above {gof['threshold']:.4g}, p < "
            f"{gof['min_p_value']:g}): {verdict}")


def points_csv_text(result: FitResult) -> str:
    """Data, model and residuals per row, in the units of the data file."""
    d = result.data
    cols = ["row"] + [f"{c} [{d.units[c]}]".replace(" []", "") for c in d.inputs]
    for o in result.outputs:
        u = f" [{d.units[o]}]" if d.units[o] else ""
        cols += [f"{o}{u}", f"{o}_model{u}", f"{o}_residual{u}"]
    cols += ["stable", "converged"]
    lines = [",".join(cols)]
    for i, p in enumerate(result.points):
        vals = [str(p["row"])] + [repr(float(d.as_given(c, [p["inputs"][c]])[0])) for c in d.inputs]
        for o in result.outputs:
            vals += [repr(float(d.as_given(o, [p[key][o]])[0])) for key in ("measured", "model",
                                                                            "residual")]
        vals += [str(p["stable"]).lower(), str(p["converged"]).lower()]
        lines.append(",".join(vals))
    return "\n".join(lines) + "\n"
