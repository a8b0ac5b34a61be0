"""Obstacles and contact forces in the shape figure (:mod:`actuator_design.contact.equilibrium`)."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["draw_obstacles", "draw_contact_forces"]


def draw_obstacles(ax, scene, window) -> None:
    """Each obstacle's solid as a grey patch (its ``outline``; a wall's as a hatched band behind
    its line), units of ℓ."""
    from matplotlib.patches import Polygon

    x0, x1, y0, y1 = window
    span = max(x1 - x0, y1 - y0)
    for k, ob in enumerate(scene.obstacles):
        label = "obstacle" if k == 0 else None
        outline = ob.outline(span)
        if ob.kind == "lumen":  # a tube: its two walls
            half = len(outline) // 2
            for wall in (outline[:half], outline[half:]):
                ax.plot(wall[:, 0], wall[:, 1], color="0.3", lw=1.4, zorder=3, label=label)
                label = None
        elif ob.kind == "wall":  # a half-plane: its line, and a hatched band on the solid side
            ax.add_patch(Polygon(outline, closed=True, facecolor="0.85", edgecolor="0.3", hatch="////", lw=0.0,
                                 zorder=3, label=label))
            ax.plot(outline[:2, 0], outline[:2, 1], color="0.3", lw=1.2, zorder=3)
        else:
            ax.add_patch(Polygon(outline, closed=True, facecolor="0.8", edgecolor="0.3", lw=1.0, zorder=3,
                                 label=label))


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
