"""Text of a fit result: the JSON contract, the readable summary and the per-row CSV table."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Dict, Optional, Tuple

import numpy as np

from actuator_design.calibration.data import COLUMNS
from actuator_design.calibration.parameters import PARAMETERS
from actuator_design.io.unit_columns import data_unit
from actuator_design.io.user_units import length_unit_of
from actuator_design.model.units import MU0

if TYPE_CHECKING:  # annotations only: a FitResult calls this module for its text
    from actuator_design.calibration.result import FitResult

__all__ = ["result_dict", "summary_text", "points_csv_text", "fit_units", "user_unit",
           "physical_block"]

#: mT of μ0 H per A/m of H (μ0 · 10³)
_MT_PER_A_PER_M = MU0 * 1e3


def fit_units(config: Optional[dict]) -> Optional[Tuple[str, float]]:
    """``(length unit, m per unit)`` of a physical fit's configuration (the unit ``rod.length`` is
    written in); None for a dimensionless scene."""
    if not isinstance(config, dict) or (config.get("scene") or {}).get("type") != "physical":
        return None
    return length_unit_of(config)


def user_unit(column: str, units, angles: bool = False) -> Optional[Tuple[str, float]]:
    """``(unit, SI value of one unit)`` of a data column in the user's units: lengths in the unit of
    ``rod.length``, fields as μ0 H in mT, forces in N, and (``angles``) angles in deg; None for a
    dimensionless scene (``units`` None) or another column."""
    if units is None:
        return None
    dimension = COLUMNS[column][1]
    if dimension == "angle":
        return ("deg", math.pi / 180.0) if angles else None
    return data_unit(dimension, *units)


def _differs(result: FitResult, column: str, units) -> Optional[Tuple[str, float]]:
    """The user unit of ``column`` when it is not the unit the data file gives it in."""
    u = user_unit(column, units)
    return u if u is not None and u[0] != result.data.units[column] else None


def physical_block(result: FitResult, units) -> Optional[Dict[str, Any]]:
    """The ``physical`` key of a physical fit's JSON: the data, model and residuals of every row in
    the user's units (``points``: lengths in ``length_unit``, fields mT as μ0 H, forces N, angles
    deg), ``rms`` and ``sigma`` in them, and field-like parameters (a remanence as μ0 M_r, a field
    offset, a critical field) in mT with their intervals (``value_mT``, ``ci_mT``)."""
    if units is None:
        return None
    d = result.data
    cols = {c: user_unit(c, units, angles=True) for c in d.columns}

    def conv(c, v):
        return float(v) / cols[c][1]

    points = [{"row": p["row"], "inputs": {c: conv(c, v) for c, v in p["inputs"].items()},
               **{key: {o: conv(o, v) for o, v in p[key].items()}
                  for key in ("measured", "model", "residual")}}
              for p in result.points]
    block: Dict[str, Any] = {
        "length_unit": units[0],
        "units": {c: u[0] + (" (mu0 H)" if u[0] == "mT" else "") for c, u in cols.items()},
        "points": points,
        "rms": {o: _rms_si(result, j) / cols[o][1] for j, o in enumerate(result.outputs)},
        "sigma": {o: float(result.sigma[j]) / cols[o][1] for j, o in enumerate(result.outputs)},
        "parameters": {}, "derived": {}}
    for name, p in result.parameters.items():
        if PARAMETERS[name].dimension == "magnetic_field":
            block["parameters"][name] = _in_mT(p)
    for name, dv in result.derived.items():
        if dv.get("unit") == "A/m":
            block["derived"][name] = _in_mT(dv)
    return block


def _in_mT(p: Dict[str, Any]) -> Dict[str, Any]:
    """``value_mT`` (and ``ci_mT``, ``std_mT``) of a value in A/m: μ0 × value in mT."""
    out = {"value_mT": float(p["value"]) * _MT_PER_A_PER_M}
    if p.get("ci") is not None:
        out["ci_mT"] = [float(v) * _MT_PER_A_PER_M for v in p["ci"]]
    if p.get("std") is not None:
        out["std_mT"] = float(p["std"]) * _MT_PER_A_PER_M
    return out


def result_dict(result: FitResult, units=None) -> Dict[str, Any]:
    """The JSON contract of ``actuator-design fit --json`` (plain Python types and arrays); with
    ``units`` (:func:`fit_units`, a physical scene) also ``physical`` (:func:`physical_block`)."""
    out = {
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
    if units is not None:
        out["physical"] = physical_block(result, units)
    return out



def summary_text(result: FitResult, units=None) -> str:
    """A readable multi-line report of ``result``; with ``units`` (:func:`fit_units`) field-like
    values also in mT (μ0 H), residuals also in the user's units, and a line naming them."""
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
        if units is not None and PARAMETERS[name].dimension == "magnetic_field":
            extra += f"  ({_mT_text(p, 'mu0 ' + PARAMETERS[name].symbol)})"
        lines.append(f"    {name:<18s} = {p['value']:.6g}{unit} ± {p['std']:.2g}  "
                     f"[{p['ci'][0]:.6g}, {p['ci'][1]:.6g}]{extra}")
    for c in result.combinations:
        lines.append(f"    {c['name']:<18s} = {c['value']:.6g} {c['unit']}  "
                     f"[{c['ci'][0]:.6g}, {c['ci'][1]:.6g}]  (identifiable combination)")
    for name, dv in result.derived.items():
        extra = f" = {_mT_text(dv, 'mu0 H')}" if units is not None and dv.get("unit") == "A/m" else ""
        lines.append(f"    {name:<18s} = {dv['value']:.6g} {dv['unit']}  "
                     f"[{dv['ci'][0]:.6g}, {dv['ci'][1]:.6g}]{extra}  (derived: {dv['description']})")
    rms = ", ".join(f"{o} {v:.4g} {result.data.units[o]}".rstrip() + _rms_user(result, o, units)
                    for o, v in result.rms.items())
    lines.append(f"  residuals   : rms {rms}; s² = {result.s2:.4g} ({_weights_text(result)}), "
                 f"dof {result.dof}")
    lines.append(f"  goodness    : {_goodness_text(result.goodness_of_fit)}")
    n_unstable = sum(1 for p in result.points if not p["stable"])
    n_failed = sum(1 for p in result.points if not p["converged"])
    lines.append(f"  equilibria  : {result.data.n - n_failed} converged, "
                 f"{result.data.n - n_unstable} stable")
    if units is not None:
        lines.append(f"  user units  : lengths in {units[0]} (rod.length), fields as mu0 H in mT, "
                     "forces in N (JSON 'physical'; fit_points.csv adds columns where the data file's "
                     "unit differs)")
    for w in result.warnings:
        lines.append(f"  warning     : {w}")
    return "\n".join(lines)


