"""Figures of loading paths and stiffness curves: pure drawing, never solves.

:func:`path_figure` draws a :class:`~actuator_design.continuation.loading.LoadingPath` (tip angle and
energy against the ramped parameter, jumps as dashed arrows, folds, bifurcations and contact
touch-downs and lift-offs marked; a
physical scene's energy in J and ramped field in mT, load in N);
:func:`stiffness_figure` draws a :class:`~actuator_design.analysis.stiffness.StiffnessCurve` with
THEORY §6's closed-form s(h) overlaid (physical scenes: N/m against μ0 H in mT); :func:`load_deflection_figure` draws load against tip
deflection curves (dimensionless or SI).
"""
from __future__ import annotations

import numpy as np

from actuator_design.io.user_units import parameter_physical, parameter_unit_label
from actuator_design.model.units import MU0
from actuator_design.physics.parameters import parameter
from actuator_design.viz.style import new_figure

__all__ = ["path_figure", "stiffness_figure", "load_deflection_figure"]


def _figure(figsize, ncols=1):
    """A figure of ``figsize`` inches with ``ncols`` panels in one row: (fig, 1-D array of axes)."""
    fig = new_figure(figsize)
    return fig, np.atleast_1d(fig.subplots(1, ncols))


def _runs(points):
    """Split path points into runs of one branch and one ramp direction (for line drawing)."""
    runs, cur = [], []
    for p in points:
        if cur and (p.branch != cur[-1].branch or p.direction != cur[-1].direction
                    or p.kind == "landing"):
            runs.append(cur)
            # a new direction starts where the old one ended (the run keeps its own direction)
            cur = [cur[-1]] if p.kind != "landing" and p.branch == cur[-1].branch else []
        cur.append(p)
    if cur:
        runs.append(cur)
    return runs


