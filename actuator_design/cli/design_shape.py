"""``design --target-shape FILE.csv``: the design whose centreline passes nearest points (s, x, y).

Exit codes as for a tip target: 0 a verified fit within the tolerance that holds over the box,
2 bad input, 3 not verified, 4 the shape is not reachable (the nearest shape is reported).
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math
from pathlib import Path

from .common import EXIT_OK, InputError, bad_input, stdout_to_stderr
from .output import emit

__all__ = ["run_shape", "read_points"]

EXIT_NOT_VERIFIED, EXIT_UNREACHABLE = 3, 4
_MAX_BYTES = 1 << 20


def read_points(path: str, units: str, scene):
    """The CSV's points in rod lengths (x, y given in rod lengths, or mm/m with ``units``)."""
    from ..analysis.design_shape import read_shape_points

    p = Path(path)
    if not p.is_file():
        raise InputError(f"--target-shape: file not found: {path}")
    if p.stat().st_size > _MAX_BYTES:
        raise InputError(f"--target-shape: {path} is larger than 1 MiB")
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"--target-shape: {path} is not UTF-8 text")
    scale = 1.0
    if units in ("mm", "m"):
        if scene.scales is None:
            raise InputError(f"--target-units {units}: needs a physical scene (this one is dimensionless)")
        scale = (1e-3 if units == "mm" else 1.0) / scene.scales.length
    with bad_input():
        return read_shape_points(text, scale)


def summary(res) -> str:
    d = res.design
    lines = ["actuator-design: inverse design for a target shape",
             f"  points      : {len(res.points)} (s, x, y) along the centreline  [rod lengths]",
             f"  variables   : {', '.join(res.vary)}"]
    if d:
        lines.append(f"  design      : h = {d['h']:.8g}, phi = {math.degrees(d['phi']):.6g} deg (field axis), "
                     f"p = {d['p']:.6g}")
    lines.append(f"  fit         : rms error {res.rms_error:.3e}, largest {res.max_error:.3e}")
    lines.append(f"  verdict     : verified {res.verified}, stable {res.stable}, snap-free {res.snap_free}")
    lines.append(f"  time        : {res.timings.get('total', float('nan')):.2f} s")
    lines.append(f"  note        : {res.message}")
    lines.append("  RESULT      : " + ("SUCCESS — a verified fit of the shape" if res.success else
                                      "NOT a success (see note)"))
    return "\n".join(lines)


def _files(res, raw) -> dict:
    from ..io import dumps_json, scene_to_dict, shape_csv_text

    payload = res.to_dict()
    payload["scene"] = scene_to_dict(res.design_scene) if res.design_scene is not None else None
    payload["config"] = raw
    buf = _io.StringIO()
    w = csv.writer(buf)
    w.writerow(["s", "x_target", "y_target", "x_fitted", "y_fitted"])
    for (s, x, y), (fx, fy) in zip(res.points, res.fitted):
        w.writerow([repr(float(s)), repr(float(x)), repr(float(y)), repr(float(fx)), repr(float(fy))])
    files = {"design.json": dumps_json(payload, indent=1) + "\n", "shape_fit.csv": buf.getvalue()}
    if res.state is not None and res.state.success:
        files["shape.csv"] = shape_csv_text(res.state)
    return files


def run_shape(args: argparse.Namespace, scene, options, raw, vary, settings) -> int:
    from ..analysis.design_shape import design_shape
    pts = read_points(args.target_shape, args.target_units or "rod", scene)
    with stdout_to_stderr(args.json), bad_input():
        res = design_shape(pts, scene=scene, vary=vary, options=options, settings=settings,
                           verify=not args.no_verify)
    emit(args, res, lambda: _files(res, raw), summary)
    if res.success:
        return EXIT_OK
    if not res.verified:
        return EXIT_NOT_VERIFIED
    return EXIT_UNREACHABLE
