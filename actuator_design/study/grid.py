"""The points of a sweep: swept values with units, cartesian or zipped, substituted into the config.

Each key of ``study.sweep`` is a dotted path into the configuration's ``scene`` mapping
(``field.magnitude``, ``loads.tip_force.y``, ``h``; a leading ``scene.`` is allowed) or, with a
leading ``solver.``, into its ``solver`` mapping. Values are numbers, strings with units
(``"5 kA/m"``) or any other YAML value; all quantities of one key are expressed in the unit of its
first value (so a table column has one unit). Each point's configuration is the raw configuration
with its values substituted, validated again by :func:`actuator_design.config.load_config`, so
units and range errors work exactly as in a hand-written file.
"""
from __future__ import annotations

import copy
import itertools
import math
import re
from dataclasses import dataclass
from typing import Any, Dict, List, Sequence, Tuple

import numpy as np

from actuator_design.config import ConfigError
from actuator_design.model.units import COMMON_UNITS, MU0, registry
from actuator_design.config.studies.sweep import RangeSpec, SweepSpec

__all__ = ["Axis", "resolve_axes", "grid_indices", "substitute", "point_values", "grid_size",
           "check_grid_size", "DEFAULT_MAX_POINTS"]

#: Largest study run without ``--max-points`` / ``study.max_points``: a million points keep the
#: plan, the manifest and the journal of a study within a few hundred MB.
DEFAULT_MAX_POINTS = 1_000_000

_NUMBER_UNIT = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*$")


@dataclass(frozen=True)
class Axis:
    """One swept key.

    Attributes
    ----------
    key : str
        As written in ``study.sweep``.
    section : {"scene", "solver"}
    path : tuple of str
        Keys inside the section.
    unit : str
        Unit of the numbers (as written in the first value; ``""`` for plain numbers).
    values : list
        Values substituted into the configuration (``"5.0 kA/m"``, numbers, other YAML values).
    numbers : list of float or None
        Magnitudes in ``unit`` (``None`` for values that are not numbers).
    """

    key: str
    section: str
    path: Tuple[str, ...]
    unit: str
    values: Tuple[Any, ...]
    numbers: Tuple[Any, ...]

    @property
    def column(self) -> str:
        """Table column name: ``key [unit]`` (or ``key`` for plain numbers)."""
        return f"{self.key} [{self.unit}]" if self.unit else self.key

    @property
    def numeric(self) -> bool:
        return all(v is not None for v in self.numbers)

    def to_dict(self) -> dict:
        return {"key": self.key, "section": self.section, "path": list(self.path),
                "unit": self.unit, "values": list(self.values), "numbers": list(self.numbers)}

    @classmethod
    def from_dict(cls, d: dict) -> "Axis":
        return cls(d["key"], d["section"], tuple(d["path"]), d["unit"], tuple(d["values"]),
                   tuple(d["numbers"]))


