"""The figure of a schedule over coil currents (:mod:`actuator_design.schedules.current_schedule`)."""
from __future__ import annotations

import numpy as np

from actuator_design.viz.design import hardware_schedule_axes

__all__ = ["current_schedule_figure"]


def current_schedule_figure(sched, units=None):
    """The rod at every waypoint (left) and each coil's current against time (right; the greedy
    schedule dashed when the optimised one is reported, the waypoints' times marked).

    Parameters
    ----------
    sched : CurrentSchedule
    units : actuator_design.io.user_units.UserUnits, optional
        Lengths in the scene's length unit.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax_c = hardware_schedule_axes(sched, units)
    colours = [f"C{k}" for k in range(len(sched.max_current))]
    curves = [(sched.times, sched.currents, "-")]
    if sched.optimal:
        curves.append((sched.greedy_times, sched.greedy_currents, "--"))
    for t, currents, style in curves:
        c = np.asarray(currents, float)
        for k in range(c.shape[1] if c.size else 0):
            ax_c.plot(t, c[:, k], style, color=colours[k], label=f"coil {k + 1}" if style == "-" else None)
    for k, limit in enumerate(sched.max_current):
        ax_c.axhline(limit, color=colours[k], lw=0.6, ls=":")
        ax_c.axhline(-limit, color=colours[k], lw=0.6, ls=":")
    for i in sched.waypoint_index:
        ax_c.axvline(sched.times[i], color="crimson", lw=0.8, ls="--")
    ax_c.set_xlabel("time / s")
    ax_c.set_ylabel("current / A")
    ax_c.legend(fontsize=8, loc="best")
    what = {"energy": "energy", "time": "time"}[sched.objective]
    ax_c.set_title(f"least {what} currents" + (" (dashed: greedy)" if sched.optimal else " NOT used: the greedy ones"),
                   fontsize=10)
    return fig
