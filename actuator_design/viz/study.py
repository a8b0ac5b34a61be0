"""Figures of a study: a result column against a swept key, from the study's tidy table.

:func:`study_figures` draws one line per combination of the other swept keys, coloured by the
``hue`` key (a colour bar for numbers); points whose status is not ``ok`` are left out, unstable
equilibria (``solve.stable`` false) are marked. :func:`default_figures` chooses the figures of a
study that names none. Pure drawing from the table (never solves).
"""
from __future__ import annotations

from typing import Dict, List, Optional

import numpy as np

from .style import new_axes_grid

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
    results = [c for c in table if "." in c and c not in {a.column for a in axes}]
    y = next((c for c in _PREFERRED_Y if c in table), None)
    if y is None:
        y = next((c for c in results if _numeric(table[c]) is not None
                  and np.any(np.isfinite(_numeric(table[c])))), None)
    if y is None:
        return []
    others = [a for a in axes if a is not x]
    hue = others[0].key if others else None
    return [{"x": x.key, "y": y, "hue": hue}]


def study_figures(axes, table: Dict[str, list], specs: List[dict]) -> Dict[str, object]:
    """Figures by file stem (``<y>_vs_<x>``) from the study table.

    Parameters
    ----------
    axes : list of Axis
    table : dict of column → list
    specs : list of {"x": key, "y": column, "hue": key or None}
    """
    by_key = {a.key: a for a in axes}
    out = {}
    status = np.array(table.get("status", []), dtype=object)
    for spec in specs:
        xa, ycol = by_key[spec["x"]], spec["y"]
        if ycol not in table:
            continue
        x = _numeric(table[xa.column])
        y = _numeric(table[ycol])
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
        if hue is not None:
            hue_vals = table[hue.column]
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
            fig.colorbar(sm, ax=ax, label=hue.column)
        elif labelled:
            ax.legend(fontsize=8)
        ax.set_xlabel(xa.column)
        ax.set_ylabel(ycol)
        n_bad = int(np.sum(status != "ok")) if status.size else 0
        ax.set_title(f"{ycol} vs {xa.key}" + (f" ({n_bad} points not ok, not drawn)" if n_bad else ""),
                     fontsize=10)
        ax.grid(alpha=0.3)
        out[f"{_safe(ycol)}_vs_{_safe(xa.key)}"] = fig
    return out


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in text)
