"""Figures of a design and of a field schedule: pure drawing, never solves.

* :func:`design_figure` — a :class:`~actuator_design.inverse.design.DesignResult`: the verified
  shape with its target, the fibre layout, the field schedule;
* :func:`schedule_figure` — a :class:`~actuator_design.schedules.schedule.ScheduleResult`: the rod
  at every waypoint and h, φ along the schedule;
* :func:`schedule_animation` / :func:`schedule_gif_bytes` — the rod moving along the schedule;
* :func:`shape_fit_figure` — a :class:`~actuator_design.inverse.shape.ShapeResult`: the
  target points, the fitted centreline and the error at each point.
"""
from __future__ import annotations

import math
from functools import partial

import numpy as np

from actuator_design.viz.shape import plot_shape
from actuator_design.viz.style import gif_bytes, new_figure
from actuator_design.viz.units import field_axis, length_axes

__all__ = ["hardware_schedule_axes", "design_figure", "design_png", "poses_figure", "schedule_figure", "schedule_animation", "schedule_gif_bytes",
           "shape_fit_figure"]


def design_figure(result, units=None, part: str = "whole"):
    """A figure with three or four panels: shape and target, α(s), field schedule (h and φ along
    the path) and, with a robustness report, the tip over the tolerance box.

    Parameters
    ----------
    result : DesignResult
    units : actuator_design.io.user_units.UserUnits, optional
        A physical scene's units: lengths in its length unit, the field in mT.
    part : {"whole", "left", "right"}
        The whole figure, or its left (shape, α) or right (schedule, box) panels alone, at the
        sizes they have in the whole (each half laid out on its own): drawn side by side they show
        what the whole figure shows (:func:`design_png`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    rob = getattr(result, "robustness", None)
    ratios = [1.35, 1, 1, 1][:4 if rob is not None else 3]
    width = 13.5 + 4.2 * (len(ratios) - 3)  # inches, for the whole figure
    spans = {"whole": slice(None), "left": slice(0, 2), "right": slice(2, None)}
    if part not in spans:
        raise ValueError(f"part: must be one of {', '.join(spans)}, got {part!r}")
    span = spans[part]
    mine = ratios[span]
    fig = new_figure((width * sum(mine) / sum(ratios), 4.8))
    axes = list(np.atleast_1d(fig.subplots(1, len(mine), gridspec_kw={"width_ratios": mine})))
    if part != "right":
        _shape_panel(axes.pop(0), result, rob, units)
        _alpha_panel(axes.pop(0), result.design.get("alpha", {}),
                     "fibre layout" + (" (designed)" if "alpha" in result.vary else " (given)"))
    if part != "left":
        _schedule_panel(axes.pop(0), result.schedule, "step of the verified schedule",
                        "field schedule from zero field", units)
        if rob is not None:
            _spread_panel(axes[0], rob, result.target, units)
            length_axes(axes[0], units)
    return fig


def design_png(result, units=None, dpi: int = 150):
    """:func:`design_figure` encoded as PNG (:class:`~.style.FigureBytes`), its two halves drawn at
    once (:func:`~.style.png_side_by_side`; with a vector format asked for, the whole figure)."""
    from actuator_design.viz.style import png_side_by_side

    return png_side_by_side([partial(design_figure, result, units, "left"),
                             partial(design_figure, result, units, "right")], dpi=dpi,
                            whole=partial(design_figure, result, units))


def _shape_panel(ax_shape, result, rob, units) -> None:
    """The verified shape with the target, the tips over the tolerance box and the field."""
    state = result.path.final if result.path is not None else result.forward
    status = getattr(result, "status", "")
    verdict = ("INACCURATE: the mesh does not resolve the design" if status == "inaccurate" else
               "FAILED: see the note" if status == "failed" else
               "verified, stable, snap-free" if result.success else
               "reachable, NOT verified" if result.reachable else "UNREACHABLE: nearest pose shown")
    if state is not None and state.success:
        end_phi = result.schedule[-1].get("phi") if getattr(result, "schedule", None) else None
        plot_shape(state, ax=ax_shape, title=f"design — {verdict}", field_angle=end_phi)
        base = getattr(result, "scene", None)
        if base is not None and base.obstacles and not state.scene.obstacles:
            # a design kept clear of the obstacles is verified without them (no contact on its path):
            # the figure shows them all the same
            from actuator_design.viz.contact import draw_obstacles
            draw_obstacles(ax_shape, base, (*ax_shape.get_xlim(), *ax_shape.get_ylim()))
    else:
        ax_shape.set_title(f"design — {verdict} (no verified state)")
    if result.target:  # a stiffness-only design has no target pose
        tx, ty = result.target[0], result.target[1]
        ax_shape.plot([tx], [ty], marker="x", color="crimson", markersize=12, mew=2.5, ls="none", label="target")
        if len(result.target) > 2:
            a = result.target[2]
            ax_shape.annotate("", xy=(tx + 0.12 * math.cos(a), ty + 0.12 * math.sin(a)), xytext=(tx, ty),
                              arrowprops=dict(arrowstyle="->", color="crimson"))
    if rob is not None and len(_finite_rows(rob.robustness.spread)):
        # every tip the branch passes through over the tolerance box (rays to the corners, edges)
        sp = _finite_rows(rob.robustness.spread)
        ax_shape.plot(sp[:, 0], sp[:, 1], ".", color="tab:blue", markersize=2.5, alpha=0.6,
                      label=f"tip over the box ({rob.robustness.tolerances.describe()})")
        corners = _corner_tips(rob.robustness)
        if corners:
            ax_shape.plot([c["x"] for c in corners], [c["y"] for c in corners], "s", mfc="none",
                          color="tab:blue", markersize=6, label="box corners")
    length_axes(ax_shape, units)
    if ax_shape.get_legend_handles_labels()[0]:
        ax_shape.legend(loc="best", fontsize=8)


def poses_figure(result):
    """One actuator, several poses: every pose's verified shape with its target and tip spread over
    the tolerance box, the shared fibre layout, and the field (h, φ) along the schedule.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((13.5, 4.8))
    ax_shape, ax_alpha, ax_sched = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1.35, 1, 1]})
    colours = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink",
               "tab:olive"]
    for k, p in enumerate(result.poses):
        c = colours[k % len(colours)]
        if p.state is not None and p.state.success:
            d = p.state.evaluate(np.linspace(0.0, 1.0, 150))
            ax_shape.plot(d["x"], d["y"], color=c, lw=2.5, label=f"pose {k + 1}")
        ax_shape.plot([p.target[0]], [p.target[1]], "x", color=c, mew=2.5, markersize=11)
        if p.robustness is not None and len(p.robustness.spread):
            sp = p.robustness.spread
            ax_shape.plot(sp[:, 0], sp[:, 1], ".", color=c, markersize=2)
    ax_shape.plot([0, 1], [0, 0], "--", color="grey", lw=1, label="undeformed")
    ax_shape.set_aspect("equal")
    ax_shape.set_xlabel("x / l")
    ax_shape.set_ylabel("y / l")
    ax_shape.grid(alpha=0.3)
    ax_shape.legend(loc="best", fontsize=8)
    ax_shape.set_title("one actuator, " + ("every pose verified" if result.success else "NOT a success"))
    _alpha_panel(ax_alpha, result.alpha, "shared fibre layout")
    _schedule_panel(ax_sched, result.schedule, "step of the schedule", "field schedule through the poses")
    return fig


