"""A study's results as a labelled N-dimensional array: ``results.nc`` (netCDF3, built with xarray).

The dataset holds what ``results.csv`` holds (:func:`actuator_design.study.outputs.build_table`),
laid out on the grid instead of one row per point:

dimensions
    A cartesian grid has one dimension per swept key, named by the key (``field.magnitude``), in
    the order of ``study.sweep``, with the swept values as its coordinate (the numbers of the
    table's column, in the unit of the key's first value; text for values that are not numbers).
    A zipped grid of more than one key is no rectangle: it has one dimension ``point`` (the grid
    index, 0 … n-1) with every swept key a coordinate along it. A zip of one key is the
    one-dimensional grid of that key.
coordinate attributes
    ``units``: the key's unit as written in the YAML (``kA/m``, ``deg``), ``"1"`` for plain
    numbers, none for values that are not numbers; ``csv_column``: the table's column.
    A physical study's swept field, force or length given in another unit than the user's also
    has a coordinate in the user's units along the same dimension, from the table's column
    ``<key> [<unit>]``: ``field.magnitude_mT`` (μ0 H, ``units = "mT"``), ``loads.tip_force.y_N``,
    ``rod.length_mm`` (the unit of ``rod.length``).
data variables
    ``point`` (cartesian grids, int32): the grid index, as in the table's ``point`` column.
    ``status`` (int8): CF flags, ``flag_values`` 0 … and ``flag_meanings``
    ``"ok not_converged invalid error not_run"`` (more meanings are appended if records carry
    other statuses); ``not_run``: the point has no record (a partial table).
    One variable per numeric column of the table, named as the column (``time_s``,
    ``solve.tip.angle``): numbers (integers too) as float64, NaN where a point has no value (not
    run, or an analysis that failed there); true/false columns (``solve.success``,
    ``solve.stable``) as int8 0/1 with ``flag_values``/``flag_meanings``, and, only when some
    point has no value, ``_FillValue = -1`` (xarray then decodes the variable as float with NaN).
    Columns of text (messages, unit labels, mixed values) and columns no point fills are left out:
    ``results.csv`` keeps them.
units of data variables
    Only where the table states one (:func:`column_units`), never guessed: a name ending the
    package's way (``time_s``, ``tip_x_m``, ``energy_J``, ``clamp_force_N.0``, ``field_A_per_m``;
    the columns in the user's units: ``tip_x_mm``, ``field_mT``, ``h_mT``),
    or an analysis's own unit labels kept in the table (``solve.units.energy = B0/l`` gives
    ``solve.energy`` its unit). Every variable also has ``csv_column``.
global attributes
    ``title``, ``config_name``, ``config_path`` (when the configuration was a file),
    ``actuator_design_version``, ``source``, ``study_id``, ``grid``, ``n_points``, ``n_run``.

netCDF3 through SciPy (``engine="scipy"``: no netCDF4/HDF5 library needed) has no 64-bit
integers, no booleans and no variable-length strings: the types above are float64, int32, int8 and
text as fixed-width UTF-8 character arrays, all of which it writes and reads back exactly. The file
is built in memory and written with :func:`actuator_design.io.save.atomic_write` (temporary name,
rename), so no reader ever sees half of it. xarray is imported only here, when a dataset is built.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from actuator_design import __version__
from actuator_design.io.save import atomic_write, dumps_json
from actuator_design.io.unit_columns import axis_unit_columns
from actuator_design.study.outputs import _cell

__all__ = ["STATUS_MEANINGS", "column_units", "build_dataset", "dataset_bytes", "write_dataset"]

#: Status codes of the ``status`` variable: position = code (``flag_values``).
STATUS_MEANINGS = ("ok", "not_converged", "invalid", "error", "not_run")

#: The table's fixed columns (not results): ``point`` and ``status`` are variables of their own,
#: ``message`` is text.
_FIXED = ("point", "status", "message")

#: Name endings that state a unit in the package's result keys, longest first
#: (``time_s``, ``tip_x_m``, ``energy_J``, ``clamp_force_N``, ``clamp_moment_Nm``,
#: ``vertical_stiffness_N_per_m``, ``field_A_per_m``, ``tip_angle_rad``, ``phi_deg``).
_SUFFIX_UNITS = (("_N_per_m", "N/m"), ("_Pa", "Pa"), ("_A_per_m", "A/m"), ("_N_m", "N m"), ("_Nm", "N m"),
                 ("_rad", "rad"), ("_deg", "deg"), ("_mT", "mT"), ("_mm", "mm"), ("_cm", "cm"),
                 ("_um", "um"), ("_µm", "µm"), ("_nm", "nm"), ("_km", "km"), ("_J", "J"),
                 ("_N", "N"), ("_m", "m"), ("_s", "s"))

#: Results whose unit an analysis's ``units`` labels give by kind rather than by name: the
#: tip position of an equilibrium is in its ``length`` unit, the residual of the moment balance
#: in its ``moment`` unit (:class:`actuator_design.equilibrium.result.EquilibriumResult`).
_KIND_OF = {"tip.x": "length", "tip.y": "length", "el_residual": "moment"}


def _name_part(column: str) -> str:
    """The last part of a dotted column name that is not a list index (``clamp_force_N.0`` →
    ``clamp_force_N``)."""
    parts = column.split(".")
    while len(parts) > 1 and parts[-1].isdigit():
        parts.pop()
    return parts[-1]


def _suffix_unit(column: str) -> Optional[str]:
    """The unit a column's name ends with, or None (also for a rate such as ``points_per_s``)."""
    name = _name_part(column)
    for suffix, unit in _SUFFIX_UNITS:
        stem = name[:-len(suffix)]
        if name.endswith(suffix) and stem and not stem.endswith("_per"):
            return unit
    return None