def _mT_text(p: Dict[str, Any], what: str) -> str:
    """``mu0 H = 12.3 mT [12.1, 12.5]`` of a value in A/m with its interval."""
    m = _in_mT(p)
    ci = f" [{m['ci_mT'][0]:.6g}, {m['ci_mT'][1]:.6g}]" if "ci_mT" in m else ""
    return f"{what} = {m['value_mT']:.6g} mT{ci}"


def _weights_text(result) -> str:
    """Which weights s² uses: Σ w ((model − data)/σ)² / dof with each output's σ (in the data
    file's unit) and, when the data file gives them, the row weights w."""
    d = result.data
    sig = ", ".join(f"{o} {float(d.as_given(o, [result.sigma[j]])[0]):.4g} {d.units[o]}".rstrip()
                    for j, o in enumerate(result.outputs))
    rows = "row weights w from the data file" if d.weights is not None else "w = 1"
    return f"weighted: residual/σ with σ = {sig}; {rows}"


def _rms_user(result: FitResult, output: str, units) -> str:
    """`` (= 0.27 mm)``: an rms residual in the user's unit when the data file's differs."""
    u = _differs(result, output, units)
    if u is None:
        return ""
    return f" (= {_rms_si(result, result.outputs.index(output)) / u[1]:.4g} {u[0]})"


def _rms_si(result: FitResult, j: int) -> float:
    """RMS residual of output ``j`` in SI (unweighted, as :attr:`FitResult.rms`)."""
    return float(np.sqrt(np.mean(np.asarray(result.residuals[:, j], float) ** 2)))




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


def points_csv_text(result: FitResult, units=None) -> str:
    """Data, model and residuals per row, in the units of the data file; with ``units``
    (:func:`fit_units`) also, after those, every input and output whose data unit is not the user's
    (lengths in the unit of ``rod.length``, fields as μ0 H in mT, forces in N) in the user's unit:
    ``field [mT]``, ``tip_deflection [mm]``, ``tip_deflection_model [mm]``, … ."""
    d = result.data
    cols = ["row"] + [f"{c} [{d.units[c]}]".replace(" []", "") for c in d.inputs]
    for o in result.outputs:
        u = f" [{d.units[o]}]" if d.units[o] else ""
        cols += [f"{o}{u}", f"{o}_model{u}", f"{o}_residual{u}"]
    cols += ["stable", "converged"]
    extra_in = [(c, _differs(result, c, units)) for c in d.inputs]
    extra_in = [(c, u) for c, u in extra_in if u is not None]
    extra_out = [(o, _differs(result, o, units)) for o in result.outputs]
    extra_out = [(o, u) for o, u in extra_out if u is not None]
    cols += [f"{c} [{u[0]}]" for c, u in extra_in]
    for o, u in extra_out:
        cols += [f"{o} [{u[0]}]", f"{o}_model [{u[0]}]", f"{o}_residual [{u[0]}]"]
    lines = [",".join(cols)]
    for i, p in enumerate(result.points):
        vals = [str(p["row"])] + [repr(float(d.as_given(c, [p["inputs"][c]])[0])) for c in d.inputs]
        for o in result.outputs:
            vals += [repr(float(d.as_given(o, [p[key][o]])[0])) for key in ("measured", "model",
                                                                            "residual")]
        vals += [str(p["stable"]).lower(), str(p["converged"]).lower()]
        vals += [repr(float(p["inputs"][c]) / u[1]) for c, u in extra_in]
        for o, u in extra_out:
            vals += [repr(float(p[key][o]) / u[1]) for key in ("measured", "model", "residual")]
        lines.append(",".join(vals))
    return "\n".join(lines) + "\n"
