"""Obstacles and contact forces in the shape figure (:mod:`actuator_design.contact`)."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["draw_obstacles", "draw_contact_forces"]


def draw_obstacles(ax, scene, window) -> None:
    """Walls as a hatched band behind their line, pegs as grey discs (units of ℓ)."""
    from matplotlib.patches import Circle, Polygon

    x0, x1, y0, y1 = window
    span = max(x1 - x0, y1 - y0)
    for k, ob in enumerate(scene.obstacles):
        label = "obstacle" if k == 0 else None
        if ob.kind == "peg":
            ax.add_patch(Circle(ob.centre, ob.radius, facecolor="0.8", edgecolor="0.3", lw=1.0, zorder=3,
                                label=label))
            continue
        n = np.array([math.cos(ob.normal_angle), math.sin(ob.normal_angle)])
        t = np.array([-n[1], n[0]])
        p = np.array(ob.point)
        a, b = p - 2 * span * t, p + 2 * span * t
        depth = 0.04 * span
        ax.add_patch(Polygon([a, b, b - depth * n, a - depth * n], closed=True, facecolor="0.85",
                             edgecolor="0.3", hatch="////", lw=0.0, zorder=3, label=label))
        ax.plot([a[0], b[0]], [a[1], b[1]], color="0.3", lw=1.2, zorder=3)


def draw_contact_forces(ax, result, window) -> None:
    """An arrow at each contact point, the force the obstacle exerts on the rod, the largest
    drawn 12 % of the window long."""
    contact = result.contact
    pts = [p for p in (contact or {}).get("points", []) if not p["weak"]]
    if not pts:
        return
    big = max(math.hypot(*p["force"]) for p in pts)
    if not big > 0:
        return
    size = 0.12 * (window[1] - window[0])
    for k, p in enumerate(pts):
        f = np.array(p["force"]) / big * size
        ax.annotate("", xy=(p["x"], p["y"]), xytext=(p["x"] - f[0], p["y"] - f[1]),
                    arrowprops=dict(arrowstyle="-|>", color="C1", lw=1.6), zorder=6)
    ax.plot([], [], color="C1", lw=1.6, label=f"contact force ({len(pts)} point{'s' if len(pts) > 1 else ''})")
