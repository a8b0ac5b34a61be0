"""Tangent tip stiffness of the equilibrium, and its dependence on the field.

Solves the scene (stable state), then computes the compliance matrix
C = d(x(1), y(1), theta(1)) / d(fx, fy, m_tip) from the NLP's parametric sensitivity (THEORY §6-7),
the stiffness matrix C^-1 and the vertical stiffness dp/dv1 = 1/C_yy, dimensionless (units of
B0/l^3) and, for physical scenes, in N/m. A scene without a tip force or moment term gets one at
value zero (a companion scene; the report says so).

--field-sweep A,B --n N follows the stable state from h = A to h = B and reports the stiffness
curve with THEORY §6's closed form s(h) = 4h^3/(2h - sqrt(2) tanh(sqrt(2) h)) (exact for phi = 0,
p = 0) alongside; --out DIR then also writes stiffness_curve.csv and stiffness.png (without a
sweep, stiffness.png is the state with its compliance ellipse at the tip).

Without CONFIG the scene is THEORY §5's cantilever with h = 1, phi = 0, p = 0, alpha = 0 unless
flags set them. A CONFIG may carry `study: {type: stiffness, field_sweep: [A, B], n: N, moment:
true}` (plus the scene flags h, phi_deg, p, alpha_deg); flags override it.

Units: lengths (tip x, y) in rod lengths l, energies in B0/l, loads in B0/l^2 (moments B0/l),
stiffness in B0/l^3 (and N/m for physical scenes); angles in degrees on the command line and
radians in the output.

JSON (--json): vertical_stiffness, vertical_stiffness_N_per_m, compliance, stiffness, loads, tips,
symmetry_error, companion_scene, notes, equilibrium, and field_sweep (when requested). A physical
scene adds the user's units: 'physical' (the state's field in mT (mu0 H) and A/m, its tip in the
unit rod.length is written in, the compliance in m/N, 1/N, rad/N, rad/(N m) and the stiffness in
N/m, N/rad, N, N m/rad with the unit of every entry), field_sweep.field_mT and
field_sweep.lowload_s_N_per_m (also columns of stiffness_curve.csv), text lines in them, and
stiffness.png in N/m against mT.
Exit codes: 0 success, 2 bad input, 3 the equilibrium (or a sweep point) did not converge.
"""
from __future__ import annotations

import argparse
import math
import sys

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                     load_config, stdout_to_stderr)
from actuator_design.cli.common import print_written, write_out
from actuator_design.cli.path import add_scene_flags, csv_text, scene_and_options, study_settings

__all__ = ["HELP", "add_args", "run"]

HELP = "tangent tip stiffness of the equilibrium (and against the field, with s(h))"

DEFAULTS = {"h": 1.0, "phi_deg": 0.0, "p": 0.0, "alpha_deg": 0.0}


def _study_model():
    from actuator_design.config.studies.commands import StiffnessStudy  # (pydantic loads only when a study is read)

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
        from actuator_design.physics.parameters import parameter
        from actuator_design.io.user_units import parameter_from_text

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
    from actuator_design.io.user_units import user_units

    units = user_units(scene, raw)
    h_values = _sweep(args, study, units)
    moment = study.moment if args.moment is None else args.moment

    from actuator_design.analysis.stiffness import stiffness_field_curve, tip_stiffness
    from actuator_design.io.save import dumps_json

    with stdout_to_stderr(args.json), bad_input():
        st = tip_stiffness(scene, options, moment=moment)
        curve = None if h_values is None else stiffness_field_curve(scene, options, h_values,
                                                                    moment=moment)
    data = st.to_dict()
    if curve is not None:
        data["field_sweep"] = curve.to_dict()
    add_physical(data, st, curve, units)
    written = None
    if args.out is not None:
        written = write_out(args.out, _render(data, curve, raw, scene, units, st), args.json)
    if args.json:
        print(dumps_json(data))
    else:
        print(_summary(st, curve))
        for line in _physical_lines(data, st, curve, units):
            print(line)
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


def add_physical(data: dict, st, curve, units) -> None:
    """Add the user's units to the ``stiffness --json`` payload in place (no key renamed or
    removed; nothing for a dimensionless scene).

    ``physical``: ``length_unit``; ``field_mT`` and ``field_A_per_m`` (mu0 H and H of the state's
    h, when the scene converts a field); ``tip`` {x, y} in the length unit; ``vertical_stiffness_N_per_m``;
    ``compliance`` (m/N, 1/N, rad/N, rad/(N m)) and ``stiffness`` (N/m, N/rad, N, N m/rad) in SI
    with ``compliance_units``/``stiffness_units`` naming the unit of every entry; ``units``.
    ``field_sweep`` gains ``field_mT`` (mu0 H) and ``lowload_s_N_per_m`` (s(h) · B0/l^3).
    """
    if units is None:
        return
    from actuator_design.io.unit_columns import compliance_si, stiffness_si

    eq = data["equilibrium"]
    comp, comp_units = compliance_si(st.compliance, st.tips, st.loads, units)
    stiff, stiff_units = stiffness_si(st.stiffness, st.tips, st.loads, units)
    phys = {"length_unit": units.length_unit,
            "tip": {"x": units.length(eq["tip"]["x"]), "y": units.length(eq["tip"]["y"])},
            "vertical_stiffness_N_per_m": st.vertical * units.stiffness_scale,
            "compliance": comp, "compliance_units": comp_units,
            "stiffness": stiff, "stiffness_units": stiff_units,
            "units": {"tip": units.length_unit, "field_mT": "mT (mu0 H)", "field_A_per_m": "A/m",
                      "vertical_stiffness_N_per_m": "N/m", "compliance": "compliance_units",
                      "stiffness": "stiffness_units"}}
    if units.has_field:
        phys["field_mT"] = units.field_mT(eq["h"])
        phys["field_A_per_m"] = units.field_A_per_m(eq["h"])
    data["physical"] = phys
    if curve is not None:
        sweep = data["field_sweep"]
        mT = _sweep_mT(curve)
        if mT is not None:
            sweep["field_mT"] = mT
        sweep["lowload_s_N_per_m"] = [float(v) * units.stiffness_scale for v in curve.lowload]


