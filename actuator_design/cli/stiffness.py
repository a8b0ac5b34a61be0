"""Tangent tip stiffness of the equilibrium, and its dependence on the field.

Solves the scene (stable state), then computes the compliance matrix
C = d(x(1), y(1), theta(1)) / d(fx, fy, m_tip) from the NLP's parametric sensitivity (THEORY §6-7),
the stiffness matrix C^-1 and the vertical stiffness dp/dv1 = 1/C_yy, dimensionless (units of
B0/l^3) and, for physical scenes, in N/m. A scene without a tip force or moment term gets one at
value zero (a companion scene; the report says so).

--field-sweep A,B --n N follows the stable state from h = A to h = B and reports the stiffness
curve with THEORY §6's closed form s(h) = 4h^3/(2h - sqrt(2) tanh(sqrt(2) h)) (exact for phi = 0,
p = 0) alongside; --out DIR then also writes stiffness_curve.csv and stiffness.png.

Without CONFIG the scene is THEORY §5's cantilever with h = 1, phi = 0, p = 0, alpha = 0 unless
flags set them. A CONFIG may carry `study: {type: stiffness, field_sweep: [A, B], n: N, moment:
true}` (plus the scene flags h, phi_deg, p, alpha_deg); flags override it.

Units: lengths (tip x, y) in rod lengths l, energies in B0/l, loads in B0/l^2 (moments B0/l),
stiffness in B0/l^3 (and N/m for physical scenes); angles in degrees on the command line and
radians in the output.

JSON (--json): vertical_stiffness, vertical_stiffness_N_per_m, compliance, stiffness, loads, tips,
symmetry_error, companion_scene, notes, equilibrium, and field_sweep (when requested).
Exit codes: 0 success, 2 bad input, 3 the equilibrium (or a sweep point) did not converge.
"""
from __future__ import annotations

import argparse
import math
import sys

from .common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                     load_config, stdout_to_stderr)
from .output import print_written, write_out
from .path import add_scene_flags, csv_text, scene_and_options, study_settings

__all__ = ["HELP", "add_args", "run"]

HELP = "tangent tip stiffness of the equilibrium (and against the field, with s(h))"

DEFAULTS = {"h": 1.0, "phi_deg": 0.0, "p": 0.0, "alpha_deg": 0.0}


