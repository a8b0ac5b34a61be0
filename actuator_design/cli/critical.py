"""Find every fold and branch point of one parameter in a window, over all equilibrium branches.

All equilibria are computed (complete shooting scan) at a few values of the parameter across the
window, each is continued until its branch leaves the window, the branches bifurcating at branch
points are followed too, and the critical points are located accurately (root of the reduced
Hessian's eigenvalue along the branch) and deduplicated. Each is reported with the parameter value,
the tip angle (rad) and the number of equilibria just below and above it (shooting counts between
consecutive critical values). Parameters (--param) as for `continue`: h, h2, phi, p, fx, fy,
m_tip, qx, qy, alpha, h_pos, h_r, magnetization, theta0 (angles in rad). E.g. an axial remanent
magnetisation in an anti-parallel field (--h 0 --phi-deg 180 --h-r 0 --param h_r --window 0,5)
buckles at h_r = pi^2/4 (THEORY §9). Each value carries an estimate of its discretisation error
(`value_error`: the point relocated on a mesh of degree + 4). Exit 0 when the list is complete and
every value is within 1e-6 x max(1, |value|); 3 (with the reasons) when the equilibria at a sample
could not be certified complete, a branch stopped inside the window, or a value misses that (its
bifurcating mode is not resolved: refine the mesh).

Units: dimensionless (THEORY §5): lengths in rod lengths l, energies in B0/l, loads in B0/l^2,
angles in rad (the --phi-deg and --alpha-deg flags take degrees). --window accepts units for
parameters with a physical meaning: angles ('10 deg,80 deg') always; for a physical scene fields
('2 mT,6 mT', '5 kA/m,8 kA/m'; h = H dh/dH) and loads ('1 mN,3 mN'). A physical scene's critical
points also carry field_mT and field_A_per_m (or value_N, ...) beside their value.

A physical scene (`type: physical`) also speaks its own units: lengths in the unit rod.length is
written in, fields as mu0 H in mT, loads in N, energies in J — text lines, the JSON's
`physical` keys beside the dimensionless ones, extra CSV columns (value_<unit>, tip_x_<unit>, tip_y_<unit>, energy_J) and
the figure's axes.

With CONFIG, its `study:` section (type: critical; keys param, window [a, b], n_samples and the
scene values h, phi_deg, p, alpha_deg) and then the flags apply.
"""
from __future__ import annotations

import argparse
import sys

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                                        check_parameter_angle, stdout_to_stderr)
from actuator_design.cli.equilibria import add_output_args, add_scene_args, build_scene
from actuator_design.cli.common import print_written, write_out
from actuator_design.config.studies.parameters import PARAM_NAMES, CriticalStudy

__all__ = ["HELP", "add_args", "run", "CriticalStudy"]

HELP = "every fold and branch point of a parameter window, over all branches"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``critical``."""
    add_scene_args(parser)
    c = parser.add_argument_group("critical points")
    c.add_argument("--param", choices=PARAM_NAMES, help="the parameter")
    c.add_argument("--window", metavar="A,B",
                   help="parameter window, A < B; units allowed where the parameter has them, e.g. '2 mT,6 mT'")
    c.add_argument("--samples", type=int, metavar="N",
                   help="parameter values where all equilibria are computed (>= 2; default 5)")
    add_output_args(parser, "critical.json, critical.csv and critical.png")


def _csv(res, units=None) -> str:
    """``critical.csv``: one row per critical point; a physical scene adds the value in the
    parameter's unit (when it has one), the tip in the length unit and the energy in J."""
    from actuator_design.io.unit_results import parameter_conversion, unit_suffix
    from actuator_design.io.user_units import parameter_physical
    from actuator_design.physics.parameters import parameter

    p = parameter(res.param)
    unit = parameter_conversion(p, units)[0] if units is not None else None
    extra, note = [], ""
    if units is not None:
        u = units.length_unit
        extra = ([f"value_{unit_suffix(unit)}"] if unit is not None else []) + [f"tip_x_{u}", f"tip_y_{u}", "energy_J"]
        note = ("; " + (f"value_{unit_suffix(unit)} in {unit}" + (" (mu0 H)" if unit == "mT" else "") + "; "
                        if unit is not None else "")
                + f"tip_x_{u}, tip_y_{u} in {u} (the unit of rod.length); energy_J in J")
    lines = [f"# critical points of {res.param}; tip angle in rad" + note,
             "kind,value,tip_angle,equilibria_below,equilibria_above,located" + "".join("," + c for c in extra)]
    for d in res.folds + res.branch_points:
        row = (f"{d['kind']},{d['value']!r},{d['tip_angle']!r},{d['equilibria_below']},"
               f"{d['equilibria_above']},{int(d['located'])}")
        if units is not None:
            vals = [parameter_physical(p, d["value"], units)] if unit is not None else []
            vals += [units.length(d["tip"]["x"]), units.length(d["tip"]["y"]), d["energy"] * units.moment_scale]
            row += "".join("," + repr(float(v)) for v in vals)
        lines.append(row)
    return "\n".join(lines) + "\n"


