"""Check a study's points before any work: every swept value and every grid combination that can
be checked without solving.

A point is valid when its configuration (the raw configuration with its values substituted,
:func:`~actuator_design.study.grid.substitute`) passes :func:`actuator_design.config.load_config`
— units, ranges, the derived groups of a physical scene, the mesh budget — and, for an expression
field, :meth:`~actuator_design.config.Config.to_scene` (its current-free check). :func:`check_points`
validates, in this order,

1. the units of the swept keys: a physical unit (``h: ["1 kA/m"]``) on a dimensionless scene is
   refused naming the key (physical units need a physical scene);
2. one grid point through every value of every key (the other keys at their first value, or the
   zipped point), so a value that is wrong on its own is named with its key;
3. every point of the grid when it has at most :data:`FULL_CHECK_POINTS` points. A larger grid is
   checked at its corners (the smallest and largest value of every numeric key, every value of
   the others; at most :data:`MAX_CORNERS`) and at the points of step 2, thinned evenly to
   :data:`FULL_CHECK_POINTS` when there are more.

The first invalid point raises one :class:`~actuator_design.config.ConfigError` naming
``study.sweep.<key>`` (the key the invalid field belongs to, or the only key) or ``study.sweep``,
the point and the configuration's own one-line error (its field and allowed range). Nothing is
built, solved or written. Only in a grid larger than :data:`FULL_CHECK_POINTS` can an invalid
point remain (a combination away from the corners, or a value the thinning skipped); it is
recorded as an ``invalid`` point, as the workers validate every point again.
"""
from __future__ import annotations

import itertools
import warnings
from typing import Iterator, List, Sequence, Tuple

import numpy as np

from actuator_design.config import ConfigError
from actuator_design.config.dimensionless import physical_unit_of
from actuator_design.config.field_specs import ExpressionSpec, PhysicalExpression
from actuator_design.config.model import validate_config
from actuator_design.study.grid import substitute

__all__ = ["check_points", "check_units", "FULL_CHECK_POINTS", "MAX_CORNERS"]

#: Grids up to this many points are checked point by point before any work (about 0.05–0.2 ms
#: a point, i.e. at most a few seconds; the workers validate every point again).
FULL_CHECK_POINTS = 20_000
#: Largest number of corner points checked in a larger grid.
MAX_CORNERS = 4096


def check_units(raw: dict, axes) -> None:
    """Refuse a physical unit swept on a dimensionless scene.

    Raises
    ------
    ConfigError
        ``study.sweep.<key>``: the value with its unit, and that physical units need a physical
        scene.
    """
    scene = raw.get("scene")
    if not (isinstance(scene, dict) and scene.get("type") == "dimensionless"):
        return
    for a in axes:
        if a.section != "scene" or not a.unit:
            continue
        shown = next((v for v in a.values if isinstance(v, str)), f"1 {a.unit}")
        unit = physical_unit_of(shown)
        if unit is not None:
            raise ConfigError(f"study.sweep.{a.key}",
                              f"{shown!r} has a physical unit ({unit}), but the scene is "
                              "dimensionless: physical units need a physical scene (type: "
                              f"physical, with the rod and its material); sweep {a.key} as plain "
                              "numbers (dimensionless, THEORY §5) or use a physical scene")


