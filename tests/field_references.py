"""The independent reference of equilibria in real fields: shooting that calls magpylib for the field
at every step (:mod:`actuator_design.reference.shooting_field`), from a result's shape."""
import magpylib as magpy
import numpy as np

from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)


def shooting_tip(scene, objs, result) -> np.ndarray:
    """(x, y, angle) at the tip (units of ℓ, rad) of the shooting solution in the field of the
    magpylib objects ``objs`` (built by hand, SI units), started from ``result``'s shape."""
    length, h0 = scene.scales.length, scene.scales.field
    field = field_from_function(lambda p: magpy.getH(objs, p, sumup=True), length, h0)
    rod = FieldRod(field, h=scene.h, h_pos=scene.h_pos, h_r=scene.h_r,
                   alpha=float(scene.fibres(np.array([0.0]))[0]),
                   beta=float(scene.magnetization(np.array([0.0]))[0]) if scene.magnetization is not None else 0.0)
    s = np.linspace(0, 1, 201)
    d = result.evaluate(s)
    shot = solve_field_shooting(rod, guess_from_shape(rod, s, d["theta"], d["dtheta"][0], d["x"], d["y"]))
    return np.array(shot.tip)
