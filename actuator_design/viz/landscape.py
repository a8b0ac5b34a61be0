"""Drawing the equilibrium landscape: pure, never solves.

* :func:`plot_equilibria` — the shapes of all equilibria of a scene, stable solid, unstable dashed;
* :func:`plot_branches` — parameter against tip angle for continued branches, stable solid,
  unstable dashed, folds (circles) and branch points (squares) marked;
* :func:`plot_multiplicity` — a multiplicity map (counts as colours) with critical curves overlaid;
* :func:`plot_landscape_map` — the total and the stable counts side by side, bistable regions
  (two or more stable states) hatched, points whose scan cannot be trusted (−1) in grey.

Every function takes result objects of :mod:`actuator_design.analysis` (or their plain arrays) and
an optional matplotlib ``Axes`` (a new figure when omitted) and returns the axes; units are those of the results (rod lengths, rad, dimensionless
parameters).
"""
from __future__ import annotations

import math
from typing import Iterable, Optional, Sequence

import numpy as np

from actuator_design.viz.style import new_axes

__all__ = ["plot_equilibria", "plot_branches", "plot_multiplicity", "plot_landscape_map"]


def plot_equilibria(result, ax=None, title: Optional[str] = None, points: int = 200, units=None):
    """Draw every equilibrium of an :class:`~actuator_design.analysis.equilibria_found.EquilibriaResult`.

    Stable shapes solid, unstable dashed; the legend gives θ'(0), the Morse index and flags
    self-intersecting shapes. With a physical scene's ``units``
    (:class:`~actuator_design.io.user_units.UserUnits`) the axes are in the length unit of
    ``rod.length``, θ'(0) in rad per that unit and the title gives the field in mT and loads in N.
    """
    from actuator_design.viz.units import groups_text, length_axes

    ax = ax or new_axes()
    s = np.linspace(0.0, 1.0, points)
    for k, e in enumerate(result.equilibria):
        d = e.result.evaluate(s)
        gamma = (f"γ = {e.gamma:.4g}" if units is None else
                 f"γ = {e.gamma / units.length(1.0):.4g} rad/{units.length_unit}")
        label = (f"{gamma}, " + ("stable" if e.stable else f"index {e.morse_index}")
                 + (", self-intersecting" if e.self_intersecting else ""))
        ax.plot(d["x"], d["y"], lw=2.2 if e.stable else 1.4, ls="-" if e.stable else "--",
                color=f"C{k % 10}", label=label)
    ax.plot([0, math.cos(result.scene.theta0)], [0, math.sin(result.scene.theta0)], color="0.6",
            ls=":", lw=1, label="undeformed")
    ax.plot([0], [0], marker="s", color="k", ms=6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x / l")
    ax.set_ylabel("y / l")
    length_axes(ax, units)
    noun = "equilibrium" if result.count == 1 else "equilibria"
    ax.set_title(title or (f"{result.count} {noun} ({result.stable_count} stable): "
                           + groups_text(result.scene, units)), fontsize=10)
    ax.legend(fontsize=7, loc="best")
    return ax


def _segments(lam, y, stable):
    """Split a branch into runs of equal stability, each sharing its end point with the next.

    A step between a stable and an unstable point belongs to the unstable run: the branch's
    located stability changes are points of it (:mod:`actuator_design.analysis.stability_changes`,
    with the index on the stable side), so a stable run ends exactly where stability is lost.
    """
    runs, start = [], 0
    n = len(lam)
    while start < n - 1 or (start == 0 and n == 1):
        if n == 1:
            return [(lam, y, bool(stable[0]))]
        st = bool(stable[start]) and bool(stable[start + 1])
        end = start + 1
        while end < n - 1 and (bool(stable[end]) and bool(stable[end + 1])) == st:
            end += 1
        runs.append((lam[start:end + 1], y[start:end + 1], st))
        start = end
    return runs


def plot_branches(branches: Iterable, ax=None, param_label: Optional[str] = None,
                  quantity: str = "tip_angle", title: Optional[str] = None, reference=None):
    """Parameter against tip angle (or ``"tip_x"``, ``"tip_y"``, ``"energy"``) for branches.

    Parameters
    ----------
    branches : iterable of Branch
    reference : sequence of (x, y, label), optional
        Reference curves (e.g. a closed form) drawn thin and black.
    """
    ax = ax or new_axes()
    branches = list(branches)
    col = {"tip_angle": 0, "tip_x": 1, "tip_y": 2}
    name = None
    for k, br in enumerate(branches):
        name = br.param
        y = br.energy if quantity == "energy" else br.tips[:, col[quantity]]
        for lam, yy, st in _segments(br.lam, y, br.morse_index == 0):
            ax.plot(lam, yy, color=f"C{k % 10}", ls="-" if st else "--", lw=1.8 if st else 1.2)
        for cp in br.folds:
            v = cp.energy if quantity == "energy" else (cp.tip["angle"] if quantity == "tip_angle" else
                                                         cp.tip["x" if quantity == "tip_x" else "y"])
            ax.plot([cp.value], [v], "o", mfc="none", mec="k", ms=7)
        for cp in br.branch_points:
            v = cp.energy if quantity == "energy" else (cp.tip["angle"] if quantity == "tip_angle" else
                                                         cp.tip["x" if quantity == "tip_x" else "y"])
            ax.plot([cp.value], [v], "s", mfc="none", mec="r", ms=7)
    for xr, yr, lab in (reference or []):
        ax.plot(xr, yr, color="k", lw=0.7, ls=":", label=lab)
    drawn = branches  # the legend names only what is drawn
    stab = [bool(np.any(b.morse_index == 0)) for b in drawn]
    unstab = [bool(np.any(b.morse_index != 0)) for b in drawn]
    if any(stab):
        ax.plot([], [], color="0.3", ls="-", label="stable")
    if any(unstab):
        ax.plot([], [], color="0.3", ls="--", label="unstable")
    if any(b.folds for b in drawn):
        ax.plot([], [], "o", mfc="none", mec="k", label="fold")
    if any(b.branch_points for b in drawn):
        ax.plot([], [], "s", mfc="none", mec="r", label="branch point")
    ax.set_xlabel(param_label or (name or "parameter"))
    ax.set_ylabel({"tip_angle": "tip angle θ(1) [rad]", "tip_x": "x(1) / l", "tip_y": "y(1) / l",
                   "energy": "energy [B0/l]"}[quantity])
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="best")
    return ax