def _alpha_panel(ax, alpha, title: str) -> None:
    """The fibre angle α(s) in degrees (``alpha``: {"s", "value"} or empty)."""
    if alpha:
        ax.plot(alpha["s"], np.degrees(alpha["value"]), color="tab:purple")
    ax.set_xlabel("s = X1 / l")
    ax.set_ylabel("fibre angle α(s) / deg")
    ax.set_title(title)
    ax.grid(alpha=0.3)


def _schedule_panel(ax, schedule, xlabel: str, title: str, units=None) -> None:
    """h (left axis, mT ticks for a physical scene) and φ in degrees (right axis) along a schedule."""
    if not schedule:
        ax.text(0.5, 0.5, "no verified schedule", ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
        return
    k = np.arange(len(schedule))
    ax.plot(k, [s["h"] for s in schedule], color="tab:green", label="h")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("field group h", color="tab:green")
    field_axis(ax.yaxis, units)
    ax2 = ax.twinx()
    ax2.plot(k, np.degrees([s["phi"] for s in schedule]), color="tab:orange", label="φ")
    ax2.set_ylabel("field angle φ / deg", color="tab:orange")
    ax.set_title(title)


def _finite_rows(points) -> np.ndarray:
    """The rows of an (k, 2) array of tips whose coordinates are both finite."""
    sp = np.asarray(points, float).reshape(-1, 2)
    return sp[np.all(np.isfinite(sp), axis=1)]


def _corner_tips(rob) -> list:
    """The tips of the box corners the branch reached, where finite."""
    return [c["tip"] for c in rob.corners
            if c.get("reached") and all(math.isfinite(float(c["tip"][k])) for k in ("x", "y"))]


def _spread_panel(ax, report, target, units=None) -> None:
    """The tip over the tolerance box (every state followed on rays and edges), the box corners and
    the reported worst-case error as a circle around the target (units of ℓ; the error's label in
    the length unit of ``units`` when given). Non-finite values (an error that could not be
    bounded, a state that did not converge) are left out and said so."""
    rob = report.robustness
    sp = _finite_rows(rob.spread)
    err = rob.worst_tip_error
    bounded = err is not None and math.isfinite(err)
    if target:
        cx, cy = float(target[0]), float(target[1])
    elif len(sp):
        cx, cy = float(sp[0, 0]), float(sp[0, 1])
    else:
        cx, cy = 0.0, 0.0
    if len(sp):
        ax.plot(sp[:, 0], sp[:, 1], ".", color="tab:blue", markersize=3, label="tip, branch followed")
    corners = _corner_tips(rob)
    if corners:
        ax.plot([c["x"] for c in corners], [c["y"] for c in corners], "s", mfc="none", color="tab:blue",
                markersize=7, label="box corners")
    if bounded:
        r = max(float(err), 1e-9)
        t = np.linspace(0, 2 * math.pi, 200)
        ax.plot(cx + r * np.cos(t), cy + r * np.sin(t), "--", color="crimson", lw=1,
                label=(f"worst-case error {r:.3g} l" if units is None else
                       f"worst-case error {units.length(r):.3g} {units.length_unit}"))
    else:
        reach = np.hypot(sp[:, 0] - cx, sp[:, 1] - cy) if len(sp) else np.zeros(0)
        r = max(float(reach.max()) if reach.size else 0.0, 1e-3)
        ax.text(0.5, 0.95, "worst-case error not bounded (see note)", ha="center", va="top",
                transform=ax.transAxes, fontsize=8, color="crimson")
    if target:
        ax.plot([cx], [cy], "x", color="crimson", mew=2.5, markersize=10, label="target")
    ax.set_xlim(cx - 1.3 * r, cx + 1.3 * r)
    ax.set_ylim(cy - 1.3 * r, cy + 1.3 * r)
    ax.set_aspect("equal")
    ax.set_xlabel("x / l")
    ax.set_ylabel("y / l")
    ax.grid(alpha=0.3)
    verdict = "holds" if getattr(report, "holds", rob.holds) else "does NOT hold"
    ax.set_title(f"tip over the box ({rob.tolerances.describe()}): {verdict}", fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower right", fontsize=7)


def _rod_xy(state, n: int = 150):
    d = state.evaluate(np.linspace(0.0, 1.0, n))
    return d["x"], d["y"]


def hardware_schedule_axes(sched, units=None):
    """(figure, right axes) of a hardware schedule's figure: the rod at every waypoint on the left
    (:func:`waypoint_panel` of ``sched.verification``, when verified) and the right axes for the
    schedule itself against time."""
    fig = new_figure((11, 4.8))
    ax, ax_right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.2, 1]})
    if sched.verification is not None:
        waypoint_panel(ax, sched.verification, units, verified=sched.success)
    return fig, ax_right


