"""Figures of a study: a result column against a swept key, from the study's tidy table.

:func:`study_figures` draws one line per combination of the other swept keys, coloured by the
``hue`` key (a colour bar for numbers); points whose status is not ``ok`` are left out, unstable
equilibria (``solve.stable`` false) are marked. :func:`default_figures` chooses the figures of a
study that names none. Pure drawing from the table (never solves).
"""
from __future__ import annotations

from typing import Dict, List, Optional

import numpy as np

from actuator_design.io.unit_columns import current_study_config, derived_name, table_units, unit_column
from actuator_design.viz.style import new_axes_grid

__all__ = ["study_figures", "default_figures"]

_PREFERRED_Y = ("solve.tip.angle", "stiffness.stiffness", "solve.tip.y", "solve.energy")


def _numeric(values) -> Optional[np.ndarray]:
    try:
        arr = np.array([np.nan if v is None else v for v in values], dtype=float)
    except (TypeError, ValueError):
        return None
    return arr


def default_figures(axes, table: Dict[str, list]) -> List[dict]:
    """One figure: the swept key with the most values against the tip angle (or the first numeric
    result), coloured by the next swept key."""
    numeric_axes = [a for a in axes if a.numeric]
    if not numeric_axes:
        return []
    x = max(numeric_axes, key=lambda a: len(set(a.numbers)))
    swept = {a.column for a in axes}
    results = [c for c in table if "." in c and c not in swept
               and not any(c.startswith(f"{a.key} [") for a in axes)]  # nor a swept key in other units
    y = next((c for c in _PREFERRED_Y if c in table), None)
    if y is None:
        y = next((c for c in results if _numeric(table[c]) is not None
                  and np.any(np.isfinite(_numeric(table[c])))), None)
    if y is None:
        return []
    others = [a for a in axes if a is not x]
    hue = others[0].key if others else None
    return [{"x": x.key, "y": y, "hue": hue}]


def _plotted(column: str, table, axes, units):
    """``(column drawn, axis label)``: a physical study's column in the user's units when the
    table has it (:func:`actuator_design.io.unit_columns.unit_column`), else ``column`` itself — with
    a word when it has a user unit that could not be computed (e.g. χ̄ = 0: no field scale)."""
    found = unit_column(column, table, axes, units)
    if found is not None:
        col, unit = found
        return col, col if col.endswith("]") else f"{column} [{unit}]"
    if units is not None and derived_name(column, units) is not None:
        return column, f"{column} (dimensionless: no conversion to the user's units here)"
    return column, column


def study_figures(axes, table: Dict[str, list], specs: List[dict],
                  raw: Optional[dict] = None) -> Dict[str, object]:
    """Figures by file stem (``<y>_vs_<x>``) from the study table.

    Parameters
    ----------
    axes : list of Axis
    table : dict of column → list
    specs : list of {"x": key, "y": column, "hue": key or None}
    raw : dict, optional
        The study's configuration (default the one set by
        :func:`actuator_design.io.unit_columns.study_config`): a physical study draws the table's
        columns in the user's units where it has them (a swept field in mT as μ0 H, forces in N,
        lengths in the unit of ``rod.length``).
    """
    units = table_units(current_study_config() if raw is None else raw, axes)
    by_key = {a.key: a for a in axes}
    out = {}
    status = np.array(table.get("status", []), dtype=object)
    for spec in specs:
        xa, ycol = by_key[spec["x"]], spec["y"]
        if ycol not in table:
            continue
        xcol, xlabel = _plotted(xa.column, table, axes, units)
        ycol_drawn, ylabel = _plotted(ycol, table, axes, units)
        x = _numeric(table[xcol])
        y = _numeric(table[ycol_drawn])
        if x is None or y is None:
            continue
        ok = (status == "ok") & np.isfinite(x) & np.isfinite(y)
        stable = table.get("solve.stable")
        unstable = (np.array([s is False for s in stable]) if stable is not None
                    else np.zeros(len(x), bool))
        fig, ax = new_axes_grid()
        ax = ax[0, 0]
        hue = by_key.get(spec.get("hue")) if spec.get("hue") else None
        others = [a for a in axes if a is not xa]
        keys = list(zip(*[table[a.column] for a in others])) if others else [()] * len(x)
        cmap, norm = None, None
        hue_vals = None
        hue_col, hue_label = (None, None) if hue is None else _plotted(hue.column, table, axes, units)
        if hue is not None:
            hue_vals = table[hue_col]
            hv = _numeric(hue_vals) if hue.numeric else None
            if hv is not None and np.isfinite(hv).any():
                import matplotlib
                import matplotlib.colors as mcolors
                lo, hi = np.nanmin(hv), np.nanmax(hv)
                norm = mcolors.Normalize(lo, hi if hi > lo else lo + 1.0)
                cmap = matplotlib.colormaps["viridis"]
        groups: Dict[tuple, List[int]] = {}
        for i, k in enumerate(keys):
            groups.setdefault(k, []).append(i)
        labelled = set()
        for k, idx in groups.items():
            idx = np.array([i for i in idx if ok[i]], int)
            if idx.size == 0:
                continue
            idx = idx[np.argsort(x[idx])]
            color, label = None, None
            if hue is not None:
                hv_i = hue_vals[idx[0]]
                if cmap is not None:
                    color = cmap(norm(float(hv_i)))
                elif hv_i not in labelled:
                    label = f"{hue.key} = {hv_i}"
                    labelled.add(hv_i)
            many = len(groups) > 12
            line, = ax.plot(x[idx], y[idx], "-" if idx.size > 1 else "o", color=color, lw=1.2,
                            ms=3, label=label if not many else None)
            bad = idx[unstable[idx]]
            if bad.size:
                ax.plot(x[bad], y[bad], "x", color="C3", ms=5,
                        label="unstable" if "unstable" not in labelled else None)
                labelled.add("unstable")
        if cmap is not None:
            import matplotlib.cm as cm
            sm = cm.ScalarMappable(norm=norm, cmap=cmap)
            fig.colorbar(sm, ax=ax, label=hue_label)
        elif labelled:
            ax.legend(fontsize=8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        n_bad = int(np.sum(status != "ok")) if status.size else 0
        ax.set_title(f"{ycol} vs {xa.key}" + (f" ({n_bad} points not ok, not drawn)" if n_bad else ""),
                     fontsize=10)
        ax.grid(alpha=0.3)
        out[f"{_safe(ycol)}_vs_{_safe(xa.key)}"] = fig
    return out


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in text)
