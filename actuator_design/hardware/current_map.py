"""The forward map of a design over coil currents (issue 19 item 2): a :class:`~actuator_design.hardware.map.HardwareMap`
over the coils' field weights w (``SourceField.weights``: I_k = w_k × the current coil k was fitted
at), every current ramped together from zero, with the squared field |ĥ|² at the rod's quadrature
points as the pointwise quantity (the ``max_field`` limit)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from actuator_design.physics.fields import field_model
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.model.scene import Scene
from actuator_design.hardware.map import HardwareMap

__all__ = ["CurrentMap", "at_weights"]


def at_weights(scene: Scene, w) -> Scene:
    """``scene`` with its coils' field weights set to ``w`` (n,)."""
    return replace(scene, field=replace(scene.field, weights=tuple(float(v) for v in w)))


class CurrentMap(HardwareMap):
    """Equilibria of a coil scene as functions of the weights w (n,), on one mesh; ``limit`` is
    |ĥ|² at the quadrature points.

    Parameters
    ----------
    scene : Scene
        A scene whose field is a ``SourceField`` of coils.
    start : EquilibriumResult
        The state reached from rest at ``w_start`` (its mesh is the map's mesh).
    w_start : ndarray, shape (n,)
    """

    def __init__(self, scene: Scene, start: EquilibriumResult, w_start: np.ndarray):
        model = field_model(scene.field)
        placed = model.parameter_values(scene.field)

        def squared_field(x, y, w):
            values = {**placed, **{name: w[k] for k, name in enumerate(model.weight_params)}}
            hx, hy = model.value(x, y, values)
            return hx * hx + hy * hy

        super().__init__(scene, start, w_start, model.weight_params, at_weights, squared_field)
