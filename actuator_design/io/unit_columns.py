"""The user's units beside dimensionless outputs: matrices, data columns and study-table columns.

The conversions themselves are :class:`~actuator_design.io.user_units.UserUnits`'s (THEORY §5: lengths x = x̂ ℓ,
forces in B0/ℓ², moments in B0/ℓ, stiffness in B0/ℓ³, the field μ0 H = μ0 h / (dh/dH)); this
module applies them to the outputs of ``stiffness`` (the compliance and stiffness matrices in SI
with a unit per entry), ``fit`` (a data column's unit in the user's units: lengths in the unit of
``rod.length``, fields in mT, forces in N) and ``study`` (columns added to the results table:
swept fields in mT, forces in N, lengths and SI metres in the unit of ``rod.length``, the field
group h as μ0 H in mT). Nothing here solves; a dimensionless scene gets nothing added.
"""
from __future__ import annotations

import contextlib
import contextvars
import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

from actuator_design.config import load_scene
from actuator_design.io.user_units import user_units
from actuator_design.model.units import MU0, parse_quantity
from actuator_design.physics.parameters import parameter

__all__ = ["TIP_UNITS", "load_unit", "compliance_si", "stiffness_si", "data_unit",
           "TableUnits", "table_units", "add_unit_columns", "unit_column", "axis_unit_columns",
           "derived_name", "study_config",
           "current_study_config", "length_noise"]

#: SI unit of each tip quantity and tip load of the compliance matrix (THEORY §6-7).
TIP_UNITS = {"x": "m", "y": "m", "angle": "rad"}
#: SI unit of a load of the compliance matrix, by its dimensionless unit (the lens parameter's)
_SI_OF_LOAD = {"B0/l^2": "N", "B0/l": "N m"}


def load_unit(name: str) -> str:
    """SI unit of the load ``name`` of the compliance matrix (``fx``, ``fy``: N; a tip moment: N m)."""
    return _SI_OF_LOAD[parameter(name).unit]


def length_noise(units) -> float:
    """Round-off of a zero length in the user's unit (1e-12 rod lengths): a tip y of -1e-16 mm
    is printed as 0 (:func:`~actuator_design.io.display.number`)."""
    return 1e-12 * units.length(1.0)


# -- stiffness: the matrices in SI ----------------------------------------------------------------
def _tip_scale(name: str, units) -> float:
    return units.length_m if name in ("x", "y") else 1.0


def _load_scale(name: str, units) -> float:
    return units.moment_scale if load_unit(name) == "N m" else units.force_scale


def compliance_si(C, tips: Sequence[str], loads: Sequence[str], units) -> Tuple[list, list]:
    """The compliance C[i, j] = d tip_i / d load_j in SI and the unit of every entry.

    Parameters
    ----------
    C : array_like, shape (k, k)
        Dimensionless compliance (tips in rod lengths and rad, loads in B0/ℓ² and B0/ℓ).
    tips, loads : sequence of str
        Row names (``x``, ``y``, ``angle``) and column names (``fx``, ``fy``, ``m_tip``).
    units : UserUnits

    Returns
    -------
    (list of list of float, list of list of str)
        C_SI[i][j] = C[i][j] · (tip scale_i) / (load scale_j): m/N, 1/N (m per N m), rad/N,
        rad/(N m).
    """
    values = [[float(C[i][j]) * _tip_scale(t, units) / _load_scale(f, units)
               for j, f in enumerate(loads)] for i, t in enumerate(tips)]
    labels = [[_compliance_unit(t, f) for f in loads] for t in tips]
    return values, labels


def _compliance_unit(tip: str, load: str) -> str:
    num, den = TIP_UNITS[tip], load_unit(load)
    if num == "m" and den == "N m":
        return "1/N"
    return f"{num}/({den})" if " " in den else f"{num}/{den}"


def stiffness_si(K, tips: Sequence[str], loads: Sequence[str], units) -> Tuple[list, list]:
    """The stiffness K = C⁻¹, K[i, j] = d load_i / d tip_j, in SI and the unit of every entry:
    K_SI[i][j] = K[i][j] · (load scale_i) / (tip scale_j): N/m, N/rad, N (N m per m), N m/rad."""
    values = [[float(K[i][j]) * _load_scale(f, units) / _tip_scale(t, units)
               for j, t in enumerate(tips)] for i, f in enumerate(loads)]
    labels = [[_stiffness_unit(f, t) for t in tips] for f in loads]
    return values, labels


def _stiffness_unit(load: str, tip: str) -> str:
    num, den = load_unit(load), TIP_UNITS[tip]
    if num == "N m" and den == "m":
        return "N"
    return f"{num}/{den}"


# -- fit: a data column in the user's units -------------------------------------------------------
def data_unit(dimension: str, length_unit: str, metres_per_unit: float) -> Optional[Tuple[str, float]]:
    """``(unit, SI value of one unit)`` a measured column of ``dimension`` is reported in: lengths
    in the unit of ``rod.length``, fields as μ0 H in mT (1 mT ↔ 1e-3/μ0 A/m), forces in N; None
    for angles (kept in the data file's unit) and anything else."""
    if dimension == "length":
        return length_unit, float(metres_per_unit)
    if dimension == "magnetic_field":
        return "mT", 1e-3 / MU0
    if dimension == "force":
        return "N", 1.0
    return None


