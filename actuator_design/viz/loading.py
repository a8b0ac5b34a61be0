"""Figures of loading paths and stiffness curves: pure drawing, never solves.

:func:`path_figure` draws a :class:`~actuator_design.analysis.loading.LoadingPath` (tip angle and
energy against the ramped parameter, jumps as dashed arrows, folds and bifurcations marked);
:func:`stiffness_figure` draws a :class:`~actuator_design.analysis.stiffness.StiffnessCurve` with
THEORY §6's closed-form s(h) overlaid; :func:`load_deflection_figure` draws load against tip
deflection curves (dimensionless or SI).
"""
from __future__ import annotations

import numpy as np

from .style import new_figure

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
            if p.kind != "landing" and p.branch == cur[-1].branch:
                cur.append(p)  # a new direction starts where the old one ended
            runs.append(cur)
            cur = []
        cur.append(p)
    if cur:
        runs.append(cur)
    return runs


def path_figure(path, title: str = None, xscale: float = 1.0, xlabel: str = None):
    """Tip angle and energy along a loading path.

    Parameters
    ----------
    path : LoadingPath
    title : str, optional
    xscale : float
        Factor applied to the ramped parameter on the x axis (e.g. 180/π for degrees).
    xlabel : str, optional
        Label of the x axis (default: the parameter name, or the path coordinate).

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
        kw = dict(color=colours[d], lw=1.8, label=None if lab in labelled else lab)
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
    return fig


def stiffness_figure(curve, title: str = None, si: bool = False):
    """Vertical tip stiffness against the field, with THEORY §6's s(h) overlaid.

    Parameters
    ----------
    curve : StiffnessCurve
    title : str, optional
    si : bool
        Plot N/m against A/m (physical scenes) instead of the dimensionless values.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (ax,) = _figure((6.6, 4.8))
    use_si = si and curve.field_A_per_m is not None and np.all(np.isfinite(curve.field_A_per_m))
    if use_si:
        x, y = curve.field_A_per_m / 1e3, curve.vertical_N_per_m
        ref = curve.lowload * (curve.vertical_N_per_m / curve.vertical)
        ax.set_xlabel("field H [kA/m]")
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
