"""The figure of ``stiffness --out`` at one state: the equilibrium with its tip compliance drawn.

Pure drawing, never solves. The tip moves by δ = C f under a small tip force f (C the 2 × 2
force/position block of the compliance, THEORY §6-7); over the unit forces f = (cos t, sin t)
δ traces the compliance ellipse, drawn at the tip to a stated scale, with the two columns of C
(the tip's motion under fx and under fy) as arrows. A physical scene's axes are in the unit of
``rod.length`` and the compliance is also stated in that unit per N.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["compliance_figure", "ELLIPSE_SIZE"]

#: Largest tip motion drawn, in rod lengths: the ellipse is scaled so that its longest axis is this.
ELLIPSE_SIZE = 0.2


def compliance_figure(st, units=None):
    """The equilibrium of a tip-stiffness result with its compliance ellipse at the tip.

    Parameters
    ----------
    st : actuator_design.analysis.stiffness.TipStiffness
        Its ``compliance`` rows are (x, y[, angle]) and columns (fx, fy[, m_tip]), dimensionless
        (ℓ³/B0 for the force/position block).
    units : actuator_design.io.user_units.UserUnits, optional
        A physical scene's units: axes in the length unit of ``rod.length``, compliance stated
        in that unit per N and the vertical stiffness in N/m.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from actuator_design.viz.shape import plot_shape
    from actuator_design.viz.units import length_axes

    eq = st.equilibrium
    ax = plot_shape(eq)
    C = np.asarray(st.compliance, float)[:2, :2]
    tip = np.array([eq.tip["x"], eq.tip["y"]])
    t = np.linspace(0.0, 2.0 * math.pi, 181)
    ring = C @ np.vstack([np.cos(t), np.sin(t)])  # tip motion per unit force in each direction
    largest = float(np.max(np.hypot(*ring))) if np.all(np.isfinite(ring)) else 0.0
    if largest > 0.0:
        k = ELLIPSE_SIZE / largest  # drawing scale: rod lengths of the figure per ℓ³/B0
        ax.plot(tip[0] + k * ring[0], tip[1] + k * ring[1], color="C4", lw=1.6, zorder=7,
                label="tip motion per unit tip force (compliance ellipse)")
        for j, name in enumerate(("fx", "fy")):
            col = k * C[:, j]
            if np.hypot(*col) > 1e-9 * ELLIPSE_SIZE:
                ax.annotate("", xy=tuple(tip + col), xytext=tuple(tip),
                            arrowprops=dict(arrowstyle="-|>", color="C4", lw=1.2), zorder=7)
                ax.text(*(tip + 1.08 * col), f"under {name}", color="C4", fontsize=8, zorder=7)
        ax.legend(loc="best", fontsize=8, framealpha=0.85)
        # the ellipse may reach beyond the shape's window
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        pad = 0.05
        ax.set_xlim(min(x0, float(np.min(tip[0] + k * ring[0])) - pad), max(x1, float(np.max(tip[0] + k * ring[0])) + pad))
        ax.set_ylim(min(y0, float(np.min(tip[1] + k * ring[1])) - pad), max(y1, float(np.max(tip[1] + k * ring[1])) + pad))
    length_axes(ax, units)
    ax.set_title(_title(st, largest, units), fontsize=9)
    return ax.figure


def _title(st, largest: float, units) -> str:
    """Vertical stiffness and the ellipse's scale, dimensionless and (physical) in SI."""
    eq = st.equilibrium
    s = st.vertical
    field = (f"μ0H = {units.field_mT(eq.scene.h):.4g} mT" if units is not None and units.has_field
             else f"h = {eq.scene.h:.4g}")
    head = f"tip stiffness at {field}, φ = {math.degrees(eq.scene.phi):.4g}°: dp/dv1 = {s:.4g} B0/l³"
    if units is not None and math.isfinite(s):
        head += f" = {s * units.stiffness_scale:.4g} N/m"
    if largest <= 0.0:
        return head + "\n(no finite compliance to draw)"
    scale = f"ellipse: longest axis {largest:.3g} l³/B0"
    if units is not None:  # ℓ³/B0 = 1/(B0/ℓ³) m/N, then in the unit of rod.length per N
        scale += f" = {largest / units.stiffness_scale / units.metres_per_unit:.3g} {units.length_unit}/N"
    return f"{head}\n{scale}, drawn as {ELLIPSE_SIZE:g} l"