def plot_multiplicity(mmap, curves: Sequence = (), ax=None, stable: bool = False,
                      title: Optional[str] = None):
    """A multiplicity map (number of equilibria, or of stable ones) with critical curves.

    Parameters
    ----------
    mmap : MultiplicityMap
    curves : sequence of FoldCurve (or objects with ``mu``, ``lam``)
        Drawn as lines in the (x, y) plane of the map: μ along x, λ along y (or swapped when the
        curve's ``param`` is the map's x parameter).
    stable : bool
        Colour by the number of stable equilibria instead.
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap
    ax = ax or new_axes()
    data = np.ma.masked_less(mmap.stable if stable else mmap.counts, 0)  # -1: unknown, not drawn
    vals = np.unique(data.compressed()) if data.count() else np.array([0])
    cmap = ListedColormap([f"C{k % 10}" for k in (2, 1, 8, 3, 4, 5, 6, 7, 9, 0)][:max(1, len(vals))])
    bounds = np.append(vals - 0.5, vals[-1] + 0.5)
    norm = BoundaryNorm(bounds, cmap.N)
    mesh = ax.pcolormesh(mmap.x, mmap.y, data, shading="nearest", cmap=cmap, norm=norm, alpha=0.85)
    cb = ax.figure.colorbar(mesh, ax=ax, ticks=vals)
    cb.set_label("stable equilibria" if stable else "equilibria")
    for k, c in enumerate(curves):
        if getattr(c, "param", None) == mmap.x_param:
            ax.plot(c.lam, c.mu, color="k", lw=1.6)
        else:
            ax.plot(c.mu, c.lam, color="k", lw=1.6, label="critical curves (folds)" if k == 0 else None)
    ax.set_xlim(mmap.x.min(), mmap.x.max())
    ax.set_ylim(mmap.y.min(), mmap.y.max())
    ax.set_xlabel({"h2": "h²"}.get(mmap.x_param, mmap.x_param))
    ax.set_ylabel({"h2": "h²"}.get(mmap.y_param, mmap.y_param))
    ax.set_title(title or "number of " + ("stable " if stable else "") + "equilibria", fontsize=10)
    if len(curves):
        ax.legend(fontsize=8, loc="upper left")
    return ax


def plot_landscape_map(mmap, curves: Sequence = (), title: Optional[str] = None):
    """Two panels: the number of equilibria and the number of stable ones, bistable regions
    (stable count ≥ 2) hatched on the second, critical curves on both, untrusted points grey.

    Parameters
    ----------
    mmap : MultiplicityMap
    curves : sequence of FoldCurve
    title : str, optional
        Figure title.

    Returns
    -------
    ndarray of Axes, shape (2,)
    """
    from actuator_design.viz.style import new_axes_grid
    fig, axes = new_axes_grid(1, 2, panel_size=(6.4, 5.2))
    axes = np.ravel(axes)
    for ax, st in zip(axes, (False, True)):
        unknown = np.ma.masked_where(mmap.counts >= 0, np.ones_like(mmap.counts, float))
        if unknown.count():
            ax.pcolormesh(mmap.x, mmap.y, unknown, shading="nearest", cmap="Greys", vmin=0, vmax=2)
        plot_multiplicity(mmap, curves, ax=ax, stable=st)
    bi = np.asarray(mmap.stable >= 2, float)
    if bi.any() and min(bi.shape) >= 2:
        axes[1].contourf(mmap.x, mmap.y, bi, levels=[0.5, 1.5], colors="none", hatches=["//"])
        axes[1].contour(mmap.x, mmap.y, bi, levels=[0.5], colors="k", linewidths=1.0)
        from matplotlib.patches import Patch
        handles, labels = axes[1].get_legend_handles_labels()
        handles.append(Patch(facecolor="none", edgecolor="k", hatch="//", lw=1.0))
        labels.append("bistable (≥ 2 stable)")
        axes[1].legend(handles, labels, fontsize=8, loc="upper left")
    axes[1].set_title("number of stable equilibria (bistable hatched)", fontsize=10)
    if title:
        fig.suptitle(title, fontsize=11)
    return axes
