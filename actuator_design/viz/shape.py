"""The shape of one equilibrium: pure drawing, never solves.

:func:`plot_shape` draws the deformed rod, the undeformed rod, the clamp, the applied field and the
tip force of an :class:`~actuator_design.equilibrium.result.EquilibriumResult` in rod lengths (x / l, y / l),
or, given a physical scene's user units, with axes in the unit of ``rod.length``, the field as
μ0 H in mT and the tip force in N; :func:`shape_figure` is the figure of ``solve --out``
(``shape.png``).
"""
from __future__ import annotations

import math

import numpy as np

from actuator_design.io.display import degrees
from actuator_design.model.scene import DipoleField, UniformField
from actuator_design.model.sources import loops
from actuator_design.physics.fields import field_model
from actuator_design.physics.registry import end_force
from actuator_design.viz.style import new_axes

__all__ = ["plot_shape", "shape_figure"]

#: Points of the dense deformed shape.
DENSE_POINTS = 300


#: Size in inches of the figure of one shape.
SHAPE_FIGSIZE = (6.4, 5.6)


def plot_shape(result, ax=None, title=None, units=None, field_angle=None):
    """Draw an equilibrium: rod, undeformed rod, clamp, field and tip force.

    Parameters
    ----------
    result : EquilibriumResult
        The equilibrium to draw (converged or not; a non-finite shape draws nothing).
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; a new Agg figure is made when omitted.
    title : str, optional
        Title; default: h, φ (deg), p and the stability verdict.
    units : actuator_design.io.user_units.UserUnits, optional
        A physical scene's units: axes ticked in the length unit of ``rod.length``, the field as
        μ0 H in mT and the tip force in N (in the labels and the default title).
    field_angle : float, optional
        The angle (rad) to draw a uniform field at, when the user set the field along the same
        axis the other way round (a soft-magnetic rod's energy is the same for φ and φ + π,
        THEORY §5): the figure then shows the angle the text reports, and that the scene's angle
        is the same axis.

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        ax = new_axes(SHAPE_FIGSIZE)
    scene = result.scene
    d = result.evaluate(np.linspace(0.0, 1.0, DENSE_POINTS))
    x, y = np.asarray(d["x"], float), np.asarray(d["y"], float)
    t0 = float(scene.theta0)
    s = np.linspace(0.0, 1.0, 2)
    ux, uy = s * math.cos(t0), s * math.sin(t0)
    window = _window(np.r_[x, ux, 0.0], np.r_[y, uy, 0.0], scene.field)

    _draw_field(ax, scene, window, np.r_[x, ux], np.r_[y, uy], units, field_angle)
    if scene.obstacles:
        from actuator_design.viz.contact import draw_contact_forces, draw_obstacles
        draw_obstacles(ax, scene, window)
        draw_contact_forces(ax, result, window)
    ax.plot(ux, uy, ls="--", color="0.55", lw=1.2, label="undeformed", zorder=2)
    ax.plot(x, y, color="C0", lw=2.6, label="deformed", zorder=4)
    _draw_clamp(ax, t0)
    _draw_end_force(ax, scene, result.tip, window, units)

    ax.set_xlim(window[0], window[1])
    ax.set_ylim(window[2], window[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x / l")
    ax.set_ylabel("y / l")
    from actuator_design.viz.units import length_axes
    length_axes(ax, units)
    ax.set_title(_default_title(result, units) if title is None else title, fontsize=10)
    ax.legend(loc="best", fontsize=8, framealpha=0.85)
    return ax


def shape_figure(result, title=None, units=None):
    """A new figure holding :func:`plot_shape` of ``result`` (``units``: see there).

    Returns
    -------
    matplotlib.figure.Figure
    """
    return plot_shape(result, title=title, units=units).figure


# -- pieces ---------------------------------------------------------------------------------------
def _default_title(result, units=None) -> str:
    scene = result.scene
    from actuator_design.viz.units import load_text, scene_field_text
    parts = [scene_field_text(scene, units)]
    if isinstance(scene.field, UniformField):
        parts.append(f"φ = {math.degrees(scene.field.phi):.4g}°")
    elif scene.field is not None:
        parts.append(f"{scene.field.kind} field")
    parts.append(load_text(scene.p, units))
    verdict = "stable" if result.stable else f"unstable (Morse index {result.morse_index})"
    if not result.success:
        verdict = "NOT CONVERGED, " + verdict
    return ", ".join(parts) + " — " + verdict


def _window(xs, ys, field):
    """Square-ish plot window around the finite points (and a dipole), with a margin."""
    xs, ys = list(xs[np.isfinite(xs)]), list(ys[np.isfinite(ys)])
    if isinstance(field, DipoleField):
        xs.append(field.x0)
        ys.append(field.y0)
    for t in getattr(field, "terms", ()):  # magnets and coils beside the rod (not those around it)
        if t.kind == "exterior":
            xs.append(t.centre[0])
            ys.append(t.centre[1])
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    span = max(x1 - x0, y1 - y0, 1.0)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    half = 0.5 * span + 0.35
    return cx - half, cx + half, cy - half, cy + half


def _draw_clamp(ax, t0: float) -> None:
    """A wall at the origin, perpendicular to the clamp direction, hatched on the far side."""
    from matplotlib.patches import Polygon
    t = np.array([math.cos(t0), math.sin(t0)])
    n = np.array([-t[1], t[0]])
    w, depth = 0.14, 0.07
    a, b = -w * n, w * n
    ax.add_patch(Polygon([a, b, b - depth * t, a - depth * t], closed=True, facecolor="none",
                         edgecolor="0.25", hatch="////", lw=0.0, zorder=3, label="clamp"))
    ax.plot([a[0], b[0]], [a[1], b[1]], color="k", lw=2.2, zorder=3)


def _draw_field(ax, scene, window, xs, ys, units=None, field_angle=None) -> None:
    field = scene.field
    if field is None:
        return
    if isinstance(field, UniformField):
        same_axis = None
        if field_angle is not None and abs(math.remainder(field_angle - field.phi, math.pi)) < 1e-9:
            same_axis, phi = (field.phi if abs(math.remainder(field_angle - field.phi, 2 * math.pi)) > 1e-9
                              else None), field_angle
        else:
            phi = field.phi
        _draw_uniform(ax, phi, scene.h, window, xs, ys, units, same_axis)
        return
    _draw_streamlines(ax, field, scene, window, units)
    if getattr(field, "kind", "") == "sources":
        _draw_sources(ax, field)
    if isinstance(field, DipoleField):
        ax.plot([field.x0], [field.y0], marker="o", ms=9, color="C3", zorder=5, ls="none",
                label="dipole")
        m = 0.12 * np.array([math.cos(field.moment_angle), math.sin(field.moment_angle)])
        ax.annotate("", xy=(field.x0 + m[0], field.y0 + m[1]), xytext=(field.x0 - m[0], field.y0 - m[1]),
                    arrowprops=dict(arrowstyle="-|>", color="C3", lw=1.8), zorder=6)


def _draw_sources(ax, field) -> None:
    """Magnets (their section in the plane, the north pole's arrow) and coils (their windings'
    sections, two dots a loop), in units of ℓ, where the field's placements put them."""
    from matplotlib.patches import Circle, Polygon
    for k, (src, (dx, dy, turn)) in enumerate(zip(field.sources, field.source_placements())):
        c = np.array(src.position) / field.length + (dx, dy)
        e = np.array([math.cos(src.axis_angle + turn), math.sin(src.axis_angle + turn)])
        n = np.array([-e[1], e[0]])
        label = "magnet" if k == 0 else None
        if hasattr(src, "field_per_amp"):  # a calibration map's coil: the map's region, once
            t = field.placed_terms()[k]
            if k == 0:
                ax.add_patch(Circle(t.centre, t.valid_radius, fill=False, ls="--", lw=0.8, edgecolor="0.5",
                                     zorder=1, label="calibration map's region"))
            continue
        if hasattr(src, "shape"):
            r = 0.5 * src.diameter / field.length
            if src.shape in ("sphere", "diametric_cylinder"):  # its section in the plane: a disc
                ax.add_patch(Circle(c, r, facecolor="0.85", edgecolor="C3", lw=1.2, zorder=4, label=label))
                half = r
            else:  # a cylinder's or a cuboid's section: height along its axis, diameter or width across
                half = 0.5 * src.height / field.length
                r = 0.5 * src.width / field.length if src.shape == "cuboid" else r
                box = [c + a * half * e + b * r * n for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
                ax.add_patch(Polygon(box, closed=True, facecolor="0.85", edgecolor="C3", lw=1.2, zorder=4,
                                     label=label))
            ax.annotate("", xy=c + 0.8 * half * e, xytext=c - 0.8 * half * e,
                        arrowprops=dict(arrowstyle="-|>", color="C3", lw=1.4), zorder=6)
            continue
        pts = np.array([c + off / field.length * e + side * src.radius / field.length * n
                        for off, _ in loops(src) for side in (-1, 1)])
        ax.plot(pts[:, 0], pts[:, 1], ls="none", marker="s", ms=4, color="C1", zorder=4,
                label=f"{src.kind} windings")


def _draw_uniform(ax, phi: float, h: float, window, xs, ys, units=None, same_axis=None) -> None:
    """Three parallel arrows in direction φ, labelled with h, in the corner farthest from the rod
    (``same_axis``: the scene's own angle, the same field axis, named in the label)."""
    x0, x1, y0, y1 = window
    w = x1 - x0
    e = np.array([math.cos(phi), math.sin(phi)])
    n = np.array([-e[1], e[0]])
    size = 0.08 * w
    corners = [np.array([cx, cy]) for cx in (x0 + 0.14 * w, x1 - 0.14 * w)
               for cy in (y1 - 0.12 * w, y0 + 0.2 * w)]
    pts = np.column_stack([xs, ys])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    centre = max(corners, key=lambda c: np.min(np.hypot(*(pts - c).T)) if len(pts) else 0.0)
    for k in (-1, 0, 1):
        c = centre + 0.45 * size * k * n
        ax.annotate("", xy=c + size * e, xytext=c - size * e,
                    arrowprops=dict(arrowstyle="-|>", color="C2", lw=1.6), zorder=5)
    from actuator_design.viz.units import field_text
    axis_note = "" if same_axis is None else f"\n(the same axis as {degrees(same_axis, '.4g')}°)"
    ax.text(centre[0], centre[1] - 1.25 * size,
            f"field: {field_text(h, units)}, φ = {degrees(phi, '.4g')}°{axis_note}",
            color="C2", ha="center", va="top", fontsize=8, zorder=5)


def _draw_streamlines(ax, field, scene, window, units=None, n: int = 41) -> None:
    """Streamlines of the field direction ĥ/|ĥ| over the window, masked near singularities."""
    model = field_model(field)
    gx = np.linspace(window[0], window[1], n)
    gy = np.linspace(window[2], window[3], n)
    X, Y = np.meshgrid(gx, gy)
    with np.errstate(all="ignore"):
        H = model.evaluate(X.ravel(), Y.ravel(), model.parameter_values(field))
        U, V = H[0].reshape(X.shape), H[1].reshape(X.shape)
        mag = np.hypot(U, V)
        bad = ~np.isfinite(mag) | (mag == 0)
        if isinstance(field, DipoleField):
            bad |= np.hypot(X - field.x0, Y - field.y0) < 0.06 * (window[1] - window[0])
        for t in getattr(field, "terms", ()):  # a fitted field is known only where its fit holds
            bad |= ~t.contains(X, Y)
        finite = mag[~bad]
        if finite.size:  # points where |ĥ| explodes (other singularities)
            bad |= mag > 1e3 * np.median(finite)
        U = np.ma.masked_array(np.where(bad, 0.0, U / np.where(bad, 1.0, mag)), mask=bad)
        V = np.ma.masked_array(np.where(bad, 0.0, V / np.where(bad, 1.0, mag)), mask=bad)
    if np.all(bad):
        return
    ax.streamplot(gx, gy, U, V, color="C2", linewidth=0.7, density=1.1, arrowsize=0.8, zorder=1)
    from actuator_design.viz.units import scene_field_text
    ax.plot([], [], color="C2", lw=0.7, label=f"field direction ({field.kind}, {scene_field_text(scene, units)})")


def _draw_end_force(ax, scene, tip, window, units=None) -> None:
    """An arrow of fixed length at the tip in the direction of the tip force, labelled."""
    f = end_force(scene)  # the dead force the terms apply at the tip
    if f is None:
        return
    fx, fy = f
    mag = math.hypot(fx, fy)
    tx, ty = float(tip["x"]), float(tip["y"])
    if mag == 0.0 or not (math.isfinite(tx) and math.isfinite(ty)):
        return
    L = 0.12 * (window[1] - window[0])
    e = np.array([fx, fy]) / mag
    ax.annotate("", xy=(tx + L * e[0], ty + L * e[1]), xytext=(tx, ty),
                arrowprops=dict(arrowstyle="-|>", color="C3", lw=2.0), zorder=6)
    if units is not None:  # in N
        k = units.force_scale
        label = (f"p = {fy * k:.4g}" if fx == 0.0 else f"f = ({fx * k:.4g}, {fy * k:.4g})") + " N"
    else:
        label = (f"p = {fy:.4g}" if fx == 0.0 else f"f = ({fx:.4g}, {fy:.4g})") + " B0/l²"
    ax.text(tx + 1.15 * L * e[0], ty + 1.15 * L * e[1], label, color="C3", fontsize=8,
            ha="left" if e[0] >= 0 else "right", va="bottom" if e[1] >= 0 else "top", zorder=6)
