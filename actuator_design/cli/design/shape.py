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

from actuator_design.io.display import degrees, number
from actuator_design.cli.common import (EXIT_NOT_VERIFIED, EXIT_OK, EXIT_UNREACHABLE, InputError, bad_input,
                                        stdout_to_stderr)
from actuator_design.cli.common import emit

__all__ = ["run_shape", "read_points"]

_MAX_BYTES = 1 << 20


def read_points(path: str, units: str, scene):
    """The CSV's points in rod lengths (x, y given in rod lengths, or mm/m with ``units``)."""
    from actuator_design.inverse.shape import read_shape_points

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


def summary(res, units=None) -> str:
    """The text report; with a physical scene's ``units`` also the field in mT, the load in N and
    the errors in the scene's length unit."""
    d = res.design
    lines = ["actuator-design: inverse design for a target shape",
             f"  points      : {len(res.points)} (s, x, y) along the centreline  [rod lengths]",
             f"  variables   : {', '.join(res.vary)}"]
    if d:
        lines.append(f"  design      : h = {number(d['h'], '.8g')}, phi = {degrees(d['phi'])} deg (field axis), "
                     f"p = {number(d['p'])}"
                     # the other groups at the design field (h_pos, h_r, THEORY §5, §9)
                     + "".join(f", {k} = {v:.8g}" for k, v in d.items() if k not in ("h", "phi", "p")
                               and isinstance(v, float)))
    lines.append(f"  fit         : rms error {res.rms_error:.3e}, largest {res.max_error:.3e}  [rod lengths]")
    phys = _physical(res, units)
    if phys:
        u = phys["length_unit"]
        field = (f"field {number(phys['field_mT'])} mT, " if "field_mT" in phys else "")
        lines.append(f"  physical    : {field}tip load {number(phys['tip_load_N'])} N; rms error "
                     f"{number(phys['rms_error'])} {u}, largest {number(phys['max_error'])} {u}")
    lines.append(f"  verdict     : verified {res.verified}, stable {res.stable}, snap-free {res.snap_free}")
    lines.append(f"  time        : {res.timings.get('total', float('nan')):.2f} s")
    lines.append(f"  note        : {res.message}")
    lines.append("  RESULT      : " + ("SUCCESS — a verified fit of the shape" if res.success else
                                      "NOT a success (see note)"))
    return "\n".join(lines)


def _physical(res, units) -> dict:
    """The design in the scene's units: field (mT), tip load (N), errors (length unit); {} for a
    dimensionless scene or no design."""
    if units is None or not res.design:
        return {}
    d = res.design
    out = {"length_unit": units.length_unit, "rms_error": units.length(res.rms_error),
           "max_error": units.length(res.max_error), "tip_load_N": float(d["p"]) * units.force_scale}
    if units.has_field:
        out["field_mT"] = units.field_mT(d["h"])
        out["field_A_per_m"] = units.field_A_per_m(d["h"])
    out["field_angle_deg"] = math.degrees(d["phi"])
    return out


def payload_of(res, raw, units=None) -> dict:
    """design.json: the result's keys, the design scene, the config and (physical scene) ``physical``."""
    from actuator_design.io.save import scene_to_dict

    payload = res.to_dict()
    payload["scene"] = scene_to_dict(res.design_scene) if res.design_scene is not None else None
    payload["config"] = raw
    phys = _physical(res, units)
    if phys:
        payload["physical"] = phys
    return payload


def _files(res, raw, units=None) -> dict:
    from actuator_design.io.save import dumps_json, shape_csv_text
    from actuator_design.viz.design import shape_fit_figure
    from actuator_design.viz.style import png_bytes

    buf = _io.StringIO()
    w = csv.writer(buf)
    header = ["s", "x_target", "y_target", "x_fitted", "y_fitted"]
    if units is not None:
        u = units.length_unit
        buf.write(f"# units: s, x, y in rod lengths; *_{u} in {u}\n")
        header += [f"{c}_{u}" for c in header[1:]]
    w.writerow(header)
    for (s, x, y), (fx, fy) in zip(res.points, res.fitted):
        row = [float(s), float(x), float(y), float(fx), float(fy)]
        if units is not None:
            row += [units.length(v) for v in row[1:]]
        w.writerow([repr(v) for v in row])
    files = {"design.json": dumps_json(payload_of(res, raw, units), indent=1) + "\n",
             "shape_fit.csv": buf.getvalue(),
             "shape_fit.png": png_bytes(shape_fit_figure(res, units=units), dpi=150)}
    if res.state is not None and res.state.success:
        files["shape.csv"] = shape_csv_text(res.state)
    return files


def run_shape(args: argparse.Namespace, scene, options, raw, vary, settings) -> int:
    from actuator_design.inverse.shape import design_shape
    from actuator_design.io.user_units import user_units
    pts = read_points(args.target_shape, args.target_units or "rod", scene)
    units = user_units(scene, raw)
    with stdout_to_stderr(args.json), bad_input():
        res = design_shape(pts, scene=scene, vary=vary, options=options, settings=settings,
                           verify=not args.no_verify)
    emit(args, res, lambda: _files(res, raw, units), lambda r: summary(r, units),
         payload=payload_of(res, raw, units))
    if res.success:
        return EXIT_OK
    if not res.verified:
        return EXIT_NOT_VERIFIED
    return EXIT_UNREACHABLE
