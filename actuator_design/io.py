"""Saving results: pure I/O, never solves.

``write_result`` writes ``result.json`` (the result contract with the scene and config embedded),
``shape.csv`` (the dense shape) and ``shape.png`` (a drawing) into a directory. Every file is written
to a temporary name in the same directory and moved into place with :func:`os.replace`, so a reader
never sees a half-written file.
"""
from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import os
import uuid
from pathlib import Path
from typing import Callable, Dict, Optional

import numpy as np

__all__ = ["jsonable", "dumps_json", "scene_to_dict", "result_to_dict", "write_result",
           "shape_csv_text", "atomic_write"]

#: Number of points of the dense shape written to ``shape.csv``.
CSV_POINTS = 201


def jsonable(obj):
    """A copy of ``obj`` made of JSON types only: numpy scalars and arrays become Python numbers
    and lists, tuples become lists, dataclasses dicts, and NaN / ±inf become ``None``."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, Path):
        return str(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return jsonable({f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)})
    return str(obj)


def dumps_json(obj, indent: Optional[int] = None) -> str:
    """Strict JSON text of ``obj`` (after :func:`jsonable`; never emits NaN)."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False, ensure_ascii=False)


def scene_to_dict(scene) -> Dict[str, object]:
    """All fields of a :class:`~actuator_design.scene.Scene` as plain data.

    Profiles via ``Profile.as_dict``, scales via ``Scales.as_dict``; angles in rad, lengths in ℓ.
    """
    field = None
    if scene.field is not None:
        field = {f.name: getattr(scene.field, f.name) for f in dataclasses.fields(scene.field)}
    return jsonable({
        "name": scene.name,
        "field": field,
        "h": scene.h,
        "h_pos": scene.h_pos,
        "fibres": scene.fibres.as_dict(),
        "stiffness": scene.stiffness.as_dict(),
        "tip_force": None if scene.tip_force is None else list(scene.tip_force),
        "tip_moment": scene.tip_moment,
        "distributed_load": None if scene.distributed_load is None else list(scene.distributed_load),
        "theta0": scene.theta0,
        "scales": None if scene.scales is None else scene.scales.as_dict(),
    })


def result_to_dict(result, config: Optional[dict] = None) -> Dict[str, object]:
    """``result.to_dict()`` plus ``scene``, ``config`` (raw, if given) and ``package_version``."""
    from . import __version__
    out = dict(result.to_dict())
    out["scene"] = scene_to_dict(result.scene)
    out["config"] = config
    out["package_version"] = __version__
    return jsonable(out)


def atomic_write(path, write: Callable, binary: bool = False) -> Path:
    """Write a file through ``write(fh)`` to a temporary name beside ``path``, then rename it."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        kwargs = {} if binary else {"encoding": "utf-8", "newline": ""}
        with open(tmp, "xb" if binary else "x", **kwargs) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def shape_csv_text(result) -> str:
    """The dense shape (:data:`CSV_POINTS` points) as CSV text: s, x, y, theta, dtheta [, x_m, y_m].

    The first line is a comment stating the units; the second the column names.
    """
    d = result.evaluate(np.linspace(0.0, 1.0, CSV_POINTS))
    cols = ["s", "x", "y", "theta", "dtheta"]
    data = [d[c] for c in cols]
    scales = result.scene.scales
    if scales is not None:
        cols += ["x_m", "y_m"]
        data += [d["x"] * scales.length, d["y"] * scales.length]
    table = np.column_stack([np.asarray(c, float) for c in data])
    lines = ["# units: s, x, y in rod lengths l (clamp at the origin); theta in rad; dtheta = "
             "dtheta/ds in rad per rod length" + ("; x_m, y_m in m" if scales is not None else ""),
             ",".join(cols)]
    lines += [",".join(repr(float(v)) for v in row) for row in table]
    return "\n".join(lines) + "\n"


def write_result(result, out_dir, config: Optional[dict] = None) -> Dict[str, Path]:
    """Write ``result.json``, ``shape.csv`` and ``shape.png`` into ``out_dir``.

    Everything is rendered in memory first; the directory is created (with parents) only then, and
    each file goes through :func:`atomic_write`.

    Parameters
    ----------
    result : EquilibriumResult
        A result of :func:`actuator_design.equilibrium.solve` (converged or not).
    out_dir : str or Path
        Output directory.
    config : dict, optional
        The raw configuration the scene came from, embedded in ``result.json``.

    Returns
    -------
    dict
        ``{"json": path, "csv": path, "png": path}``.
    """
    from .plotting import save_shape_png

    payload = dumps_json(result_to_dict(result, config), indent=1) + "\n"
    csv_text = shape_csv_text(result)
    png = io.BytesIO()
    save_shape_png(result, png)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "result.json", "csv": out / "shape.csv", "png": out / "shape.png"}
    atomic_write(paths["json"], lambda fh: fh.write(payload))
    atomic_write(paths["csv"], lambda fh: fh.write(csv_text))
    atomic_write(paths["png"], lambda fh: fh.write(png.getvalue()), binary=True)
    return paths