def waypoint_panel(ax, result, units=None, verified=None) -> None:
    """The rod at every waypoint of a verified schedule (``result``: a ScheduleResult), its tip path
    and the waypoints, on ``ax`` (rod lengths, or the scene's length unit with ``units``);
    ``verified`` (default ``result.success``) titles it."""
    from matplotlib import cm

    colours = cm.viridis(np.linspace(0, 0.9, len(result.waypoint_index)))
    for k, i in enumerate(result.waypoint_index):
        if i < len(result.states):
            x, y = _rod_xy(result.states[i])
            ax.plot(x, y, color=colours[k], lw=2, label=f"waypoint {k}")
    tips = [(s.tip["x"], s.tip["y"]) for s in result.states]
    if tips:
        ax.plot(*zip(*tips), color="0.6", lw=1, ls=":", label="tip path")
    ax.plot(*zip(*result.waypoints), "x", color="crimson", ms=10, mew=2, label="waypoints")
    ax.plot([0, 0], [-0.12, 0.12], color="k", lw=3)
    ax.set_aspect("equal")
    ax.set_xlabel("x / l")
    ax.set_ylabel("y / l")
    length_axes(ax, units)
    ok = result.success if verified is None else verified
    ax.set_title("rod at the waypoints — " + ("verified, snap-free" if ok else "NOT verified"))
    ax.legend(fontsize=8, loc="best")


