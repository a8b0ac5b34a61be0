"""Magnitude checks of the data against the scene: a unit in the header that is 1000× off.

A header's unit is checked against the column's dimension when the file is read (:mod:`.data`);
a unit of the right dimension but the wrong size (``field [kA/mm]`` for kA/m, ``tip_x [m]`` for
mm, ``tip_angle [rad]`` for degrees) passes that check and is found here, from the dimensionless
groups the data give at the initial parameters (THEORY §5, §9) and from the rod's geometry:

* the largest measured field gives a field group whose end layer is thinner than
  :data:`.limits.PLAUSIBLE_LAYER` of the rod (h > 100, h_r > 1e4: the rod would lie along the field
  but for a boundary layer of 1 % of its length; each group declares its ``layer_power``);
* a load gives |p| > :data:`.limits.PLAUSIBLE_LOAD` (p = P ℓ²/B);
* a tip coordinate lies farther than :data:`.limits.PLAUSIBLE_TIP_DISTANCE` rod lengths from the
  clamp (an inextensible rod's tip is at most ℓ away);
* an angle exceeds :data:`.limits.PLAUSIBLE_ANGLE` (two turns).

Each finding is a warning naming the column, its unit and the factor by which it is off; the fit
then runs, and its goodness-of-fit test (:mod:`.goodness`) says whether the model explains the data.
"""
from __future__ import annotations

from typing import List

import numpy as np

from actuator_design.calibration import limits as fit_limits
from actuator_design.physics import parameters as lens

__all__ = ["magnitude_warnings"]


def _groups():
    """(slot, data column, largest plausible value): every group the field drives whose end layers
    narrow with it (``Parameter.layer_power``: the layer's wavenumber ∝ value^power, so a layer of
    PLAUSIBLE_LAYER at value PLAUSIBLE_LAYER^(−1/power)), and the tip load's components."""
    return tuple((p.slot, "field", fit_limits.PLAUSIBLE_LAYER ** (-1.0 / p.layer_power))
                 for p in lens.parameters().values() if p.layer_power and p.field_power and p.name == p.slot) + (
        ("fx", "load_x", fit_limits.PLAUSIBLE_LOAD), ("fy", "load_y", fit_limits.PLAUSIBLE_LOAD))


_WHY = {"field": "the rod would lie along the field but for a boundary layer of 1 % of its length",
        "load": "40 times the Euler buckling load",
        "tip": "an inextensible rod's tip is at most one rod length from the clamp",
        "angle": "two turns"}


def _column(data, name: str) -> str:
    """The data column behind a group (``load_y`` may be written ``load``)."""
    if name == "load_y" and "load" in data.columns:
        return "load"
    return name


def _implausible(data, column: str, what: str, value: float, plausible: float, why: str) -> str:
    unit = data.units.get(column, "")
    unit = f" [{unit}]" if unit else ""
    return (f"column '{column}{unit}': its largest value gives {what} = {value:.4g}, "
            f"{value / plausible:.3g} times the plausible largest {plausible:g} ({why}): is the "
            "unit in the header right (e.g. 1000 times too large)?")


def magnitude_warnings(problem) -> List[str]:
    """Warnings on data magnitudes that are implausible for the scene (module docstring).

    Parameters
    ----------
    problem : FitProblem
        Its initial parameters, distinct conditions and fit map give the groups of the data.
    """
    data, out = problem.data, []
    theta0 = np.array([problem.initial[n] for n in problem.names], float)
    q = np.asarray(problem.f_map_all(theta0, problem.conditions.T)[0], float)
    q = q.reshape(len(problem.slots), problem.n_conditions)
    for slot, column, plausible in _groups():
        col = _column(data, column)
        if slot not in problem.slots or col not in data.columns:
            continue
        largest = float(np.max(np.abs(q[problem.slots.index(slot)])))
        if largest > plausible:
            what = f"the group {slot}" if column == "field" else "the dimensionless load p"
            why = _WHY["field" if column == "field" else "load"]
            out.append(_implausible(data, col, what, largest, plausible, why))
    length = problem.const["L"] if problem.kind == "physical" else 1.0
    for col in ("tip_x", "tip_y", "tip_deflection"):
        if col in data.columns:
            largest = float(np.max(np.abs(data.columns[col]))) / length
            if largest > fit_limits.PLAUSIBLE_TIP_DISTANCE:
                out.append(_implausible(data, col, "a distance from the clamp in rod lengths",
                                        largest, fit_limits.PLAUSIBLE_TIP_DISTANCE, _WHY["tip"]))
    for col in ("tip_angle", "field_angle"):
        if col in data.columns:
            largest = float(np.max(np.abs(data.columns[col])))
            if largest > fit_limits.PLAUSIBLE_ANGLE:
                out.append(_implausible(data, col, "an angle in rad", largest,
                                        fit_limits.PLAUSIBLE_ANGLE, _WHY["angle"]))
    return out
