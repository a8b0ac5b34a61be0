"""The figure of a schedule over a magnet's pose (:mod:`actuator_design.schedules.pose_schedule`)."""
from __future__ import annotations

import math

import numpy as np

from actuator_design.viz.design import hardware_schedule_axes

__all__ = ["pose_schedule_figure"]


def pose_schedule_figure(sched, units=None):
    """The rod at every waypoint (left) and the magnet's position (mm) and axis angle (deg) against
    time (right; the waypoints' times marked).

    Parameters
    ----------
    sched : PoseSchedule
    units : actuator_design.io.user_units.UserUnits, optional
        Lengths in the scene's length unit (left panel).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax_p = hardware_schedule_axes(sched, units)
    pos = np.asarray(sched.positions, float).reshape(-1, 2) * 1e3
    ax_p.plot(sched.times, pos[:, 0], "-", color="C0", label="x / mm")
    ax_p.plot(sched.times, pos[:, 1], "-", color="C1", label="y / mm")
    ax_a = ax_p.twinx()
    ax_a.plot(sched.times, [math.degrees(a) for a in sched.axis_angles], "-", color="C2", label="axis / deg")
    ax_a.set_ylabel("axis angle / deg", color="C2")
    for i in sched.waypoint_index:
        ax_p.axvline(sched.times[i], color="crimson", lw=0.8, ls="--")
    ax_p.set_xlabel("time / s")
    ax_p.set_ylabel("magnet position / mm")
    lines = ax_p.get_lines()[:2] + ax_a.get_lines()[:1]
    ax_p.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="best")
    rates = [f"{sched.speed * 1e3:.3g} mm/s" if math.isfinite(sched.speed) else "",
             f"{math.degrees(sched.turn_rate):.3g} deg/s" if math.isfinite(sched.turn_rate) else ""]
    ax_p.set_title(f"the magnet's stage ({', '.join(r for r in rates if r)})", fontsize=10)
    return fig
