"""Axes in the user's units: ticks of a dimensionless axis labelled in a physical unit.

The data stay dimensionless (rod lengths, the field group h); an axis whose quantity is a fixed
multiple of a physical one (x [mm] = x̂ ℓ / 1 mm, B [mT] = μ0 h / (dh/dH) · 10³) gets round ticks in
that unit and a label naming it. Pure drawing, no solving.
"""
from __future__ import annotations

__all__ = ["scaled_axis", "length_axes", "field_axis"]


def scaled_axis(axis, factor: float, label: str) -> None:
    """Tick ``axis`` (``ax.xaxis`` or ``ax.yaxis``) at round values of ``factor`` × data, labelled so.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
    factor : float
        Physical value per data unit (> 0).
    label : str
        The axis label, e.g. ``"x / mm"``.
    """
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    class _Scaled(MaxNLocator):
        def tick_values(self, vmin, vmax):
            return super().tick_values(vmin * factor, vmax * factor) / factor

    axis.set_major_locator(_Scaled(nbins="auto", steps=[1, 2, 2.5, 5, 10]))
    axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v * factor:.6g}"))
    axis.set_label_text(label)


def length_axes(ax, units) -> None:
    """Both axes of a shape panel (data in rod lengths) in the scene's length unit; no-op for None."""
    if units is None:
        return
    f = units.length(1.0)
    scaled_axis(ax.xaxis, f, f"x / {units.length_unit}")
    scaled_axis(ax.yaxis, f, f"y / {units.length_unit}")


def field_axis(axis, units, label: str = "field μ0H / mT") -> bool:
    """An axis of the field group h ticked in mT (μ0 H); False (nothing done) without a field scale."""
    if units is None or not units.has_field:
        return False
    scaled_axis(axis, units.field_mT(1.0), label)
    return True
