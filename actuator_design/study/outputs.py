"""A study's files: the tidy results table (CSV, Parquet when pyarrow is there) and the manifest.

Pure I/O: nothing here solves. Every file goes through :func:`actuator_design.io.save.atomic_write`
(or, for Parquet, a temporary name and :func:`os.replace`), so no reader sees a half-written file.
A study folder grows by design (journal, resume, figures redrawn at the end), so unlike a command's
``--out`` set (:func:`actuator_design.io.save.write_output_set`) it is not written all or nothing.

The table has one row per point: ``point`` (index in the grid), one column per swept key
(``field.magnitude [kA/m]``: the number in the unit of the key's first value), ``status``,
``message``, ``time_s``, then the analysis results (``solve.tip.angle``, …) kept by ``outputs``.
"""
from __future__ import annotations

import csv
import fnmatch
import io
import os
import platform
import sys
import uuid
from importlib import metadata
from pathlib import Path
from typing import Dict, List, Optional, Sequence

from actuator_design.io.save import atomic_write, dumps_json
from actuator_design.io.unit_columns import add_unit_columns, current_study_config, table_units

__all__ = ["table_columns", "build_table", "write_csv", "write_parquet", "write_manifest",
           "versions"]

_PACKAGES = ("actuator-design", "casadi", "numpy", "scipy", "pydantic", "pint", "PyYAML",
             "matplotlib", "tqdm", "dask", "distributed", "pyarrow")


def versions() -> Dict[str, Optional[str]]:
    """Python, platform and the versions of the package and its dependencies (None: absent)."""
    out: Dict[str, Optional[str]] = {"python": sys.version.split()[0],
                                     "platform": platform.platform()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def table_columns(axes, records: Dict[int, dict], outputs: Optional[Sequence[str]]) -> List[str]:
    """Column names: fixed columns, swept keys, then result columns (first-seen order) kept by
    the ``outputs`` glob patterns (all when None)."""
    seen: Dict[str, None] = {}
    for i in sorted(records):
        for k in records[i].get("results", {}):
            seen.setdefault(k, None)
    results = list(seen)
    if outputs is not None:
        results = [c for c in results if any(fnmatch.fnmatchcase(c, p) for p in outputs)]
    return ["point"] + [a.column for a in axes] + ["status", "message", "time_s"] + results


def build_table(axes, indices, records: Dict[int, dict], outputs=None,
                raw: Optional[dict] = None) -> Dict[str, list]:
    """Column name → list of values (one per point with a record, by point index).

    A physical study (``raw``, the configuration; default the one set by
    :func:`actuator_design.io.unit_columns.study_config`) gets, after these, columns in the user's
    units (:func:`actuator_design.io.unit_columns.add_unit_columns`): a swept field also as μ0 H in
    mT (``field.magnitude [mT]``), a swept force in N, SI lengths and lengths in rod lengths in
    the unit of ``rod.length`` (``solve.physical.tip_x_mm``, ``solve.tip.x_mm``), fields in A/m
    and the group h as μ0 H in mT (``solve.physical.field_mT``, ``solve.h_mT``).
    """
    table = _plain_table(axes, indices, records, outputs)
    add_unit_columns(table, axes, table_units(current_study_config() if raw is None else raw, axes))
    return table


def _plain_table(axes, indices, records: Dict[int, dict], outputs=None) -> Dict[str, list]:
    """:func:`build_table` without the columns in the user's units."""
    cols = table_columns(axes, records, outputs)
    table: Dict[str, list] = {c: [] for c in cols}
    for i in sorted(records):
        rec = records[i]
        res = rec.get("results", {})
        table["point"].append(i)
        for a, j in zip(axes, indices[i]):
            table[a.column].append(a.numbers[j] if a.numbers[j] is not None else
                                   (a.values[j] if isinstance(a.values[j], (str, int, float, bool))
                                    else dumps_json(a.values[j])))
        table["status"].append(rec.get("status"))
        table["message"].append(rec.get("message", ""))
        table["time_s"].append(rec.get("time_s"))
        for c in cols[len(axes) + 4:]:
            table[c].append(res.get(c))
    return table


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_csv(path, table: Dict[str, list]) -> Path:
    """Write the table as CSV (empty cell = missing)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = list(table)
    w.writerow(cols)
    n = len(table[cols[0]]) if cols else 0
    for r in range(n):
        w.writerow([_cell(table[c][r]) for c in cols])
    text = buf.getvalue()
    return atomic_write(path, lambda fh: fh.write(text))


def write_parquet(path, table: Dict[str, list]) -> Optional[Path]:
    """Write the table as Parquet when pyarrow is installed (else do nothing and return None)."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return None
    path = Path(path)
    arrays = {}
    for c, vals in table.items():
        kinds = {type(v) for v in vals if v is not None}
        if kinds <= {int, float} and kinds:
            arrays[c] = pa.array([None if v is None else float(v) for v in vals], pa.float64())
        elif kinds == {bool}:
            arrays[c] = pa.array(vals, pa.bool_())
        else:
            arrays[c] = pa.array([None if v is None else str(v) for v in vals], pa.string())
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        pq.write_table(pa.table(arrays), tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def write_manifest(path, manifest: dict) -> Path:
    """Write ``manifest.json`` (strict JSON, NaN as null), indented, with one line per point
    (a million points stay quick to write and to read)."""
    points = manifest.get("points")
    if not isinstance(points, list):
        text = dumps_json(manifest, indent=1) + "\n"
    else:
        token = uuid.uuid4().hex  # a placeholder no configuration value can equal
        mark = f"\"{token}\""
        head = dumps_json({**manifest, "points": token}, indent=1)
        body = ("[\n  " + ",\n  ".join(dumps_json(p) for p in points) + "\n ]") if points else "[]"
        text = head.replace(mark, body, 1) + "\n"
    return atomic_write(path, lambda fh: fh.write(text))
