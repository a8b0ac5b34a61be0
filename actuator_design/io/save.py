"""Saving results: all file writing, never solves, never draws.

* :func:`atomic_write` writes one file to a temporary name beside it and moves it into place with
  :func:`os.replace`, so a reader never sees a half-written file;
* :func:`write_output_set` writes a command's whole output set all or nothing (see there);
* :func:`write_result` writes ``result.json`` (the result contract with the scene and config
  embedded), ``shape.csv`` (the dense shape) and, when given, the shape figure as ``shape.png``.

Figures reach this module already drawn: as PNG bytes, or as any object with a matplotlib-like
``savefig(file, format=..., dpi=...)`` method. This module never imports matplotlib or
:mod:`actuator_design.viz`.
"""
from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import os
import shutil
import uuid
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Union

import numpy as np

from actuator_design import __version__
from actuator_design.io.safe_files import write_all
from actuator_design.model.profiles import Profile
from actuator_design.model.scene import TermValues
from actuator_design.physics.registration import describe_scales, saved_scales_fields

__all__ = ["jsonable", "dumps_json", "scene_to_dict", "result_to_dict", "result_files",
           "write_result", "shape_csv_text", "atomic_write", "write_output_set", "encode_content",
           "FileContent"]

#: What a file of an output set may be given as: text (written as UTF-8), bytes, or a drawn figure
#: (any object with ``savefig(file, format="png", dpi=...)``, written as PNG).
FileContent = Union[str, bytes, bytearray, object]

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
    """Strict JSON text of ``obj`` (after :func:`jsonable`; never emits NaN).

    Data made of JSON types already (a study's records) is encoded directly; anything the strict
    encoder refuses (numpy types, NaN, paths, dataclasses) goes through :func:`jsonable` first.
    """
    try:
        return json.dumps(obj, indent=indent, allow_nan=False, ensure_ascii=False)
    except (TypeError, ValueError):
        return json.dumps(jsonable(obj), indent=indent, allow_nan=False, ensure_ascii=False)


def scene_to_dict(scene) -> Dict[str, object]:
    """All fields of a :class:`~actuator_design.model.scene.Scene` as plain data, enough to rebuild it
    (:func:`actuator_design.io.saved.scene_from_dict`).

    One key per field of the dataclass and per term value (``scene.values``), whatever term it
    belongs to: profiles via ``Profile.as_dict``, plug-in terms as ``{"name", "values"}``, scales via
    ``Scales.as_dict`` (derived SI units) and, exactly, ``scales_fields`` (the dataclass's own
    fields); angles in rad, lengths in ℓ.
    """
    out = {"name": scene.name}  # first, as a reader looks for it
    out.update((f.name, _plain(getattr(scene, f.name))) for f in dataclasses.fields(scene) if f.name != "values")
    out["extra_terms"] = _plain(scene.extra_terms) or []  # the plug-in terms, each {"name", "values"}
    out.update((name, _plain(value)) for name, value in scene.values  # each built-in value under its own name
               if not isinstance(value, TermValues))
    out["scales"] = describe_scales(scene.scales)
    out["scales_fields"] = saved_scales_fields(scene.scales)
    return jsonable(out)


def _plain(value):
    """A scene field's value as data :func:`jsonable` completes (profiles and plug-in terms by hand)."""
    if isinstance(value, Profile):
        return value.as_dict()
    if isinstance(value, tuple) and value and all(isinstance(t, TermValues) for t in value):
        return [{"name": t.name, "values": [[k, v] for k, v in t.values]} for t in value]
    return value


def result_to_dict(result, config: Optional[dict] = None) -> Dict[str, object]:
    """``result.to_dict()`` plus ``scene``, ``config`` (raw, if given) and ``package_version``."""
    out = dict(result.to_dict())
    out["scene"] = scene_to_dict(result.scene)
    out["config"] = config
    out["package_version"] = __version__
    return jsonable(out)


def atomic_write(path, write: Callable, binary: bool = False) -> Path:
    """Write a file through ``write(fh)`` to a temporary name beside ``path``, then rename it.

    ``write`` fills an in-memory file (text, or bytes with ``binary``); its content is then written
    to a new temporary file in the same folder (created exclusively: never through an existing
    link) and moved over ``path`` with :func:`os.replace` (which replaces a link at ``path``
    itself, never its target). On any failure the temporary file is removed and ``path`` is as it
    was.
    """
    path = Path(path)
    buf = io.BytesIO() if binary else io.StringIO(newline="")
    write(buf)
    data = buf.getvalue() if binary else buf.getvalue().encode("utf-8")
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        _write_new_file(tmp, data)
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(err, OSError) and err.filename is None:  # os.write names no file
            err.filename = str(path)
        raise
    return path


def _unique_suffix() -> str:
    return f"{os.getpid()}.{uuid.uuid4().hex[:8]}"