def path_figure(path, title: str = None, xscale: float = 1.0, xlabel: str = None, units=None):
    """Tip angle and energy along a loading path.

    Parameters
    ----------
    path : LoadingPath
    title : str, optional
    xscale : float
        Factor applied to the ramped parameter on the x axis (e.g. 180/π for degrees).
    xlabel : str, optional
        Label of the x axis (default: the parameter name, or the path coordinate).
    units : actuator_design.io.user_units.UserUnits, optional
        A physical scene's units: the energy in J and, when ``xscale`` is 1, a ramped field in mT
        (μ0 H), a load in N (N m, N/m); a field group the scene cannot convert (χ̄ = 0) stays
        dimensionless and its label says so.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (ax_a, ax_e) = _figure((11.5, 4.6), ncols=2)
    if xlabel is None:
        xlabel = path.param if path.param is not None else "path coordinate t (schedule point index)"
    colours = {1: "C0", -1: "C1", 0: "C0"}
    labelled = set()
    for run in _runs(path.points):
        x = [p.param * xscale for p in run]
        d = run[-1].direction
        lab = {1: f"{xlabel} increasing", -1: f"{xlabel} decreasing", 0: "stable path"}[d]
        # the way back is dashed: where it retraces the way out (no hysteresis) both stay visible
        kw = dict(color=colours[d], lw=1.8, ls=(0, (5, 3)) if d == -1 else "-",
                  label=None if lab in labelled else lab)
        labelled.add(lab)
        ax_a.plot(x, [p.tip["angle"] for p in run], **kw)
        ax_e.plot(x, [p.energy for p in run], **kw)
    for j in path.jumps:
        for ax, a, b in ((ax_a, j.from_state.tip["angle"], j.to_state.tip["angle"]),
                         (ax_e, j.from_state.energy, j.to_state.energy)):
            ax.annotate("", xy=(j.param * xscale, b), xytext=(j.param * xscale, a),
                        arrowprops=dict(arrowstyle="-|>", color="C3", ls="--", lw=1.4))
            ax.plot([j.param * xscale], [a], "o", color="C3", ms=5)
    if path.jumps:
        ax_a.plot([], [], color="C3", ls="--", label="snap-through (fold)")
    for b in path.bifurcations:
        ax_a.plot([b.param * xscale], [b.state.tip["angle"]], "s", color="C2", ms=6,
                  label="continuous bifurcation" if b is path.bifurcations[0] else None)
    for kind, marker in (("touch-down", "v"), ("lift-off", "^")):  # contact events (paths with obstacles)
        pts = [p for p in path.points if p.kind == kind]
        for ax, key in ((ax_a, "angle"), (ax_e, None)):
            ax.plot([p.param * xscale for p in pts], [p.tip[key] if key else p.energy for p in pts], marker,
                    color="C4" if kind == "touch-down" else "C5", ms=7, ls="none",
                    label=(kind if ax is ax_a and pts else None), zorder=5)
    ax_a.set_xlabel(xlabel)
    ax_a.set_ylabel("tip angle θ(1) [rad]")
    ax_e.set_xlabel(xlabel)
    ax_e.set_ylabel("energy [B0/l]")
    hy = path.hysteresis
    text = "snap-free" if path.snap_free else f"{len(path.jumps)} snap(s)"
    if hy.get("loops"):
        text += f"; hysteresis width {hy['width'] * xscale:.4g}, loop area {hy['area'] * xscale:.4g}"
    ax_a.set_title(title or f"loading path — {text}", fontsize=10)
    ax_e.set_title("energy along the path", fontsize=10)
    ax_a.legend(loc="best", fontsize=8)
    for ax in (ax_a, ax_e):
        ax.grid(alpha=0.3)
    if units is not None:
        _physical_path_axes(path, (ax_a, ax_e), units, xlabel if xscale == 1.0 else None, title is None)
    return fig


def _physical_path_axes(path, axes, units, xlabel, retitle: bool = True) -> None:
    """Energy in J; the ramped parameter (``xlabel`` given: in its own unit) in mT, N, N m or N/m."""
    from actuator_design.viz.units import parameter_axis, scaled_axis

    ax_a, ax_e = axes
    scaled_axis(ax_e.yaxis, units.moment_scale, "energy / J")
    if xlabel is None or path.param is None:
        return
    try:
        p = parameter(path.param)
    except ValueError:
        return
    label = parameter_unit_label(p, units)
    hi = max((pt.param for pt in path.points), default=0.0)
    for ax in axes:
        parameter_axis(ax, p, units, xlabel, "x", data_max=hi)
    hy = path.hysteresis
    if retitle and label is not None and p.transform != "sqrt" and hy.get("loops"):
        ax_a.set_title(f"loading path — {len(path.jumps)} snap(s); hysteresis width "
                       f"{parameter_physical(p, hy['width'], units):.4g} {label}", fontsize=10)


def stiffness_figure(curve, title: str = None, si: bool = False, stiffness_scale: float = None):
    """Vertical tip stiffness against the field, with THEORY §6's s(h) overlaid.

    Parameters
    ----------
    curve : StiffnessCurve
    title : str, optional
    si : bool
        Plot N/m against the field μ0 H in mT (physical scenes) instead of the dimensionless
        values; without a field scale (χ̄ = 0) the field axis stays the group h, and says so.
    stiffness_scale : float, optional
        B0/ℓ³ in N/m (for the closed form in N/m; default: from the curve's N/m values).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (ax,) = _figure((6.6, 4.8))
    has_field = curve.field_A_per_m is not None and np.all(np.isfinite(curve.field_A_per_m))
    use_si = si and curve.vertical_N_per_m is not None
    if use_si:
        scale = stiffness_scale if stiffness_scale is not None else float(
            np.nanmedian(curve.vertical_N_per_m / curve.vertical))
        y, ref = curve.vertical_N_per_m, curve.lowload * scale
        if has_field:
            x = curve.field_A_per_m * MU0 * 1e3
            ax.set_xlabel("field μ0H [mT]")
        else:
            x = curve.h
            ax.set_xlabel("field group h (dimensionless: this scene has no field scale)")
        ax.set_ylabel("tip stiffness K [N/m]")
    else:
        x, y, ref = curve.h, curve.vertical, curve.lowload
        ax.set_xlabel("field group h")
        ax.set_ylabel("tip stiffness dp/dv1 [B0/l³]")
    ok = curve.success
    ax.plot(x[ok], y[ok], "o-", color="C0", ms=3.5, lw=1.6, label="computed (tangent stiffness)")
    if np.any(ok & ~curve.stable):
        bad = ok & ~curve.stable
        ax.plot(x[bad], y[bad], "x", color="C3", label="unstable state")
    lab = "closed form s(h) (THEORY §6)" + ("" if curve.lowload_applies else ", φ = 0, p = 0 only")
    ax.plot(x, ref, "--", color="k", lw=1.2, label=lab)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "tip stiffness against field", fontsize=10)
    return fig


def load_deflection_figure(curves, xlabel: str, ylabel: str, title: str = None, slopes=None):
    """Load against tip deflection for several fields.

    Parameters
    ----------
    curves : list of (label, deflection ndarray (n,), load ndarray (n,))
    xlabel, ylabel : str
    title : str, optional
    slopes : list of float or None, optional
        Low-load stiffness per curve (load per deflection), drawn as dashed lines from the origin.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (ax,) = _figure((6.8, 5.0))
    for i, (label, v, P) in enumerate(curves):
        ax.plot(v, P, color=f"C{i}", lw=1.8, label=label)
        if slopes is not None and slopes[i] is not None and np.isfinite(slopes[i]):
            vv = np.linspace(0, np.nanmax(v) * 0.6, 2)
            ax.plot(vv, slopes[i] * vv, "--", color=f"C{i}", lw=1.0)
    if slopes is not None:
        ax.plot([], [], "--", color="0.3", lw=1.0, label="low-load stiffness s(h) (THEORY §6)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "load against tip deflection", fontsize=10)
    return fig
