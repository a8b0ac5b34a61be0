"""The error–time (Pareto) figure of the forward benchmark: pure drawing from benchmark rows.

Rows are those of :func:`actuator_design.benchmarks.runner.run_benchmark` (``problem``, ``method``,
``error`` in rod lengths / rad, ``time_s`` in s, ``converged``, ``peer``).
"""
from __future__ import annotations

import math
from typing import Dict, List, Sequence

from actuator_design.viz.style import new_figure

__all__ = ["pareto_figure", "pareto_front"]

_STYLE = {
    "lgl-fast": ("o", "-", "C0"), "lgl-fast-jit": ("*", "-", "C9"), "midpoint-fast": ("s", "-", "C1"),
    "lgl-newton": ("D", ":", "C2"), "lgl-ipopt": ("^", ":", "C3"), "midpoint-ipopt": ("v", ":", "C5"),
    "api-fast": ("P", "", "C6"), "numpy-floor": ("x", "--", "C7"), "shooting": ("h", "", "C8"),
    "solve_bvp": ("X", "--", "k"),
}


def pareto_front(rows: Sequence[Dict]) -> List[Dict]:
    """Rows not dominated in (time, error): nothing else is both faster and more accurate."""
    pts = sorted((r for r in rows if r["converged"] and math.isfinite(r["error"])),
                 key=lambda r: (r["time_s"], r["error"]))
    front, best = [], math.inf
    for r in pts:
        if r["error"] < best:
            front.append(r)
            best = r["error"]
    return front


def pareto_figure(rows: Sequence[Dict]):
    """A grid of log-log error–time plots, one panel per problem.

    Each method family is one series (in order of resolution or tolerance); the Pareto front of the project's methods
    is shaded grey; ``solve_bvp`` (the peer) is black.

    Returns
    -------
    matplotlib.figure.Figure
    """
    problems = list(dict.fromkeys(r["problem"] for r in rows))
    ncol = min(3, len(problems)) or 1
    nrow = math.ceil(len(problems) / ncol) or 1
    fig = new_figure((4.6 * ncol, 3.8 * nrow))
    axes = fig.subplots(nrow, ncol, squeeze=False).ravel()
    floor_err = 1e-16
    for ax, prob in zip(axes, problems):
        sub = [r for r in rows if r["problem"] == prob and r["converged"] and math.isfinite(r["error"])]
        for name in dict.fromkeys(r["method"] for r in sub):
            pts = [r for r in sub if r["method"] == name]  # in the runner's order: resolution / tol
            marker, ls, color = _STYLE.get(name, (".", "-", None))
            ax.plot([1e3 * r["time_s"] for r in pts], [max(r["error"], floor_err) for r in pts],
                    marker=marker, linestyle=ls or "none", color=color, label=name, ms=5, lw=1)
        front = pareto_front([r for r in sub if not r["peer"]])
        if front:
            ax.step([1e3 * r["time_s"] for r in front], [max(r["error"], floor_err) for r in front],
                    where="post", color="0.6", lw=4, alpha=0.35, zorder=0)
        ax.axhline(1e-8, color="0.5", lw=0.6, ls=":")
        ax.axvline(0.2, color="0.5", lw=0.6, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(prob, fontsize=10)
        ax.set_xlabel("warm time per solve [ms]")
        ax.set_ylabel("max tip error [l, rad]")
        ax.grid(True, which="major", alpha=0.3)
    for ax in axes[len(problems):]:
        ax.set_visible(False)
    handles, labels = {}, {}
    for ax in axes[:len(problems)]:
        for h, l in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(l, h)
    if handles:
        fig.legend(list(handles.values()), list(handles.keys()), loc="outside lower center",
                   ncol=min(6, len(handles)), fontsize=8)
    fig.suptitle("Forward solve: error against warm time (dotted: 1e-8 and 0.2 ms targets)")
    return fig