# -- study: columns of the results table ----------------------------------------------------------
_STUDY_CONFIG: contextvars.ContextVar = contextvars.ContextVar("study_config", default=None)


@contextlib.contextmanager
def study_config(raw: Optional[dict]):
    """Within the block, a study's tables and figures are written for the configuration ``raw``
    (its scene's units) unless a call names another one (``actuator-design study`` sets it)."""
    token = _STUDY_CONFIG.set(raw)
    try:
        yield
    finally:
        _STUDY_CONFIG.reset(token)


def current_study_config() -> Optional[dict]:
    """The configuration set by :func:`study_config` (None outside it)."""
    return _STUDY_CONFIG.get()


#: Swept scene keys that cannot change the scene's scales (ℓ, B0, dh/dH): the field itself, the
#: loads and the clamp (THEORY §5: dh/dH = √(μ0 χ̄ A ℓ² / (2 B0)) reads the rod and magnetics only).
_SCALE_FREE = ("field.", "loads.", "clamp.")


@dataclass(frozen=True)
class TableUnits:
    """The user's units of a physical study.

    Attributes
    ----------
    length_unit : str
        The unit ``rod.length`` is written in.
    metres_per_unit : float
    length_m : float
        ℓ of the configuration, m (used unless ``length_key`` is swept).
    length_key : str or None
        The swept key of the rod length (``rod.length``), if any.
    h_per_field : float
        dh/dH of the configuration, per A/m, when no swept key can change it; else 0 (a row's
        ``<analysis>.scales.h_per_field_per_A_per_m`` is used where the table has it).
    """

    length_unit: str
    metres_per_unit: float
    length_m: float
    length_key: Optional[str] = None
    h_per_field: float = 0.0


def table_units(raw: Optional[dict], axes=()) -> Optional[TableUnits]:
    """The units of a study of configuration ``raw`` with swept ``axes`` (None: dimensionless or
    unreadable)."""
    if not isinstance(raw, dict) or (raw.get("scene") or {}).get("type") != "physical":
        return None
    try:
        scene, _options, raw = load_scene({k: v for k, v in raw.items() if k != "study"})
    except Exception:  # noqa: BLE001 - the study reports a bad configuration itself
        return None
    units = user_units(scene, raw)
    if units is None:
        return None
    scene_keys = [a.key for a in axes if a.section == "scene"]
    fixed = all(k.startswith(_SCALE_FREE) for k in scene_keys)
    length_key = next((k for k in scene_keys if k == "rod.length"), None)
    return TableUnits(units.length_unit, units.metres_per_unit, units.length_m, length_key,
                      units.h_per_field if fixed else 0.0)


def _unit_factor(unit: str, dimension: str) -> Optional[float]:
    """SI value of one ``unit`` in ``dimension`` (a field in A/m, T as H = B/μ0), or None."""
    if not unit:
        return None
    try:
        return float(parse_quantity(f"1 {unit}", dimension, "unit"))
    except Exception:  # noqa: BLE001 - not a unit of this dimension
        return None


def _axis_columns(axis, units: TableUnits) -> List[Tuple[str, str, float]]:
    """``(column, unit, factor)`` of a swept key in the user's units (value = number × factor)."""
    if not axis.numeric or axis.section != "scene":
        return []
    out = []
    for dimension, target, per in (("magnetic_field", "mT", 1e-3 / MU0), ("force", "N", 1.0),
                                   ("length", units.length_unit, units.metres_per_unit)):
        f = _unit_factor(axis.unit, dimension)
        if f is not None:
            if axis.unit != target:
                out.append((f"{axis.key} [{target}]", target, f / per))
            break
    return out


def _split(column: str) -> Tuple[str, str]:
    """``(name part, list-index tail)``: ``a.clamp_force_N.0`` → (``a.clamp_force_N``, ``.0``)."""
    parts = column.split(".")
    tail = []
    while len(parts) > 1 and parts[-1].isdigit():
        tail.insert(0, parts.pop())
    return ".".join(parts), "".join("." + t for t in tail)


_SI_SUFFIXES = (("_N_per_m", None), ("_Pa", None), ("_A_per_m", "field"), ("_N_m", None), ("_Nm", None),
                ("_per_m", None), ("_m", "length"))