def schedule_figure(result, units=None, optimal=None):
    """The rod at every waypoint along a field schedule, the waypoints, and h, φ along the schedule.

    Parameters
    ----------
    result : ScheduleResult
    units : actuator_design.io.user_units.UserUnits, optional
        A physical scene's units: lengths in its length unit, the field in mT.
    optimal : OptimalSchedule, optional
        An optimal-control schedule (``result`` is its ``result``): h and φ are drawn against time
        (s), with the greedy schedule dashed when the optimised one is reported.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((11, 4.8))
    ax, ax_s = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.2, 1]})
    waypoint_panel(ax, result, units)
    ax2 = ax_s.twinx()
    curves = [(optimal.times if optimal is not None else np.arange(len(result.schedule)), result.schedule, "-")]
    if optimal is not None and optimal.optimal:
        curves.append((optimal.greedy_times, optimal.greedy_schedule, "--"))
    for t, sched, style in curves:
        ax_s.plot(t, [s["h"] for s in sched], style, color="tab:green")
        ax2.plot(t, np.degrees([s["phi"] for s in sched]), style, color="tab:orange")
    ax_s.set_ylabel("field group h", color="tab:green")
    field_axis(ax_s.yaxis, units)
    ax2.set_ylabel("field angle φ / deg", color="tab:orange")
    for i in result.waypoint_index:
        ax_s.axvline(curves[0][0][i], color="crimson", lw=0.8, ls="--")
    if optimal is None:
        ax_s.set_xlabel("schedule step (from zero field)")
        ax_s.set_title("field schedule (dashed: waypoints)")
    else:
        ax_s.set_xlabel("time / s")
        ax_s.set_title(f"least {optimal.objective} schedule" + (" (dashed: greedy)" if optimal.optimal else
                                                                " NOT used: the greedy one"), fontsize=10)
    return fig


def schedule_animation(result):
    """The rod along the verified schedule, one frame per schedule point (rod lengths, field arrow).

    Returns
    -------
    matplotlib.animation.FuncAnimation
    """
    from matplotlib.animation import FuncAnimation

    fig = new_figure((5, 5))
    ax = fig.subplots()
    ax.set_aspect("equal")
    ax.set_xlim(-0.6, 1.1)
    ax.set_ylim(-0.85, 0.85)
    ax.plot(*zip(*result.waypoints), "x", color="crimson", ms=9, mew=2)
    ax.plot([0, 0], [-0.1, 0.1], color="k", lw=3)
    (line,) = ax.plot([], [], lw=2.5, color="tab:blue")
    arrow = ax.annotate("", xy=(0, 0), xytext=(0, 0), arrowprops=dict(arrowstyle="->", color="tab:green"))
    text = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9)
    ax.set_xlabel("x / l")
    ax.set_ylabel("y / l")

    def frame(i):
        st, sc = result.states[i], result.schedule[i]
        line.set_data(*_rod_xy(st))
        c = (0.75, 0.65)
        arrow.set_position(c)
        arrow.xy = (c[0] + 0.25 * math.cos(sc["phi"]), c[1] + 0.25 * math.sin(sc["phi"]))
        text.set_text(f"h = {sc['h']:.3f}, φ = {math.degrees(sc['phi']):.1f}°")
        return line, arrow, text

    return FuncAnimation(fig, frame, frames=len(result.states), blit=False)


def schedule_gif_bytes(result, fps: int = 12) -> bytes:
    """The GIF of :func:`schedule_animation` at ``fps`` frames per second."""
    return gif_bytes(schedule_animation(result), fps=fps)


def shape_fit_figure(result, units=None):
    """The target points of a shape design, the designed rod and the error at each point.

    Parameters
    ----------
    result : ShapeResult
        Points (s, x, y) and fitted points in rod lengths, ``state`` the designed equilibrium
        (None when no design was found: the panel shows the targets only).
    units : UserUnits, optional
        A physical scene's units: the shape axes and the error axis in its length unit.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: the shape (equal aspect) and the error |fitted − target| against s.
    """
    fig = new_figure((11.0, 4.6))
    ax_shape, ax_err = fig.subplots(1, 2, width_ratios=[1.3, 1.0])
    pts = np.asarray(result.points, dtype=float).reshape(-1, 3)
    fitted = np.asarray(result.fitted, dtype=float).reshape(-1, 2)
    if result.state is not None and getattr(result.state, "success", False):
        x, y = _rod_xy(result.state)
        ax_shape.plot(x, y, "-", color="C0", lw=2, label="designed rod")
    ax_shape.plot([0.0, 1.0], [0.0, 0.0], ":", color="0.6", lw=1, label="undeformed rod")
    ax_shape.plot(pts[:, 1], pts[:, 2], "o", mfc="none", color="C3", label="target points")
    if len(fitted) == len(pts):
        ax_shape.plot(fitted[:, 0], fitted[:, 1], ".", color="C0", label="rod at the targets' s")
    ax_shape.set_aspect("equal", adjustable="datalim")
    ax_shape.set_xlabel("x / rod lengths")
    ax_shape.set_ylabel("y / rod lengths")
    length_axes(ax_shape, units)
    ax_shape.legend(loc="best", fontsize="small")
    ax_shape.set_title("target shape and design")
    if len(fitted) == len(pts) and len(pts):
        err = np.hypot(fitted[:, 0] - pts[:, 1], fitted[:, 1] - pts[:, 2])
        ax_err.plot(pts[:, 0], err, "o-", color="C3")
    ax_err.set_xlabel("arc length s / rod lengths")
    if units is not None:
        from actuator_design.viz.units import scaled_axis
        scaled_axis(ax_err.yaxis, units.length(1.0), f"error / {units.length_unit}")
    else:
        ax_err.set_ylabel("error / rod lengths")
    ax_err.set_ylim(bottom=0.0)
    ax_err.set_title(f"error at the points (rms {result.rms_error:.3g} rod lengths)"
                     if math.isfinite(result.rms_error) else "no fitted shape")
    return fig