def _unit_labels(table: Dict[str, list]) -> Dict[str, Dict[str, str]]:
    """``{analysis: {label: unit}}`` from the table's ``<analysis>.units.<label>`` columns (text,
    the same at every point that has it)."""
    labels: Dict[str, Dict[str, str]] = {}
    for column, values in table.items():
        parts = column.split(".")
        if len(parts) != 3 or parts[1] != "units":
            continue
        found = {v for v in values if v is not None}
        if len(found) == 1 and isinstance(next(iter(found)), str):
            labels.setdefault(parts[0], {})[parts[2]] = found.pop()
    return labels


def column_units(table: Dict[str, list]) -> Dict[str, str]:
    """Units of the table's result columns, where the table states them.

    A column's unit is, first, what its name ends with (:data:`_SUFFIX_UNITS`: ``time_s`` → s,
    ``solve.physical.tip_x_m`` → m), else its analysis's unit label (a column
    ``<analysis>.units.<label>``) named by the column's last name part (``solve.units.energy``
    for ``solve.energy``, ``solve.units.force`` for ``solve.clamp_reaction.force.0``) or by its
    kind (:data:`_KIND_OF`: ``solve.units.length`` for ``solve.tip.x``). Columns of no stated unit
    are absent.

    Parameters
    ----------
    table : dict of str → list
        Column name → values (:func:`~actuator_design.study.outputs.build_table`).

    Returns
    -------
    dict of str → str
        Column name → unit text as the table gives it (``"s"``, ``"B0/l"``, ``"rod length"``).
    """
    labels = _unit_labels(table)
    out: Dict[str, str] = {}
    for column in table:
        unit = _suffix_unit(column)
        analysis, _, rest = column.partition(".")
        own = labels.get(analysis, {})
        if unit is None and rest and not rest.startswith("units."):
            unit = own.get(_name_part(rest))
            if unit is None:
                kind = next((k for key, k in _KIND_OF.items()
                             if rest == key or rest.endswith("." + key)), None)
                unit = own.get(kind) if kind else None
        if unit is not None:
            out[column] = unit
    return out