def _split(value, where: str):
    """(magnitude, unit text) of a number or a ``"<number> <unit>"`` string, else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise ConfigError(where, f"must be a finite number, got {value!r}")
        return float(value), ""
    if isinstance(value, str):
        m = _NUMBER_UNIT.match(value.replace("°", " deg"))
        if m:
            return float(m.group(1)), m.group(2)
    return None


def _convert(mag: float, unit: str, target: str, where: str, shown) -> float:
    if unit == target:
        return mag
    if not unit or not target:
        raise ConfigError(where, f"mixes plain numbers and values with units ({shown!r}): write "
                                 "every value of a key with its unit")
    ureg = registry()
    try:
        q, t = ureg.Quantity(mag, unit), ureg.Unit(target)
        flux, field = ureg.tesla.dimensionality, (ureg.ampere / ureg.meter).dimensionality
        # a field given as flux density in vacuum, B = μ0 H (the configuration's convention)
        if q.dimensionality == flux and t.dimensionality == field:
            q = ureg.Quantity(q.to(ureg.tesla).magnitude / MU0, "A/m")
        elif q.dimensionality == field and t.dimensionality == flux:
            q = ureg.Quantity(q.to("A/m").magnitude * MU0, "T")
        return float(q.to(t).magnitude)
    except Exception as err:  # noqa: BLE001 - pint: unknown or incompatible units
        raise ConfigError(where, f"cannot express {shown!r} in '{target}' (the unit of the "
                                 f"first value): {' '.join(str(err).split())}") from None


def _check_unit(unit: str, where: str, shown) -> None:
    if not unit:
        return
    if unit in COMMON_UNITS:  # known without pint
        return
    try:
        registry().Unit(unit)
    except Exception as err:  # noqa: BLE001
        raise ConfigError(where, f"unknown unit in {shown!r}: {' '.join(str(err).split())}") from None


def _as_text(mag: float, unit: str):
    return f"{mag!r} {unit}" if unit else mag


def _resolve(key: str, spec) -> Axis:
    where = f"study.sweep.{key}"
    parts = key.split(".")
    section = "scene"
    if parts[0] in ("scene", "solver") and len(parts) > 1:
        section, parts = parts[0], parts[1:]
    if isinstance(spec, RangeSpec):
        a = _split(spec.start, f"{where}.from")
        b = _split(spec.stop, f"{where}.to")
        if a is None or b is None:
            bad, name = (spec.start, "from") if a is None else (spec.stop, "to")
            raise ConfigError(f"{where}.{name}", f"expected a number or a number with a unit, got "
                                                 f"{bad!r}")
        unit = a[1]
        _check_unit(unit, f"{where}.from", spec.start)
        lo, hi = a[0], _convert(b[0], b[1], unit, f"{where}.to", spec.stop)
        if spec.spacing == "log":
            if lo <= 0 or hi <= 0:
                raise ConfigError(f"{where}.spacing", f"log spacing needs from and to > 0, got "
                                                      f"{spec.start!r} and {spec.stop!r}")
            nums = np.geomspace(lo, hi, spec.n)
        else:
            nums = np.linspace(lo, hi, spec.n)
        nums = [float(v) for v in nums]
        return Axis(key, section, tuple(parts), unit, tuple(_as_text(v, unit) for v in nums),
                    tuple(nums))
    split = [_split(v, f"{where}[{i}]") for i, v in enumerate(spec)]
    first = next((s for s in split if s is not None), None)
    if first is None:  # no numbers at all: values substituted as they are
        return Axis(key, section, tuple(parts), "", tuple(spec), tuple(None for _ in spec))
    unit = first[1]
    _check_unit(unit, f"{where}[0]", spec[0])
    values, nums = [], []
    for i, (v, s) in enumerate(zip(spec, split)):
        if s is None:
            if any(x is not None for x in split):
                raise ConfigError(f"{where}[{i}]", f"expected a number (with a unit like the other "
                                                   f"values), got {v!r}")
        mag = _convert(s[0], s[1], unit, f"{where}[{i}]", v)
        nums.append(mag)
        values.append(_as_text(mag, unit) if (s[1] != unit or isinstance(v, str)) else v)
    return Axis(key, section, tuple(parts), unit, tuple(values), tuple(nums))


def resolve_axes(spec: SweepSpec) -> List[Axis]:
    """The swept keys with their values, in the order given.

    Raises
    ------
    ConfigError
        ``study.sweep.<key>...``: a value that is not a number with a unit where the others are,
        incompatible or unknown units, log spacing through zero.
    """
    return [_resolve(k, v) for k, v in spec.sweep.items()]


def grid_size(spec: SweepSpec) -> Tuple[int, List[int]]:
    """The number of points of a sweep and of values per key, from the specification alone.

    Nothing is built: ``{from, to, n}`` counts ``n`` values, a list its length.

    Returns
    -------
    total : int
        Product of the sizes (cartesian) or the common size (zip).
    sizes : list of int
        Values per key, in the order given.
    """
    sizes = [v.n if isinstance(v, RangeSpec) else len(v) for v in spec.sweep.values()]
    total = sizes[0] if spec.grid == "zip" else math.prod(sizes)
    return total, sizes


def check_grid_size(spec: SweepSpec, max_points: int) -> int:
    """The number of points, checked against ``max_points`` before any grid is built.

    Raises
    ------
    ConfigError
        ``study.sweep``: more points than ``max_points`` (the message gives both and says how to
        raise the limit).
    """
    total, sizes = grid_size(spec)
    if total > max_points:
        shape = f"{' × '.join(map(str, sizes))} = " if len(sizes) > 1 and spec.grid != "zip" else ""
        raise ConfigError("study.sweep", f"the grid has {shape}{total} points, more than the limit "
                                         f"of {max_points}; raise the limit with --max-points N "
                                         "(or study.max_points)")
    return total


def grid_indices(axes: Sequence[Axis], grid: str) -> List[Tuple[int, ...]]:
    """Value indices of every point: the cartesian product (last key fastest) or the zip."""
    sizes = [len(a.values) for a in axes]
    if grid == "zip":
        return [tuple([i] * len(axes)) for i in range(sizes[0])]
    return list(itertools.product(*[range(n) for n in sizes]))


def point_values(axes: Sequence[Axis], idx: Sequence[int]) -> Dict[str, Any]:
    """``{key: value}`` of one point (values as substituted)."""
    return {a.key: a.values[i] for a, i in zip(axes, idx)}


def substitute(raw: dict, axes: Sequence[Axis], idx: Sequence[int]) -> dict:
    """A copy of the raw configuration with one point's values put in place.

    Raises
    ------
    ConfigError
        ``study.sweep.<key>``: the path runs through a value that is not a mapping.
    """
    # only the mappings on the swept paths are copied; the rest is shared with ``raw``, which
    # load_config reads and never changes
    out = {k: v for k, v in raw.items() if k != "study"}
    for sec in {a.section for a in axes}:
        out[sec] = dict(raw.get(sec) or {})
    copied = {id(out[sec]) for sec in {a.section for a in axes}}
    for a, i in zip(axes, idx):
        node = out[a.section]
        for j, part in enumerate(a.path[:-1]):
            nxt = node.get(part)
            if nxt is None:
                nxt = {}
            if not isinstance(nxt, dict):
                where = ".".join((a.section,) + a.path[:j + 1])
                raise ConfigError(f"study.sweep.{a.key}", f"{where} is {nxt!r}, not a mapping: "
                                                          "cannot set a key inside it")
            if id(nxt) not in copied:
                nxt = node[part] = dict(nxt)
                copied.add(id(nxt))
            node = nxt
        node[a.path[-1]] = copy.deepcopy(a.values[i])
    return out