def encode_content(content: FileContent, dpi: int = 150) -> bytes:
    """The bytes of one output file: text as UTF-8, bytes as given, a figure as PNG.

    Parameters
    ----------
    content : str, bytes or object with ``savefig``
    dpi : int
        Resolution of a figure given as an object (dots per inch).

    Raises
    ------
    TypeError
        ``content`` is none of these.
    """
    if isinstance(content, str):
        return content.encode("utf-8")
    if isinstance(content, (bytes, bytearray)):
        return bytes(content)
    if callable(getattr(content, "savefig", None)):
        buf = io.BytesIO()
        content.savefig(buf, format="png", dpi=dpi)
        return buf.getvalue()
    raise TypeError(f"cannot write an object of type {type(content).__name__} to a file: "
                    "expected str, bytes or a figure with savefig")


def _write_new_file(path: Path, data: bytes) -> None:
    """Create ``path`` (it must not exist, not even as a link) holding ``data``, flushed to disk."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
    try:
        write_all(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(path: Path) -> None:
    """Make a rename in directory ``path`` durable (best effort: not every platform allows it)."""
    with contextlib.suppress(OSError, AttributeError):
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _make_parents(directory: Path) -> List[Path]:
    """Create ``directory`` and its missing ancestors; return those created, outermost first."""
    missing = []
    d = directory
    while not d.exists():
        missing.append(d)
        if d.parent == d:
            break
        d = d.parent
    created = []
    for d in reversed(missing):
        try:
            d.mkdir()
        except FileExistsError:
            continue
        created.append(d)
    return created


def _commit_into_existing(staging: Path, out: Path, names: List[str]) -> None:
    """Move the complete set in ``staging`` into the existing directory ``out``, all or nothing.

    Each file of an earlier set is first moved aside (into ``staging``), then the new file moved in
    (:func:`os.replace`: same file system). When any move fails, the new files are removed and the
    earlier ones put back before the error is raised. Files of ``out`` outside the set are left
    alone.
    """
    for name in names:
        target = out / name
        if target.is_dir() and not target.is_symlink():
            raise IsADirectoryError(f"{target} is a directory, cannot replace it with a file")
    previous = staging / ".previous"
    previous.mkdir()
    moved_aside: List[str] = []
    placed: List[str] = []
    try:
        for name in names:
            target = out / name
            if os.path.lexists(target):
                os.replace(target, previous / name)
                moved_aside.append(name)
            os.replace(staging / name, target)
            placed.append(name)
    except BaseException:
        for name in reversed(placed):
            with contextlib.suppress(OSError):
                os.unlink(out / name)
        for name in reversed(moved_aside):
            with contextlib.suppress(OSError):
                os.replace(previous / name, out / name)
        raise
    _fsync_dir(out)


def write_output_set(out_dir, files: Mapping[str, FileContent], dpi: int = 150) -> List[Path]:
    """Write a command's output set into ``out_dir``, all or nothing.

    Every file is rendered in memory first (figures to PNG), then written into a hidden staging
    folder; only when the whole set is there is it moved into place:

    * ``out_dir`` does not exist: the staging folder is its sibling and is renamed to ``out_dir``
      (one atomic rename; missing parents are created first);
    * ``out_dir`` exists (an earlier set, other files, a mount point): the staging folder is inside
      it (same file system) and each file replaces its namesake; if any move fails, the earlier
      files are restored (see :func:`_commit_into_existing`).

    On failure nothing of the new set is left: no file, no staging folder, no parent directory that
    this call created. (A process killed outright cannot clean up: it may leave its hidden
    ``.partial-*`` staging folder behind and, if killed during the final moves into an existing
    folder, a mix of earlier and new files.)

    Parameters
    ----------
    out_dir : str or Path
        The directory of the set.
    files : mapping of file name → str, bytes or figure
        Plain file names (no directories); see :data:`FileContent`.
    dpi : int
        Resolution of figures given as objects.

    Returns
    -------
    list of Path
        ``out_dir / name`` for every file, in the order of ``files``.

    Raises
    ------
    OSError
        A file could not be written or moved into place (the message names it); ``out_dir`` is
        as before the call.
    ValueError
        A name is not a plain file name.
    """
    names = list(files)
    for name in names:
        if not name or name in (".", "..", ".previous") or os.sep in name \
                or (os.altsep and os.altsep in name):
            raise ValueError(f"output file name {name!r}: must be a plain file name")
    data = {name: encode_content(files[name], dpi) for name in names}
    out = Path(os.path.abspath(out_dir))
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"{out_dir} exists and is not a directory")
    created = [] if out.exists() else _make_parents(out.parent)
    fresh = not out.exists()
    staging = (out.parent / f".{out.name}.partial-{_unique_suffix()}" if fresh
               else out / f".partial-{_unique_suffix()}")
    try:
        staging.mkdir()
        for name in names:
            _write_new_file(staging / name, data[name])
        _fsync_dir(staging)
        try:
            if not fresh:
                raise FileExistsError
            os.rename(staging, out)
            _fsync_dir(out.parent)
        except FileExistsError:  # out_dir exists (or appeared meanwhile): file by file
            _commit_into_existing(staging, out, names)
        except OSError:
            if not out.is_dir():
                raise
            _commit_into_existing(staging, out, names)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        for d in reversed(created):
            with contextlib.suppress(OSError):
                d.rmdir()
        raise
    shutil.rmtree(staging, ignore_errors=True)
    return [Path(out_dir) / name for name in names]


def shape_csv_text(result, units=None) -> str:
    """The dense shape (:data:`CSV_POINTS` points) as CSV text: s, x, y, theta, dtheta [, x_m, y_m].

    The first line is a comment stating the units; the second the column names. With ``units``
    (a physical scene's :class:`~actuator_design.io.user_units.UserUnits`) also, after those, the
    shape in the unit ``rod.length`` is written in: ``s_<unit>``, ``x_<unit>``, ``y_<unit>`` (x_mm,
    y_mm; x_m and y_m are not repeated for a rod written in m) and ``dtheta_rad_per_<unit>``.
    """
    d = result.evaluate(np.linspace(0.0, 1.0, CSV_POINTS))
    cols = ["s", "x", "y", "theta", "dtheta"]
    data = [d[c] for c in cols]
    scales = result.scene.scales
    if scales is not None:
        cols += ["x_m", "y_m"]
        data += [d["x"] * scales.length, d["y"] * scales.length]
    note = "; x_m, y_m in m" if scales is not None else ""
    if units is not None:
        u, f = units.length_unit, units.length(1.0)
        extra = [(f"s_{u}", d["s"] * f)] + [(f"{c}_{u}", d[c] * f) for c in ("x", "y") if f"{c}_{u}" not in cols]
        extra.append((f"dtheta_rad_per_{u}", d["dtheta"] / f))
        cols += [c for c, _v in extra]
        data += [v for _c, v in extra]
        note += f"; s_{u}, x_{u}, y_{u} in {u} (the unit of rod.length); dtheta_rad_per_{u} in rad/{u}"
    table = np.column_stack([np.asarray(c, float) for c in data])
    lines = ["# units: s, x, y in rod lengths l (clamp at the origin); theta in rad; dtheta = "
             "dtheta/ds in rad per rod length" + note,
             ",".join(cols)]
    lines += [",".join(repr(float(v)) for v in row) for row in table]
    return "\n".join(lines) + "\n"


def result_files(result, config: Optional[dict] = None, units=None,
                 payload: Optional[dict] = None) -> Dict[str, str]:
    """The data files of ``solve --out`` in memory: ``result.json`` and ``shape.csv`` (text).

    Parameters
    ----------
    result : EquilibriumResult
        A result of :func:`actuator_design.equilibrium.pipeline.solve` (converged or not).
    config : dict, optional
        The raw configuration the scene came from, embedded in ``result.json``.
    units : UserUnits, optional
        A physical scene's user units: ``shape.csv`` adds the shape in them
        (:func:`shape_csv_text`).
    payload : dict, optional
        The result's JSON contract to write (default ``result.to_dict()``), e.g. with the user's
        units added; ``scene``, ``config`` and ``package_version`` are added to it.
    """
    if payload is None:
        data = result_to_dict(result, config)
    else:
        data = jsonable({**payload, "scene": scene_to_dict(result.scene), "config": config,
                         "package_version": __version__})
    return {"result.json": dumps_json(data, indent=1) + "\n",
            "shape.csv": shape_csv_text(result, units)}


def write_result(result, out_dir, config: Optional[dict] = None,
                 figure: Optional[FileContent] = None) -> Dict[str, Path]:
    """Write ``result.json``, ``shape.csv`` and (when ``figure`` is given) ``shape.png`` into
    ``out_dir``, all or nothing (:func:`write_output_set`).

    Parameters
    ----------
    result : EquilibriumResult
        A result of :func:`actuator_design.equilibrium.pipeline.solve` (converged or not).
    out_dir : str or Path
        Output directory (created with its parents if needed).
    config : dict, optional
        The raw configuration the scene came from, embedded in ``result.json``.
    figure : bytes or object with ``savefig``, optional
        The drawing of the shape, e.g. ``viz.style.png_bytes(viz.shape.shape_figure(result))``.

    Returns
    -------
    dict
        ``{"json": path, "csv": path}`` and ``"png": path`` when a figure was given.

    Raises
    ------
    OSError
        A file of the set could not be written; nothing of the set was left in ``out_dir``.
    """
    files: Dict[str, FileContent] = dict(result_files(result, config))
    if figure is not None:
        files["shape.png"] = figure
    paths = write_output_set(out_dir, files)
    keys = {"result.json": "json", "shape.csv": "csv", "shape.png": "png"}
    return {keys[p.name]: p for p in paths}
