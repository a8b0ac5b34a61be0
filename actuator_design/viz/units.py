"""Axes in the user's units: ticks of a dimensionless axis labelled in a physical unit.

The data stay dimensionless (rod lengths, the field group h); an axis whose quantity is a fixed
multiple of a physical one (x [mm] = x̂ ℓ / 1 mm, B [mT] = μ0 h / (dh/dH) · 10³) gets round ticks in
that unit and a label naming it. :func:`parameter_axis` does this for an axis of a lens parameter
(h → μ0 H in mT, h² → a second axis in mT, a load p → N, a moment → N m); :func:`field_text` and
:func:`load_text` write a scene's field and tip load for a title. Pure drawing, no solving.
"""
from __future__ import annotations

import math

import numpy as np

from actuator_design.io.display import degrees, number
from actuator_design.io.unit_results import scene_physical
from actuator_design.io.user_units import parameter_physical, parameter_unit_label
from actuator_design.physics.parameters import parameter, parameters, remanent_group

__all__ = ["scaled_axis", "length_axes", "field_axis", "parameter_axis", "field_text", "load_text", "groups_text",
           "NO_FIELD_SCALE"]

#: What an axis of a field group says when the scene cannot convert it (χ̄ = 0).
NO_FIELD_SCALE = "dimensionless: this scene has no field scale"


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
    # the minus sign as matplotlib's own ticks draw it (U+2212), and no "-0"
    axis.set_major_formatter(FuncFormatter(
        lambda v, _pos: _tick_text(v * factor)))
    axis.set_label_text(label)


def _tick_text(value: float) -> str:
    return number(value, ".6g", noise=0.0).replace("-", "\u2212")


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


def parameter_axis(ax, param, units, label: str, which: str = "x", data_max: float = None) -> None:
    """The ``which`` axis (``"x"`` or ``"y"``) of ``ax``, whose data are values of the lens
    parameter ``param``, in the user's units of a physical scene (no-op for ``units`` None).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    param : actuator_design.physics.parameters.Parameter or str
    units : actuator_design.io.user_units.UserUnits or None
    label : str
        The axis label of the dimensionless values (``"h"``, ``"h²"``, ``"p"``).
    which : {"x", "y"}
    data_max : float, optional
        Largest value of ``h2`` drawn (round field ticks on the second axis).

    Notes
    -----
    ``h``: ticks in mT (μ0 H), labelled ``field μ0H / mT``; ``h2`` (= h², μ0 H ∝ √h2): the axis stays
    h² and a second axis (top or right) is ticked in mT; loads: ``p / N``, ``m_tip / N m``,
    ``qy / N/m``; a field group the scene cannot convert (χ̄ = 0) keeps its values and its label
    says so; angles and groups without a physical unit (h_r, h_pos) are left as they are.
    """
    if units is None:
        return

    p = parameter(param) if isinstance(param, str) else param
    unit = parameter_unit_label(p, units)
    axis = ax.xaxis if which == "x" else ax.yaxis
    if p.field_magnitude and unit is None:  # χ̄ = 0: no field conversion
        axis.set_label_text(f"{label} ({NO_FIELD_SCALE})")
    elif unit == "mT" and p.transform == "sqrt":  # h2 = h²: mT ∝ √h2, a second axis
        c = units.field_mT(1.0)
        funcs = (lambda v: c * np.sqrt(np.maximum(v, 0.0)), lambda b: (np.asarray(b) / c) ** 2)
        if which == "x":
            ax.set_xlim(left=0.0)  # h2 >= 0: no margin where √h2 is undefined
            sec = ax.secondary_xaxis("top", functions=funcs)
        else:
            ax.set_ylim(bottom=0.0)
            sec = ax.secondary_yaxis("right", functions=funcs)
        sec_axis = sec.xaxis if which == "x" else sec.yaxis
        sec_axis.set_label_text("field μ0H / mT")
        if data_max is not None and data_max > 0:  # round fields at evenly spaced h2
            sec_axis.set_ticks(sorted({float(f"{c * math.sqrt(v):.2g}")
                                       for v in np.linspace(0.0, data_max, 5)}))
        axis.set_label_text(f"{label} (dimensionless; field μ0H / mT on "
                            f"{'top' if which == 'x' else 'the right'})")
    elif unit == "mT":
        field_axis(axis, units)
    elif unit is not None:
        scaled_axis(axis, parameter_physical(p, 1.0, units), f"{label} / {unit}")


def field_text(h: float, units) -> str:
    """``μ0H = 25 mT`` of the group ``h`` on a physical scene with a field scale, else ``h = 1.545``."""
    if units is not None and units.has_field:
        return f"μ0H = {units.field_mT(h):.4g} mT"
    return f"h = {h:.4g}"


def scene_field_text(scene, units) -> str:
    """:func:`field_text` of a scene: on a physical scene μ0H of h, or of h_r for a hard-magnetic
    rod without soft coupling (:func:`~actuator_design.io.unit_results.scene_physical`); else the
    group that carries the field (``h_r = 2`` when h = 0)."""
    if units is not None:
        mT = scene_physical(scene, units).get("field_mT")
        if mT is not None:
            return f"μ0H = {mT:.4g} mT"
    group = remanent_group(scene)  # the remanent group of a hard-magnetic rod (THEORY §9)
    if scene.h == 0 and group > 0:
        p = next(p for p in parameters().values() if p.remanent_field and abs(p.get(scene)) == group)
        return f"{p.name} = {p.get(scene):.4g}"
    return f"h = {scene.h:.4g}"


def load_text(p: float, units, name: str = "p") -> str:
    """``p = 7e-05 N`` (a tip load in B0/ℓ² on a physical scene), else ``p = 0.5376``."""
    if units is not None:
        return f"{name} = {p * units.force_scale:.4g} N"
    return f"{name} = {p:.4g}"


def groups_text(scene, units=None) -> str:
    """A title's ``h = 1.5, φ = 90°, p = 0`` of a scene; on a physical scene the field as
    ``μ0H = 40 mT`` (of h, or of h_r for a hard-magnetic rod whose h has no field scale) and the
    tip load in N."""
    h, phi, p = (parameter(name).get(scene) for name in ("h", "phi", "p"))
    field = f"h = {h:.4g}"
    if units is not None:
        mT = scene_physical(scene, units).get("field_mT")
        if mT is not None:
            field = f"μ0H = {mT:.4g} mT"
    return f"{field}, φ = {degrees(phi, '.4g')}°, {load_text(p, units)}"