def _sweep_mT(curve):
    """mu0 H in mT of every sweep point (None without a field scale: no NaN is reported)."""
    import numpy as np

    from actuator_design.model.units import MU0
    H = curve.field_A_per_m
    if H is None or not np.all(np.isfinite(H)):
        return None
    return [float(v) * MU0 * 1e3 for v in H]


def _physical_lines(data, st, curve, units) -> list:
    """The state, the compliance and stiffness matrices and the sweep in the user's units."""
    from actuator_design.io.display import number
    from actuator_design.io.unit_columns import length_noise

    phys = data.get("physical")
    if phys is None:
        return []
    u, noise = units.length_unit, length_noise(units)
    field = (f"mu0 H = {number(phys['field_mT'])} mT ({number(phys['field_A_per_m'])} A/m)"
             if "field_mT" in phys else
             "field: none converted (this scene has no field scale: its material's coupling per field is 0)")
    lines = [f"  in the user's units      : {field}; tip ({number(phys['tip']['x'], noise=noise)}, "
             f"{number(phys['tip']['y'], noise=noise)}) {u}"]
    for title, key in (("compliance (SI)", "compliance"), ("stiffness C^-1 (SI)", "stiffness")):
        rows, cols = (st.tips, st.loads) if key == "compliance" else (st.loads, st.tips)
        lines.append(f"  {title} d({', '.join(rows)})/d({', '.join(cols)}):")
        for vals, labs in zip(phys[key], phys[f"{key}_units"]):
            lines.append("    " + "  ".join((f"{v:12.6g} {lab:<9s}" if math.isfinite(v) else
                                            f"{'singular':>12s} {'':<9s}") for v, lab in zip(vals, labs)))
    if curve is not None:
        sw = data["field_sweep"]
        where = (f"mu0 H from {number(sw['field_mT'][0])} to {number(sw['field_mT'][-1])} mT"
                 if "field_mT" in sw else f"h from {curve.h[0]:.6g} to {curve.h[-1]:.6g} (no field scale)")
        k = curve.vertical * units.stiffness_scale
        lines.append(f"  field sweep in SI        : {where}; stiffness from {k[0]:.6g} to {k[-1]:.6g} N/m "
                     f"(closed form s(h): {sw['lowload_s_N_per_m'][0]:.6g} to "
                     f"{sw['lowload_s_N_per_m'][-1]:.6g} N/m)")
    return lines


def _render(data, curve, raw, scene, units=None, st=None):
    from actuator_design.io.save import dumps_json
    from actuator_design.viz.loading import stiffness_figure
    from actuator_design.viz.style import png_bytes

    payload = dict(data)
    payload["config"] = raw
    files = {"stiffness.json": dumps_json(payload, indent=1) + "\n"}
    if curve is not None:
        cols, rows = curve.table()
        comment = ("units: h dimensionless (THEORY §5); stiffness in B0/l^3 (N/m columns in SI); "
                   "tip angle in rad; lowload_s = THEORY §6 s(h)")
        if units is not None:
            sw = data["field_sweep"]
            extra = [("field_mT", sw.get("field_mT")), ("lowload_s_N_per_m", sw["lowload_s_N_per_m"])]
            extra = [(c, v) for c, v in extra if v is not None]
            cols = list(cols) + [c for c, _v in extra]
            rows = [list(r) + [v[i] for _c, v in extra] for i, r in enumerate(rows)]
            comment += ("; field_mT = mu0 H in mT" if "field_mT" in sw else
                        "; no field_mT column: this scene has no field scale") + "; lowload_s_N_per_m in N/m"
        files["stiffness_curve.csv"] = csv_text(cols, rows, comment)
        files["stiffness.png"] = png_bytes(stiffness_figure(
            curve, si=scene.scales is not None,
            stiffness_scale=None if units is None else units.stiffness_scale), dpi=150)
    elif st is not None:  # one state: its shape with the compliance ellipse at the tip
        from actuator_design.viz.compliance import compliance_figure
        files["stiffness.png"] = png_bytes(compliance_figure(st, units), dpi=150)
    return files
