"""Figures of fits: measured data against the fitted model, and the residuals (never solves).

Kept here only until the calibration package lands (its figures go to
``actuator_design/viz/calibration.py``); then this module is deleted. It draws through
:mod:`actuator_design.viz.style` and does not import matplotlib itself.
"""
from __future__ import annotations

from typing import Dict

import numpy as np

from ..viz.style import new_axes_grid

__all__ = ["fit_figures"]


def fit_figures(result) -> Dict[str, object]:
    """``fit_data_vs_model`` and ``fit_residuals`` figures of a :class:`~actuator_design.fit.FitResult`."""
    d, outputs, curves = result.data, result.outputs, result.curves
    primary = curves.get("x")
    n_out = len(outputs)
    if primary is not None:
        xdata = d.columns[primary]
        xlabel = f"{primary} [{d.units[primary]}]" if d.units[primary] else primary
    else:
        xdata = np.arange(1, d.n + 1, dtype=float)
        xlabel = "data row"
    groups = curves.get("groups") or [{"label": "", "inputs": {}, "x": None, "y": {}}]

    def in_group(g):
        mask = np.ones(d.n, bool)
        for c, v in g["inputs"].items():
            mask &= d.columns[c] == v
        return mask

    fig, axs = new_axes_grid(ncols=n_out)
    for j, o in enumerate(outputs):
        ax = axs[0, j]
        for gi, g in enumerate(groups):
            color = f"C{gi % 10}"
            mask = in_group(g)
            xd = d.as_given(primary, xdata[mask]) if primary else xdata[mask]
            ax.plot(xd, d.as_given(o, d.columns[o][mask]), "o", color=color, ms=4, mfc="none",
                    label=f"data {g['label']}".strip())
            if g.get("x") is not None:
                ax.plot(d.as_given(primary, g["x"]), d.as_given(o, g["y"][o]), "-", color=color,
                        lw=1.5, label=f"model {g['label']}".strip())
        unit = f" [{d.units[o]}]" if d.units[o] else ""
        ax.set_xlabel(xlabel)
        ax.set_ylabel(o + unit)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(_fit_title(result), fontsize=9)

    fig2, axs2 = new_axes_grid(ncols=n_out)
    for j, o in enumerate(outputs):
        ax = axs2[0, j]
        res = d.as_given(o, result.residuals[:, j])
        for gi, g in enumerate(groups):
            mask = in_group(g)
            xd = d.as_given(primary, xdata[mask]) if primary else xdata[mask]
            ax.plot(xd, res[mask], "o", color=f"C{gi % 10}", ms=4, label=g["label"] or None)
        s = float(np.sqrt(np.mean(res**2)))
        ax.axhline(0.0, color="k", lw=0.8)
        for sign in (-2, 2):
            ax.axhline(sign * s, color="0.5", lw=0.8, ls="--")
        unit = f" [{d.units[o]}]" if d.units[o] else ""
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"residual (model − data) {o}{unit}")
        ax.set_title(f"rms {s:.3g}{unit}; dashed: ±2 rms", fontsize=9)
        ax.grid(alpha=0.3)
        if any(g["label"] for g in groups):
            ax.legend(fontsize=7)
    fig2.suptitle(_fit_title(result), fontsize=9)
    return {"fit_data_vs_model": fig, "fit_residuals": fig2}


def _fit_title(result) -> str:
    parts = []
    for name, p in result.parameters.items():
        if p["fitted"]:
            parts.append(f"{name} = {p['value']:.4g} [{p['ci'][0]:.4g}, {p['ci'][1]:.4g}]")
    return (f"{result.name}\n" + "; ".join(parts) + f" ({100 * result.confidence:g}% CI)")