def _study_model():
    from typing import List, Literal, Optional as O

    from pydantic import BaseModel, ConfigDict, Field, StrictBool

    class StiffnessStudy(BaseModel):
        """``study: {type: stiffness, ...}`` — the flags of ``actuator-design stiffness``."""

        model_config = ConfigDict(extra="forbid")
        type: Literal["stiffness"] = "stiffness"
        field_sweep: O[List[float]] = Field(None, min_length=2, max_length=2)
        n: int = Field(41, ge=2, le=100000)
        moment: StrictBool = True
        h: O[float] = Field(None, ge=0)
        phi_deg: O[float] = None
        p: O[float] = None
        alpha_deg: O[float] = None

    return StiffnessStudy


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``stiffness``."""
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene (and optional `study: {type: stiffness, ...}`); omit for the default")
    g = parser.add_argument_group("stiffness")
    g.add_argument("--no-moment", dest="moment", action="store_false", default=None,
                   help="2x2 compliance of (x, y) under (fx, fy) only (default: 3x3 with the tip "
                        "angle and moment)")
    g.add_argument("--field-sweep", metavar="A,B",
                   help="also compute the stiffness for h from A to B (dimensionless, >= 0; for a "
                        "physical scene also fields, e.g. '2 mT,6 mT')")
    g.add_argument("--n", type=int, metavar="N", help="points of the field sweep (>= 2, default 41)")
    add_scene_flags(parser, DEFAULTS)
    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    o.add_argument("--out", metavar="DIR",
                   help="write stiffness.json (and stiffness_curve.csv, stiffness.png with a sweep)")


def _sweep(args, study, units=None):
    text = args.field_sweep
    if text is not None:
        from ..parameters import parameter
        from ..user_units import parameter_from_text

        parts = text.split(",")
        with bad_input():
            ab = [parameter_from_text(v.strip(), parameter("h"), units, "--field-sweep") for v in parts]
        if len(ab) != 2:
            raise InputError(f"--field-sweep: expected two values A,B, got {text!r}")
    else:
        ab = study.field_sweep
    n = args.n if args.n is not None else study.n
    if ab is None:
        if args.n is not None:
            raise InputError("--n: only with --field-sweep")
        return None
    if not all(math.isfinite(v) and v >= 0 for v in ab) or ab[0] == ab[1]:
        raise InputError(f"--field-sweep: need two different finite values h >= 0, got {ab}")
    if n < 2:
        raise InputError(f"--n: must be >= 2, got {n}")
    import numpy as np
    return np.linspace(ab[0], ab[1], n)


def run(args: argparse.Namespace) -> int:
    """Run ``stiffness``."""
    check_out_dir(args.out)
    study, loaded = _study_model()(), None
    if args.config is not None:
        loaded = load_config(args.config)
        study = study_settings(loaded[2], "stiffness", _study_model())
    scene, options, raw = scene_and_options(args, DEFAULTS, study, loaded)
    from ..user_units import user_units

    h_values = _sweep(args, study, user_units(scene, raw))
    moment = study.moment if args.moment is None else args.moment

    from ..analysis.stiffness import stiffness_field_curve, tip_stiffness
    from ..io import dumps_json

    with stdout_to_stderr(args.json), bad_input():
        st = tip_stiffness(scene, options, moment=moment)
        curve = None if h_values is None else stiffness_field_curve(scene, options, h_values,
                                                                    moment=moment)
    data = st.to_dict()
    if curve is not None:
        data["field_sweep"] = curve.to_dict()
    written = None
    if args.out is not None:
        written = write_out(args.out, _render(data, curve, raw, scene), args.json)
    if args.json:
        print(dumps_json(data))
    else:
        print(_summary(st, curve))
    if written is not None:
        print_written(written, args.json)
    ok = st.equilibrium.success and (curve is None or bool(curve.success.all()))
    if not ok:
        print("actuator-design: warning: the equilibrium (or a sweep point) did not converge",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _summary(st, curve) -> str:
    eq = st.equilibrium
    lines = [f"tangent tip stiffness at h = {eq.scene.h:.6g}, phi = {math.degrees(eq.scene.phi):.6g} deg, "
             f"p = {eq.scene.p:.6g} ({'stable' if eq.stable else 'UNSTABLE'} equilibrium, tip angle "
             f"{eq.tip['angle']:.6f} rad)",
             f"  vertical stiffness dp/dv1 : {st.vertical:.12g} B0/l^3"]
    if st.vertical_N_per_m is not None:
        lines.append(f"                              {st.vertical_N_per_m:.6g} N/m")
    lines.append(f"  compliance d({', '.join(st.tips)})/d({', '.join(st.loads)}):")
    for row in st.compliance:
        lines.append("    " + "  ".join(f"{v:14.8g}" for v in row))
    lines.append(f"  symmetry (Maxwell-Betti)  : max|C - C^T|/max|C| = {st.symmetry_error:.2e}")
    for n in st.notes:
        lines.append(f"  note: {n}")
    if curve is not None:
        lines.append(f"  field sweep: h from {curve.h[0]:.6g} to {curve.h[-1]:.6g} ({curve.h.size} points); "
                     f"stiffness from {curve.vertical[0]:.6g} to {curve.vertical[-1]:.6g} B0/l^3 "
                     f"(closed form s(h): {curve.lowload[0]:.6g} to {curve.lowload[-1]:.6g})")
        for n in curve.notes:
            lines.append(f"  note: {n}")
    return "\n".join(lines)


def _render(data, curve, raw, scene):
    from ..io import dumps_json
    from ..viz.loading import stiffness_figure
    from ..viz.style import png_bytes

    payload = dict(data)
    payload["config"] = raw
    files = {"stiffness.json": dumps_json(payload, indent=1) + "\n"}
    if curve is not None:
        cols, rows = curve.table()
        files["stiffness_curve.csv"] = csv_text(
            cols, rows, "units: h dimensionless (THEORY §5); stiffness in B0/l^3 (N/m columns in SI); "
                        "tip angle in rad; lowload_s = THEORY §6 s(h)")
        files["stiffness.png"] = png_bytes(stiffness_figure(curve, si=scene.scales is not None), dpi=150)
    return files
