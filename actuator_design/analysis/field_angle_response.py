"""Soft against hard magnetic response over the field angle φ (THEORY §5, §9).

A soft-magnetic rod feels −h² cos²(θ + α − φ): its response is π-periodic in φ (the fibres align
with the field *axis*). A hard-magnetic rod feels −h_r cos(θ + β − φ): 2π-periodic (the
magnetisation aligns with the field *direction*), so turning the field over reverses the torque.
:func:`field_angle_response` follows the stable equilibrium of each scene as φ turns (natural
stepping with warm starts, one NLP per scene) and returns the tip angle; drawing is in
:mod:`actuator_design.viz.materials`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Dict, Optional, Sequence

import numpy as np

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene, UniformField
from actuator_design.equilibrium.solver import get_solver

__all__ = ["AngleResponse", "field_angle_response"]


@dataclass
class AngleResponse:
    """Tip angle against field angle for several scenes.

    Attributes
    ----------
    phi : ndarray, shape (n,)
        Field angles, rad.
    tip_angle : dict of str -> ndarray, shape (n,)
        θ(1) (rad) of the followed equilibrium per scene label.
    stable : dict of str -> ndarray of bool, shape (n,)
    """

    phi: np.ndarray
    tip_angle: Dict[str, np.ndarray]
    stable: Dict[str, np.ndarray]


def field_angle_response(scenes: Dict[str, Scene], phi: Sequence[float],
                         options: Optional[SolverOptions] = None) -> AngleResponse:
    """Follow the stable equilibrium of each uniform-field scene over the field angles ``phi``.

    Parameters
    ----------
    scenes : dict of str -> Scene
        Labelled uniform-field scenes (e.g. ``{"soft": ..., "hard": ...}``).
    phi : sequence of float, shape (n,)
        Field angles in sweep order, rad.
    options : SolverOptions, optional

    Returns
    -------
    AngleResponse
    """
    phi = np.asarray(phi, float)
    if phi.ndim != 1 or phi.size == 0 or not np.all(np.isfinite(phi)):
        raise ValueError("phi: need a non-empty list of finite field angles (rad)")
    options = options or SolverOptions()
    out_t, out_s = {}, {}
    for label, scene in scenes.items():
        if scene.field is not None and not isinstance(scene.field, UniformField):
            raise ValueError(f"{label}: the field-angle sweep needs a uniform field, got {scene.field.kind}")
        solver = get_solver(scene.with_values(phi=float(phi[0])), options)
        tips, stab, prev = np.full(phi.size, np.nan), np.zeros(phi.size, bool), None
        for i, ph in enumerate(phi):
            r = solve(scene.with_values(phi=float(ph)), options, initial=prev, solver=solver)
            tips[i], stab[i] = r.tip["angle"], r.stable
            prev = r if r.success else prev
        out_t[label], out_s[label] = tips, stab
    return AngleResponse(phi, out_t, out_s)