def add_units(payload: dict, param, scene, units) -> None:
    """A physical scene's units in ``critical``'s JSON, in place: the top-level ``physical`` and
    each critical point's value in the parameter's unit and ``physical`` {tip, energy_J}."""
    if units is None:
        return
    from actuator_design.io.unit_results import add_point_units, command_physical

    payload["physical"] = command_physical(scene, units, [param])
    add_point_units(payload["folds"] + payload["branch_points"], param, units)


def run(args: argparse.Namespace) -> int:
    """Run ``critical``."""
    check_out_dir(args.out)
    scene, options, raw, study = build_scene(args, CriticalStudy, "critical")
    param = args.param or (study.param if study else None)
    if param is None:
        raise InputError("--param: required (or give it in the config's study section)")
    from actuator_design.io.user_units import (pair_from_text, parameter_unit_label, physical_value_keys,
                                               user_units)
    from actuator_design.physics.parameters import parameter

    units = user_units(scene, raw)
    with bad_input():
        window = (pair_from_text(args.window, parameter(param), units, "--window") if args.window
                  else (tuple(study.window) if study else None))
    if window is None:
        raise InputError("--window: required as A,B (or give it in the config's study section)")
    if not args.window:  # from the study section, in the parameter's unit
        for v in window:
            check_parameter_angle(param, v, "study.window")
    n_samples = args.samples if args.samples is not None else (study.n_samples if study else 5)
    if n_samples < 2:
        raise InputError(f"--samples: must be >= 2, got {n_samples}")

    from actuator_design.continuation.critical import critical_points
    from actuator_design.io.save import dumps_json
    from actuator_design.physics.parameters import set_value as set_param

    with bad_input(f"--param {param}: "):
        set_param(scene, param, window[0])
        set_param(scene, param, window[1])
    with stdout_to_stderr(args.json), bad_input():
        res = critical_points(scene, param, window, options=options, n_samples=n_samples)
    payload = res.to_dict()
    add_units(payload, param, scene, units)
    unit = parameter_unit_label(parameter(param), units)
    written = None
    if args.out is not None:
        from actuator_design.viz.landscape import plot_branches
        from actuator_design.viz.style import png_bytes
        with stdout_to_stderr(args.json):
            ax = plot_branches(res.branches, title=f"branches and critical points in {param}")
            from actuator_design.viz.units import parameter_axis  # h in mT, loads in N, ...
            parameter_axis(ax, parameter(param), units, param, "x", data_max=window[1])
            full = res.to_dict(branches=True)
            add_units(full, param, scene, units)
            files = {"critical.json": dumps_json({**full, "config": raw}, indent=1) + "\n",
                     "critical.csv": _csv(res, units), "critical.png": png_bytes(ax, dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        from actuator_design.io.display import ANGLE_NOISE_RAD, critical_value_note, number
        from actuator_design.io.unit_results import state_text

        def degrees_free(rad):  # a tip angle in rad, round-off of zero as 0
            return number(rad, "+.8f", ANGLE_NOISE_RAD)
        ends = [physical_value_keys(parameter(param), v, units) for v in window]
        span = (f" ({ends[0]['field_mT']:.6g} to {ends[1]['field_mT']:.6g} mT)" if "field_mT" in ends[0] else "")
        print(f"{param} in [{window[0]:g}, {window[1]:g}]{span}: {len(res.folds)} fold(s), "
              f"{len(res.branch_points)} branch point(s) over {res.stats['branches']} branch(es)"
              f" (complete: {res.complete})")
        for d in res.folds + res.branch_points:
            phys = f" ({d['field_mT']:.6g} mT)" if "field_mT" in d else (
                f" ({next(v for k, v in d.items() if k.startswith('value_')):.6g} {unit})" if unit else "")
            print(f"  {d['kind']:12s} {param} = {d['value']:.12g}{phys}  tip angle {degrees_free(d['tip_angle'])} rad  "
                  f"equilibria {d['equilibria_below']} -> {d['equilibria_above']}"
                  + critical_value_note(d["value"], d.get("value_error"), d["located"]).replace(",", " ", 1))
            if units is not None:
                print(f"      in the user's units: {state_text(d['tip'], d['energy'], units)}")
        if units is not None:
            from actuator_design.io.unit_results import physical_header, scene_text, units_line
            given = scene_text(scene, units)
            print(f"  user units: {units_line(units)}" + (f"; scene: {given}" if given else ""))
            for note in physical_header(units, [param])["notes"]:
                print(f"  note: {note}")
    if written is not None:
        print_written(written, args.json)
    for why in res.incomplete_reasons:
        print(f"actuator-design: warning: not complete: {why}", file=sys.stderr)
    if res.accuracy is not None:
        print(f"actuator-design: warning: inaccurate: {res.accuracy}", file=sys.stderr)
    if not res.complete or res.accuracy is not None:  # the list may miss points, or misplace one
        return EXIT_NOT_CONVERGED
    return EXIT_OK