def derived_name(column: str, units: TableUnits) -> Optional[Tuple[str, str, str]]:
    """``(new column, unit, kind)`` of a result column in the user's units, or None.

    kinds: ``"si_length"`` (``*_m`` → ``*_<unit>``), ``"si_field"`` (``*_A_per_m`` → ``*_mT``),
    ``"rod_length"`` (``*.tip.x``, ``*.tip_y`` … in rod lengths → ``*_<unit>``), ``"group_h"``
    (``*.h``, ``*.groups.h`` → ``*_mT``, μ0 H of the field group h).
    """
    name, tail = _split(column)
    last = name.rsplit(".", 1)[-1]
    lu = units.length_unit
    for suffix, kind in _SI_SUFFIXES:
        if last.endswith(suffix) and last != suffix and not last[:-len(suffix)].endswith("_per"):
            if kind == "field":
                return f"{name[:-len(suffix)]}_mT{tail}", "mT", "si_field"
            if kind == "length" and lu != "m":
                return f"{name[:-len(suffix)]}_{lu}{tail}", lu, "si_length"
            return None
    if tail == "" and (name.endswith((".tip.x", ".tip.y")) or last in ("tip_x", "tip_y")):
        return f"{column}_{lu}", lu, "rod_length"
    if tail == "" and (last == "h" and "." in name):
        return f"{column}_mT", "mT", "group_h"
    return None


def add_unit_columns(table: Dict[str, list], axes, units: Optional[TableUnits]) -> Dict[str, str]:
    """Add the table's columns in the user's units, in place (existing columns are kept).

    Swept keys: ``<key> [mT]`` for a field given in another unit (μ0 H), ``<key> [N]`` for a force,
    ``<key> [<unit>]`` for a length in another unit; results: see :func:`derived_name`. A value
    that cannot be converted (no ℓ or dh/dH for the row, χ̄ = 0, not a number) is left empty.

    Returns
    -------
    dict of str → str
        New column → its unit (empty for a dimensionless study).
    """
    if units is None or not table:
        return {}
    n = len(next(iter(table.values())))
    added: Dict[str, str] = {}
    by_column = {a.column: a for a in axes}
    lengths = _row_lengths(table, by_column, units, n)
    for a in axes:
        for col, unit, factor in _axis_columns(a, units):
            if col not in table:
                table[col] = [None if _num(v) is None else _num(v) * factor for v in table[a.column]]
                added[col] = unit
    for column in list(table):
        if column in by_column or column in added or column in ("point", "status", "message"):
            continue
        d = derived_name(column, units)
        if d is None or d[0] in table:
            continue
        new, unit, kind = d
        values = _converted(table, column, kind, lengths, units, n)
        if values is not None:
            table[new] = values
            added[new] = unit
    return added


def _num(v) -> Optional[float]:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        return None
    return float(v)


def _row_lengths(table, by_column, units: TableUnits, n: int) -> List[Optional[float]]:
    """ℓ in m of every row: the swept rod length, else the configuration's."""
    if units.length_key is None:
        return [units.length_m] * n
    axis = next(a for a in by_column.values() if a.key == units.length_key)
    per = _unit_factor(axis.unit, "length")
    if per is None:
        return [None] * n
    return [None if _num(v) is None else _num(v) * per for v in table[axis.column]]


def _converted(table, column, kind, lengths, units: TableUnits, n) -> Optional[list]:
    values = [_num(v) for v in table[column]]
    if all(v is None for v in values) and any(v is not None for v in table[column]):
        return None  # not a numeric column
    if kind == "si_field":
        return [None if v is None else v * MU0 * 1e3 for v in values]
    if kind == "si_length":
        return [None if v is None else v / units.metres_per_unit for v in values]
    if kind == "rod_length":
        return [None if v is None or ell is None else v * ell / units.metres_per_unit
                for v, ell in zip(values, lengths)]
    # group_h: μ0 H = μ0 h / (dh/dH), dh/dH of the configuration or of the row's analysis
    own = table.get(f"{column.split('.', 1)[0]}.scales.h_per_field_per_A_per_m")
    rates = [_num(v) for v in own] if own is not None else [units.h_per_field or None] * n
    if not any(rates):
        return None
    return [None if v is None or not c else v / c * MU0 * 1e3 for v, c in zip(values, rates)]


def axis_unit_columns(axis, table: Dict[str, list]) -> List[Tuple[str, str, float]]:
    """``(column, unit, factor)`` of the table's columns of swept key ``axis`` in another unit
    (``field.magnitude [mT]`` beside ``field.magnitude [kA/m]``): value = number × factor."""
    out = []
    prefix = f"{axis.key} ["
    for column in table:
        if column == axis.column or not column.startswith(prefix) or not column.endswith("]"):
            continue
        unit = column[len(prefix):-1]
        for dimension in ("magnetic_field", "force", "length"):
            fa, ft = _unit_factor(axis.unit, dimension), _unit_factor(unit, dimension)
            if fa is not None and ft is not None:
                out.append((column, unit, fa / ft))
                break
    return out


def unit_column(column: str, table: Dict[str, list], axes=(),
                units: Optional[TableUnits] = None) -> Optional[Tuple[str, str]]:
    """``(column, unit)`` of the table's column in the user's units that :func:`add_unit_columns`
    made of ``column``, or None when there is none."""
    if units is None:
        return None
    for a in axes:
        if a.column == column:
            return next(((c, u) for c, u, _f in _axis_columns(a, units) if c in table), None)
    d = derived_name(column, units)
    return (d[0], d[1]) if d is not None and d[0] in table else None