def _kind(values: Sequence[Any]) -> Optional[str]:
    """``"number"``, ``"bool"`` or None (text, mixed, or no value at all) for a column."""
    kinds = set(map(type, values))
    kinds.discard(type(None))
    if not kinds:
        return None
    if kinds == {bool}:
        return "bool"
    if kinds <= {int, float}:
        return "number"
    return None


def _axis_coordinate(axis) -> tuple:
    """``(values, attrs)`` of a swept key's coordinate: its numbers (in the key's unit) or, for
    values that are not numbers, the table's text of them."""
    attrs = {"csv_column": axis.column}
    if axis.numeric:
        return np.asarray(axis.numbers, dtype=np.float64), {"units": axis.unit or "1", **attrs}
    texts = [_cell(v if isinstance(v, (str, int, float, bool)) else dumps_json(v))
             for v in axis.values]
    return np.asarray(texts, dtype=str), attrs


def _user_unit_coordinates(axis, table: Dict[str, list]) -> Dict[str, tuple]:
    """Coordinates of a numeric swept key in the user's units, from the table's columns
    ``<key> [<unit>]`` (:func:`actuator_design.io.unit_columns.add_unit_columns`): name
    ``<key>_<unit>`` (``field.magnitude_mT``) → (column, unit, factor on the key's numbers)."""
    if not axis.numeric:
        return {}
    return {f"{axis.key}_{unit.replace('/', '_per_').replace(' ', '_')}": (column, unit, factor)
            for column, unit, factor in axis_unit_columns(axis, table)}


def _status_codes(statuses: Sequence[Any]) -> List[str]:
    """The status meanings: :data:`STATUS_MEANINGS`, then any other status in the records."""
    meanings = list(STATUS_MEANINGS)
    for s in statuses:
        word = str(s).replace(" ", "_")
        if word not in meanings:
            meanings.append(word)
    return meanings


