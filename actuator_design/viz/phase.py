"""Phase portraits (θ, θ'): pure drawing from a :class:`~actuator_design.analysis.phase.PhasePortrait`.

Level lines of the first integral H in grey, the equilibria's trajectories highlighted (stable solid,
unstable dashed), the start line θ = θ0 and the end line θ' = m/b, as in the paper's phase-diagram
figures.
"""
from __future__ import annotations

import math

import numpy as np

from actuator_design.viz.style import new_figure

__all__ = ["plot_phase", "phase_figure"]


def _title(portrait, units=None) -> str:
    from actuator_design.viz.units import groups_text

    sc = portrait.scene
    parts = [groups_text(sc, units)]
    if sc.fibres.value:
        parts.append(f"α = {math.degrees(sc.fibres.value):.4g}°")
    n, ns = len(portrait.trajectories), sum(t.stable for t in portrait.trajectories)
    return ", ".join(parts) + f" — {n} equilibria ({ns} stable)"


def plot_phase(portrait, ax=None, title: str = None, legend: bool = True, units=None):
    """Draw one phase portrait into ``ax`` (a new Agg figure when omitted); returns the axes.

    With a physical scene's ``units`` (:class:`~actuator_design.io.user_units.UserUnits`) θ' is ticked
    in rad per the length unit of ``rod.length`` and the title gives the field in mT, loads in N."""
    if ax is None:
        fig, axes = _figure(1)
        ax = axes[0]
    ax.contour(portrait.theta, portrait.dtheta, portrait.H, levels=portrait.levels, colors="0.7",
               linewidths=0.6, linestyles="solid")
    ax.axvline(portrait.theta0, color="k", lw=0.9, ls=":")
    ax.axhline(portrait.end_dtheta, color="k", lw=0.9, ls=":")
    for i, t in enumerate(portrait.trajectories):
        c = f"C{i % 10}"
        ax.plot(t.theta, t.dtheta, color=c, lw=2.2, ls="-" if t.stable else "--",
                label=(f"θ(1) = {t.tip_angle:.3f}, " + ("stable" if t.stable else f"unstable (index {t.morse_index})")
                       + (", self-intersecting" if t.self_intersecting else "")))
        ax.plot([t.theta[0]], [t.dtheta[0]], "o", color=c, ms=4.5)
        ax.plot([t.theta[-1]], [t.dtheta[-1]], "s", color=c, ms=4.5)
    ax.set_xlim(portrait.theta[0], portrait.theta[-1])
    ax.set_ylim(portrait.dtheta[0], portrait.dtheta[-1])
    ax.set_xlabel("θ [rad]")
    ax.set_ylabel("θ' = κ [rad/l]")
    if units is not None:
        from actuator_design.viz.units import scaled_axis
        scaled_axis(ax.yaxis, 1.0 / units.length(1.0), f"θ' = κ [rad/{units.length_unit}]")
    ax.set_title(title or _title(portrait, units), fontsize=9)
    if legend and portrait.trajectories:
        ax.legend(loc="upper right", fontsize=7, framealpha=0.85)
    return ax


def _figure(n):
    """A figure for ``n`` panels, two per row: (fig, flat array of axes)."""
    ncols = min(n, 2)
    nrows = int(math.ceil(n / ncols))
    fig = new_figure((6.6 * ncols, 5.2 * nrows))
    return fig, np.atleast_1d(fig.subplots(nrows, ncols)).ravel()


def phase_figure(portraits, titles=None, units=None):
    """A figure with one panel per portrait (a single portrait or a list); ``units``: see
    :func:`plot_phase`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(portraits, (list, tuple)):
        portraits = [portraits]
    fig, axes = _figure(len(portraits))
    for i, p in enumerate(portraits):
        plot_phase(p, ax=axes[i], title=None if titles is None else titles[i], units=units)
    for ax in axes[len(portraits):]:
        ax.set_visible(False)
    return fig

