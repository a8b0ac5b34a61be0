"""Figures of a calibration: measured data against the fitted model, and the residuals.

Pure functions of a :class:`~actuator_design.calibration.FitResult` (they never solve); figures are
made without pyplot's global state (Agg backend).
"""
from __future__ import annotations

import sys
from typing import Dict

import numpy as np

from actuator_design.calibration.report import user_unit

__all__ = ["fit_figures", "fit_figure_pngs"]


def _figure(ncols: int = 1, nrows: int = 1, size=(6.4, 4.6)):
    import matplotlib
    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")
    from matplotlib.figure import Figure
    fig = Figure(figsize=(size[0] * ncols, size[1] * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def _axis_units(d, units):
    """``(values, label)`` functions of a data column: its unit in the user's units (a physical
    scene: lengths in the unit of ``rod.length``, fields as μ0 H in mT, forces in N), else the
    data file's."""
    def values(c, v):
        u = user_unit(c, units)
        return np.asarray(v, float) / u[1] if u is not None else d.as_given(c, v)

    def unit(c):
        u = user_unit(c, units)
        return (u[0] + (" (μ0H)" if u[0] == "mT" else "")) if u is not None else d.units[c]
    return values, unit


def fit_figures(result, units=None) -> Dict[str, object]:
    """``fit_data_vs_model`` and ``fit_residuals`` figures of a fit result.

    Parameters
    ----------
    result : actuator_design.calibration.FitResult
    units : (str, float), optional
        A physical scene's length unit and its size in m
        (:func:`~actuator_design.calibration.report.fit_units`): axes of lengths in that unit,
        fields as μ0 H in mT, forces in N (angles as in the data file). Default: the data
        file's units.

    Returns
    -------
    dict of str → matplotlib.figure.Figure
        Data against the fitted model curves (one panel per measured column, one curve per
        group of the other inputs), and the residuals against the primary input (±2 rms dashed).
    """
    d, outputs, curves = result.data, result.outputs, result.curves
    as_unit, unit_of = _axis_units(d, units)
    primary = curves.get("x")
    n_out = len(outputs)
    if primary is not None:
        xdata = d.columns[primary]
        xlabel = f"{primary} [{unit_of(primary)}]" if unit_of(primary) else primary
    else:
        xdata = np.arange(1, d.n + 1, dtype=float)
        xlabel = "data row"
    groups = curves.get("groups") or [{"label": "", "inputs": {}, "x": None, "y": {}}]
    if units is not None:  # the other inputs of each curve in the user's units too
        groups = [{**g, "label": ", ".join(f"{c} = {float(as_unit(c, [v])[0]):.4g} {unit_of(c)}".strip()
                                           for c, v in g["inputs"].items())} if g["inputs"] else g
                  for g in groups]

    def in_group(g):
        mask = np.ones(d.n, bool)
        for c, v in g["inputs"].items():
            mask &= d.columns[c] == v
        return mask

    fig, axs = _figure(ncols=n_out)
    for j, o in enumerate(outputs):
        ax = axs[0, j]
        for gi, g in enumerate(groups):
            color = f"C{gi % 10}"
            mask = in_group(g)
            xd = as_unit(primary, xdata[mask]) if primary else xdata[mask]
            ax.plot(xd, as_unit(o, d.columns[o][mask]), "o", color=color, ms=4, mfc="none",
                    label=f"data {g['label']}".strip())
            if g.get("x") is not None:
                _model_curve(ax, as_unit(primary, g["x"]), as_unit(o, g["y"][o]),
                             g.get("branch_switch"), color, f"model {g['label']}".strip())
        unit = f" [{unit_of(o)}]" if unit_of(o) else ""
        ax.set_xlabel(xlabel)
        ax.set_ylabel(o + unit)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(_fit_title(result), fontsize=9)

    fig2, axs2 = _figure(ncols=n_out)
    for j, o in enumerate(outputs):
        ax = axs2[0, j]
        res = as_unit(o, result.residuals[:, j])
        for gi, g in enumerate(groups):
            mask = in_group(g)
            xd = as_unit(primary, xdata[mask]) if primary else xdata[mask]
            ax.plot(xd, res[mask], "o", color=f"C{gi % 10}", ms=4, label=g["label"] or None)
        s = float(np.sqrt(np.mean(res**2)))
        ax.axhline(0.0, color="k", lw=0.8)
        for sign in (-2, 2):
            ax.axhline(sign * s, color="0.5", lw=0.8, ls="--")
        unit = f" [{unit_of(o)}]" if unit_of(o) else ""
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"residual (model − data) {o}{unit}")
        ax.set_title(f"rms {s:.3g}{unit}; dashed: ±2 rms", fontsize=9)
        ax.grid(alpha=0.3)
        if any(g["label"] for g in groups):
            ax.legend(fontsize=7)
    fig2.suptitle(_fit_title(result), fontsize=9)
    return {"fit_data_vs_model": fig, "fit_residuals": fig2}


def _model_curve(ax, x, y, switch, color, label) -> None:
    """The model curve, one solid line per branch: at a branch switch (``switch[m]``: point m is
    on another branch than m − 1) the two branches are joined by a dotted line."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    marks = np.flatnonzero(np.asarray(switch if switch is not None else [], bool))
    cuts = [0] + [int(m) for m in marks if 0 < m < x.size] + [x.size]
    for k, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        ax.plot(x[a:b], y[a:b], "-", color=color, lw=1.5, label=label if k == 0 else None)
        if a > 0:
            ax.plot(x[a - 1:a + 1], y[a - 1:a + 1], ":", color=color, lw=1.2,
                    label="jump to the branch nearest the data" if k == 1 else None)


def _fit_title(result) -> str:
    parts = []
    for name, p in result.parameters.items():
        if p["fitted"]:
            parts.append(f"{name} = {p['value']:.4g} [{p['ci'][0]:.4g}, {p['ci'][1]:.4g}]")
    ci = f" ({100 * result.confidence:g}% CI)"
    joined = "; ".join(parts) + ci
    # one parameter a line when they do not fit the figure's width (no title cut off at the edges)
    return f"{result.name}\n" + (joined if len(joined) <= 80 else ";\n".join(parts) + ci)


def fit_figure_pngs(result, dpi: int = 150, units=None) -> Dict[str, bytes]:
    """PNG bytes of :func:`fit_figures` (``units``: see there), by figure name
    (:func:`~.style.png_bytes`)."""
    from actuator_design.viz.style import png_bytes
    return {name: png_bytes(fig, dpi=dpi) for name, fig in fit_figures(result, units).items()}