def build_dataset(axes, indices, grid: str, table: Dict[str, list],
                  attrs: Optional[Dict[str, Any]] = None):
    """The study's results on its grid (see the module docstring for the layout).

    Parameters
    ----------
    axes : list of Axis
        The swept keys (:func:`~actuator_design.study.grid.resolve_axes`), sizes ``n_1 … n_k``.
    indices : list of tuple of int, length n_points
        Value indices of every grid point (:func:`~actuator_design.study.grid.grid_indices`).
    grid : {"cartesian", "zip"}
    table : dict of str → list
        The table of the points that have a record
        (:func:`~actuator_design.study.outputs.build_table`: ``point`` gives each row's grid
        index); grid points without a row are ``not_run``.
    attrs : dict, optional
        Global attributes (text or numbers).

    Returns
    -------
    xarray.Dataset
        Cartesian: every variable of shape ``(n_1, …, n_k)`` over dims ``(key_1, …, key_k)``;
        zip of k > 1 keys: shape ``(n_points,)`` over dim ``point``.
    """
    import xarray as xr

    n_points = len(indices)
    rows = np.asarray(table.get("point", []), dtype=np.int64)
    gridded = grid != "zip" or len(axes) == 1
    if gridded:
        dims = tuple(a.key for a in axes)
        shape = tuple(len(a.values) for a in axes)
        where = np.asarray(indices, dtype=np.int64).reshape(n_points, len(axes))
        flat = np.ravel_multi_index(tuple(where.T), shape)  # grid point → cell
        cells = flat[rows]
        coords = {}
        for a in axes:
            values, a_attrs = _axis_coordinate(a)
            coords[a.key] = xr.Variable((a.key,), values, a_attrs)
            for name, (column, unit, factor) in _user_unit_coordinates(a, table).items():
                coords[name] = xr.Variable((a.key,), values * factor, {"units": unit, "csv_column": column})
    else:
        dims, shape = ("point",), (n_points,)
        flat = np.arange(n_points)
        cells = rows
        coords = {"point": xr.Variable(("point",), np.arange(n_points, dtype=np.int32),
                                       {"long_name": "grid point", "csv_column": "point"})}
        for a in axes:
            values, a_attrs = _axis_coordinate(a)
            at = values[[i[0] for i in indices]]
            coords[a.key] = xr.Variable(("point",), at, a_attrs)
            for name, (column, unit, factor) in _user_unit_coordinates(a, table).items():
                coords[name] = xr.Variable(("point",), at * factor, {"units": unit, "csv_column": column})

    def on_grid(values, dtype, fill) -> np.ndarray:
        out = np.full(int(np.prod(shape)), fill, dtype=dtype)
        out[cells] = values
        return out.reshape(shape)

    data: Dict[str, Any] = {}
    if gridded:
        point = np.full(int(np.prod(shape)), -1, dtype=np.int32)
        point[flat] = np.arange(n_points, dtype=np.int32)
        data["point"] = xr.Variable(dims, point.reshape(shape),
                                    {"long_name": "grid point (index in results.csv and the "
                                                  "journal)", "csv_column": "point"})
    meanings = _status_codes(table.get("status", []))
    code = {m: i for i, m in enumerate(meanings)}
    status = [code[str(s).replace(" ", "_")] for s in table.get("status", [])]
    data["status"] = xr.Variable(dims, on_grid(status, np.int8, code["not_run"]), {
        "long_name": "status of the point", "flag_values": np.arange(len(meanings), dtype=np.int8),
        "flag_meanings": " ".join(meanings), "csv_column": "status",
        "comment": "not_run: the point has no record (not computed)"})
    units = column_units(table)
    axis_columns = {a.column for a in axes} | {v.attrs.get("csv_column") for v in coords.values()}
    for column, values in table.items():
        if column in _FIXED or column in coords or column in axis_columns:
            continue
        kind = _kind(values)
        v_attrs = {"csv_column": column, **({"units": units[column]} if column in units else {})}
        full = kind is not None and None not in values
        if kind == "number":
            nums = np.array(values if full else [np.nan if v is None else v for v in values],
                            dtype=np.float64)
            data[column] = xr.Variable(dims, on_grid(nums, np.float64, np.nan), v_attrs)
        elif kind == "bool":
            flags = np.array(values if full else [-1 if v is None else v for v in values],
                             dtype=np.int8)
            var = xr.Variable(dims, on_grid(flags, np.int8, -1), {
                **v_attrs, "flag_values": np.array([0, 1], dtype=np.int8),
                "flag_meanings": "false true"})
            if (var.values < 0).any():
                var.encoding["_FillValue"] = np.int8(-1)
            data[column] = var
    ds = xr.Dataset(data, coords=coords, attrs={k: v for k, v in (attrs or {}).items()
                                                if v is not None})
    ds.attrs.update(n_points=n_points, n_run=int(len(rows)))
    return ds


def dataset_bytes(ds) -> bytes:
    """The netCDF3 (64-bit offset) file of ``ds``, written by SciPy through xarray."""
    encoding = {name: {"_FillValue": None} for name in ds.coords}
    return bytes(ds.to_netcdf(engine="scipy", encoding=encoding))


def write_dataset(path, plan, table: Dict[str, list]) -> Path:
    """Write ``results.nc`` of a study atomically (temporary name in the folder, then rename).

    Parameters
    ----------
    path : Path
        The file (``<study folder>/results.nc``).
    plan : StudyPlan
        The study (:func:`~actuator_design.study.plan.plan_study`): grid, swept keys and the global
        attributes.
    table : dict of str → list
        The table written to ``results.csv``.

    Returns
    -------
    Path

    Raises
    ------
    OSError
        The file system refused the write (``path`` is as it was).
    """
    attrs = {"title": f"actuator-design study: {plan.name}", "config_name": plan.name,
             "config_path": plan.source, "actuator_design_version": __version__,
             "source": f"actuator-design {__version__} (study)", "study_id": plan.study_id,
             "grid": plan.spec.grid}
    data = dataset_bytes(build_dataset(plan.axes, plan.indices, plan.spec.grid, table, attrs))
    return atomic_write(path, lambda fh: fh.write(data), binary=True)