def _validate(raw: dict, axes, idx) -> None:
    """Raise the ConfigError of one point's configuration, if any."""
    config = validate_config(substitute(raw, axes, idx))  # substitute copies what it changes
    if isinstance(config.scene.field, (ExpressionSpec, PhysicalExpression)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            config.to_scene()  # the expression field's current-free check


def _representatives(axes, grid: str) -> Iterator[Tuple[int, ...]]:
    """One grid point through every value of every key."""
    if grid == "zip":
        yield from (tuple([i] * len(axes)) for i in range(len(axes[0].values)))
        return
    for k, a in enumerate(axes):
        for i in range(len(a.values)):
            yield tuple(i if j == k else 0 for j in range(len(axes)))


def _corners(axes, grid: str) -> Iterator[Tuple[int, ...]]:
    """The corners of a cartesian grid: the indices of the smallest and largest value of every
    numeric key, every index of the others (at most :data:`MAX_CORNERS`)."""
    if grid == "zip":
        return iter(())
    choices: List[Sequence[int]] = []
    for a in axes:
        if a.numeric:
            lo = min(range(len(a.numbers)), key=lambda i: a.numbers[i])
            hi = max(range(len(a.numbers)), key=lambda i: a.numbers[i])
            choices.append(sorted({lo, hi}))
        else:
            choices.append(range(len(a.values)))
    return itertools.islice(itertools.product(*choices), MAX_CORNERS)


def _order(axes, indices, grid: str) -> Iterator[Tuple[int, ...]]:
    """The points to check, without repeats: representatives then every point (a grid of at most
    FULL_CHECK_POINTS), or the corners then at most FULL_CHECK_POINTS representatives, evenly
    spread over them (a larger grid)."""
    seen = set()
    if len(indices) <= FULL_CHECK_POINTS:
        order = itertools.chain(_representatives(axes, grid), indices)
    else:
        reps = list(_representatives(axes, grid))
        if len(reps) > FULL_CHECK_POINTS:
            keep = np.unique(np.linspace(0, len(reps) - 1, FULL_CHECK_POINTS).round().astype(int))
            reps = [reps[k] for k in keep]
        order = itertools.chain(_corners(axes, grid), reps)
    for idx in order:
        idx = tuple(idx)
        if idx not in seen:
            seen.add(idx)
            yield idx


def _blame(err: ConfigError, axes) -> str:
    """The swept key an error belongs to (its field lies on the key's path), the only key, or ''."""
    for a in axes:
        path = ".".join((a.section,) + a.path)
        if err.field == path or err.field.startswith(path + ".") or err.field.startswith(path + "["):
            return a.key
    return axes[0].key if len(axes) == 1 else ""


def _position(axes, idx, grid: str) -> int:
    """The point's number in the grid (cartesian: last key fastest, as grid_indices)."""
    if grid == "zip":
        return int(idx[0])
    n = 0
    for a, i in zip(axes, idx):
        n = n * len(a.values) + int(i)
    return n


def check_points(raw: dict, axes, indices, grid: str) -> int:
    """Check a study's points before any work (module docstring).

    Parameters
    ----------
    raw : dict
        The configuration as loaded (without substitution).
    axes : list of Axis
        The swept keys (:func:`~actuator_design.study.grid.resolve_axes`).
    indices : list of tuple of int
        The grid's points (:func:`~actuator_design.study.grid.grid_indices`).
    grid : {"cartesian", "zip"}

    Returns
    -------
    int
        The number of points checked.

    Raises
    ------
    ConfigError
        The first invalid point: ``study.sweep.<key>: grid point 2 of 4 (rod.length = -5 mm) is
        invalid: scene.rod.length: must be > 0, got -5 mm``; a swept key that is not a value of
        the configuration (``... is not a value of this scene``); a physical unit on a
        dimensionless scene (:func:`check_units`).
    """
    check_units(raw, axes)
    checked = 0
    for idx in _order(axes, indices, grid):
        checked += 1
        try:
            _validate(raw, axes, idx)
        except ConfigError as err:
            key = _blame(err, axes)
            for a in axes:  # a key the configuration does not have
                path = ".".join((a.section,) + a.path)
                if "unknown key" in err.detail and (path == err.field
                                                    or path.startswith(err.field + ".")):
                    raise ConfigError(f"study.sweep.{a.key}", f"{path} is not a value of this "
                                                              f"{a.section}: {err}") from None
            values = ", ".join(f"{a.key} = {a.values[i]}" for a, i in zip(axes, idx))
            where = f"grid point {_position(axes, idx, grid) + 1} of {len(indices)}"
            raise ConfigError(f"study.sweep.{key}" if key else "study.sweep",
                              f"{where} ({values}) is invalid, refused before any work: "
                              f"{err}") from None
    return checked
