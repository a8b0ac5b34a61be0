"""A loading path's schedule: parameter settings in order, checked against the scene (names of the
parameter lens, :mod:`actuator_design.physics.parameters`, with the wording "path parameter").

Shared by the quasi-static path follower (:mod:`actuator_design.continuation.loading`) and the
contact path (:mod:`actuator_design.contact.path`).
"""
from __future__ import annotations

from typing import Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens

__all__ = ["Schedule", "prepare_scene", "scene_values", "apply_values", "ramp", "normalise_schedule",
           "checked_schedule"]

Schedule = Union[Sequence[Mapping[str, float]], Mapping[str, Sequence[float]]]


# -- parameters: the lens (actuator_design.physics.parameters), with this analysis' wording ---------------
_WHAT = "path parameter"


def _check_name(name: str) -> None:
    lens.parameter(name, _WHAT)


def prepare_scene(scene: Scene, names: Sequence[str]) -> Scene:
    """``scene`` with every term a parameter in ``names`` needs present (added at value zero), so
    that the whole path shares one NLP structure."""
    return lens.prepare_scene(scene, names, _WHAT)


def scene_values(scene: Scene, names: Sequence[str]) -> Dict[str, float]:
    """The current values of the named parameters in ``scene``."""
    return lens.scene_values(scene, names, _WHAT)


def apply_values(scene: Scene, values: Mapping[str, float]) -> Scene:
    """A copy of ``scene`` with the named parameters set (names of the parameter lens).

    Setting ``h`` (or ``h2``) in a non-uniform field scales ``h_pos`` by the same factor (both
    groups are proportional to the field magnitude H, THEORY §5) unless ``h_pos`` is also given
    or the scene's h is 0: the lens' field-scaling rule (:func:`actuator_design.physics.parameters.apply_values`).

    Raises
    ------
    ValueError
        Unknown name, non-finite value, h, h2 or h_pos negative, phi in a non-uniform field.
    """
    return lens.apply_values(scene, values, _WHAT)


def ramp(name: str, start: float, stop: float, back: bool = False) -> List[Dict[str, float]]:
    """The schedule ``[{name: start}, {name: stop}]`` (and back to ``start`` if ``back``)."""
    _check_name(name)
    out = [{name: float(start)}, {name: float(stop)}]
    if back:
        out.append({name: float(start)})
    return out


def normalise_schedule(schedule: Schedule) -> Tuple[List[str], np.ndarray]:
    """Names and an (n_points, n_names) array of values from a schedule.

    A schedule is a list of dicts with the same keys (``[{"h": 0}, {"h": 2}]``) or a dict of
    equal-length lists (``{"h": [0, 2, 0]}``).
    """
    if isinstance(schedule, Mapping):
        names = list(schedule)
        lengths = {len(list(v)) for v in schedule.values()}
        if len(lengths) != 1:
            raise ValueError("schedule: the lists of values must all have the same length")
        rows = [dict(zip(names, vals)) for vals in zip(*[list(schedule[n]) for n in names])]
    else:
        rows = [dict(r) for r in schedule]
    if len(rows) < 2:
        raise ValueError(f"schedule: needs at least 2 points, got {len(rows)}")
    names = list(rows[0])
    if not names:
        raise ValueError("schedule: the points name no parameter")
    for i, r in enumerate(rows):
        if set(r) != set(names):
            raise ValueError(f"schedule[{i}]: names {sorted(r)} differ from schedule[0]'s {sorted(names)}")
    for n in names:
        _check_name(n)
    vals = np.array([[float(r[n]) for n in names] for r in rows])
    if not np.all(np.isfinite(vals)):
        raise ValueError("schedule: every value must be a finite number")
    return names, vals


def checked_schedule(scene: Scene, schedule: Schedule, max_step: Optional[float], max_dtheta: float):
    """``(base, names, values, max_step)``: the schedule normalised and checked against the scene
    (every point applicable), the scene prepared for its names, the step defaulted to
    min(1, n_segments/20) and both step settings checked.

    Raises
    ------
    ValueError
        Naming the schedule point or the setting."""
    names, vals = normalise_schedule(schedule)
    if max_step is None:
        max_step = min(1.0, (len(vals) - 1) / 20.0)
    if not (0.0 < max_step <= 1.0):
        raise ValueError(f"max_step: must lie in (0, 1], got {max_step!r}")
    if not (max_dtheta > 0.0):
        raise ValueError(f"max_dtheta: must be > 0, got {max_dtheta!r}")
    base = prepare_scene(scene, names)
    for i, row in enumerate(vals):
        try:
            apply_values(base, dict(zip(names, row)))
        except ValueError as err:
            raise ValueError(f"schedule[{i}].{err}") from None
    return base, names, vals, max_step
