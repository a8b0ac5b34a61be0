"""Continue an equilibrium branch in one parameter (pseudo-arclength), with stability, folds and
branch points.

The equilibrium at --from A (the state reached from rest, or the straight rod with --straight) is
followed through folds until the parameter leaves [min(A, B), max(A, B)], on one mesh graded for
the window's more demanding end. The states at the branch's least and greatest parameter value
and at its sharpest clamp layer are held to the accuracy of `solve`, and each located fold and
branch point to 1e-6 x max(1, |value|) by its estimated error (`value_error`: relocated on a mesh of
degree + 4); the JSON's `accurate`, `accuracy`, `success`: a branch that misses either exits 3 and
says where. Parameters (--param):
h, h2 (= h^2), phi (rad), p (vertical tip load), fx, fy, m_tip, qx, qy, alpha (constant fibre
angle, rad), theta0 (clamp angle, rad). Folds are limit points of the parameter; branch points are
where another branch crosses (e.g. the pitchforks at h_crit^(m) = (2m-1) pi/(2 sqrt 2) for
phi = 90 deg, p = 0); --switch also follows the branches that bifurcate there.

A scene with obstacles, or a rod with a thickness (contact_gap > 0, always on a physical scene),
is continued until the rod first touches an obstacle or itself (located as an event; the branch's
status `touch`). From there the rest of the window is followed by a loading path of contact
equilibria (as `path` does: touch-down and lift-off located as events, snaps located at the
contact branch's fold), warm-started from the touching state: the JSON's `contact_path` (the
contract of `path --json`), the CSV's last branch (column with_contact = 1), the figure's red
line. That path follows stable states only, in the direction the branch was moving; it does not
turn round folds. Exit 0 when it reaches the window's end, 3 when it fails (the message says
where). A start that already touches is followed with contact over the whole window from its
contact equilibrium (from rest; the branch is that one state). --stop-at-touch stops at the touch
instead, and refuses a start in contact (exit 3).

Units: dimensionless (THEORY §5): lengths in rod lengths l, energies in B0/l, loads in B0/l^2,
angles in rad (the --phi-deg and --alpha-deg flags take degrees). --from/--to accept units for
parameters with a physical meaning: angles ('30 deg') always; for a physical scene fields ('2 mT',
'5 kA/m'; h = H dh/dH) and loads ('1 mN'). A physical scene's folds and branch points also carry
field_mT and field_A_per_m (or value_N, ...) beside their value.

A physical scene (`type: physical`) also speaks its own units: lengths in the unit rod.length is
written in, fields as mu0 H in mT, loads in N, energies in J — text lines, the JSON's
`physical` keys beside the dimensionless ones, extra CSV columns (value_<unit>, tip_x_<unit>, tip_y_<unit>, energy_J) and
the figure's axes.

With CONFIG, its `study:` section (type: continuation; keys param, from, to, ds, ds_max,
max_points, switch, straight and the scene values h, phi_deg, p, alpha_deg) and then the flags
apply.
"""
from __future__ import annotations

import argparse
import sys

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                                        check_parameter_angle, finite_float, stdout_to_stderr)
from actuator_design.cli.equilibria import add_output_args, add_scene_args, build_scene
from actuator_design.cli.common import print_written, write_out
from actuator_design.config.studies.parameters import PARAM_NAMES, ContinuationStudy

__all__ = ["HELP", "add_args", "run", "ContinuationStudy", "PARAM_NAMES"]

HELP = "continue an equilibrium branch in one parameter (folds, branch points, stability)"

def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``continue``."""
    add_scene_args(parser)
    c = parser.add_argument_group("continuation")
    c.add_argument("--param", choices=PARAM_NAMES, help="the continuation parameter")
    c.add_argument("--from", dest="start", metavar="A", help="start value (units allowed, e.g. '2 mT')")
    c.add_argument("--to", dest="stop", metavar="B", help="end value (units allowed, e.g. '6 mT')")
    c.add_argument("--ds", type=finite_float, help="initial arclength step (> 0; default 0.05)")
    c.add_argument("--ds-max", type=finite_float, help="largest arclength step (> 0; default 0.5, or 1/400 of a wider window)")
    c.add_argument("--max-points", type=int, help="at most this many points per branch (default 2000)")
    c.add_argument("--switch", action="store_true", default=None,
                   help="also follow the branches bifurcating at branch points")
    c.add_argument("--straight", action="store_true", default=None,
                   help="start from the straight rod (Newton, no saddle escape) instead of the state reached from rest")
    c.add_argument("--stop-at-touch", action="store_true", default=None,
                   help="stop where the rod first touches an obstacle or itself (default: follow on with contact)")
    add_output_args(parser, "branch.json, branch.csv and branch.png")


def _csv(res, units=None) -> str:
    """``branch.csv``: one row per point; a physical scene adds the value in its unit (when the
    parameter has one) and the state in the user's units."""
    from actuator_design.io.unit_results import (parameter_conversion, state_columns, state_csv_note,
                                                 state_values, unit_suffix)
    from actuator_design.io.user_units import parameter_physical
    from actuator_design.physics.parameters import parameter

    extra, note = [], ""
    p = parameter(res.param)
    unit = parameter_conversion(p, units)[0] if units is not None else None
    if units is not None:
        extra = ([f"value_{unit_suffix(unit)}"] if unit is not None else []) + state_columns(units)
        note = ("; " + (f"value_{unit_suffix(unit)} in {unit}" + (" (mu0 H)" if unit == "mT" else "") + "; "
                        if unit is not None else "") + state_csv_note(units))
    lines = [f"# branch in {res.param}; tip x, y in rod lengths l, angle in rad, energy in B0/l" + note,
             "branch,value,tip_angle,tip_x,tip_y,energy,morse_index,stable"
             + "".join("," + c for c in extra) + ",with_contact"]
    if res.contact_path is not None:
        lines[0] += ("; the last branch (with_contact = 1) is the loading path with contact on from the "
                     "first touch")
    for k, br in enumerate([res.branch] + res.secondary):
        for i in range(len(br)):
            # float(): numpy scalars' repr is "np.float64(…)" since numpy 2
            row = (f"{k},{float(br.lam[i])!r},{float(br.tips[i, 0])!r},{float(br.tips[i, 1])!r},"
                   f"{float(br.tips[i, 2])!r},{float(br.energy[i])!r},{int(br.morse_index[i])},"
                   f"{int(br.morse_index[i] == 0)}")
            if units is not None:
                tip = {"x": float(br.tips[i, 1]), "y": float(br.tips[i, 2])}
                vals = ([parameter_physical(p, float(br.lam[i]), units)] if unit is not None else [])
                vals += state_values(tip, float(br.energy[i]), float(br.gamma[i]), units)
                row += "".join("," + repr(float(v)) for v in vals)
            lines.append(row + ",0")
    if res.contact_path is not None:
        k = 1 + len(res.secondary)
        for q, state in zip(res.contact_path.points, res.contact_path.point_states):
            row = (f"{k},{q.param!r},{q.tip['angle']!r},{q.tip['x']!r},{q.tip['y']!r},{q.energy!r},"
                   f"{q.morse_index},{int(q.stable)}")
            if units is not None:
                vals = ([parameter_physical(p, q.param, units)] if unit is not None else [])
                vals += state_values(q.tip, q.energy, state.gamma, units)
                row += "".join("," + repr(float(v)) for v in vals)
            lines.append(row + ",1")
    return "\n".join(lines) + "\n"


def add_units(payload: dict, res, units) -> None:
    """A physical scene's units in ``continue``'s JSON, in place: the top-level ``physical`` and,
    beside every point's, fold's and branch point's value, its value in the parameter's unit and
    ``physical`` {tip in the length unit, energy_J} (secondary branches too)."""
    if units is None:
        return
    from actuator_design.io.unit_results import add_point_units, command_physical

    payload["physical"] = command_physical(res.scene, units, [res.param])
    add_point_units(payload["branch"] + payload["folds"] + payload["branch_points"], res.param, units)
    if payload.get("contact_path"):  # the path's items carry their value as "param"
        from actuator_design.io.unit_results import point_physical
        from actuator_design.io.user_units import physical_value_keys
        from actuator_design.physics.parameters import parameter

        cp = payload["contact_path"]
        for item in cp["points"] + cp["contact_events"] + cp["jumps"]:
            item.update(physical_value_keys(parameter(res.param), item["param"], units))
        for q in cp["points"]:
            q["physical"] = point_physical(q["tip"], q["energy"], units)
    for sec in payload.get("secondary_branches", []):
        add_point_units(sec["points"] + sec["folds"] + sec["branch_points"], res.param, units)


def _pick(flag, study, key, default=None):
    if flag is not None:
        return flag
    if study is not None:
        return getattr(study, key)
    return default


def run(args: argparse.Namespace) -> int:
    """Run ``continue``."""
    check_out_dir(args.out)
    scene, options, raw, study = build_scene(args, ContinuationStudy, "continuation")
    param = _pick(args.param, study, "param")
    if param is None:
        raise InputError("--param: required (or give it in the config's study section)")
    from actuator_design.io.user_units import parameter_from_text, user_units
    from actuator_design.physics.parameters import parameter

    units = user_units(scene, raw)
    with bad_input():
        start = (parameter_from_text(args.start, parameter(param), units, "--from") if args.start is not None
                 else _pick(None, study, "start"))
        stop = (parameter_from_text(args.stop, parameter(param), units, "--to") if args.stop is not None
                else _pick(None, study, "to"))
    for flag, v, given in (("--from", start, args.start), ("--to", stop, args.stop)):
        if v is None:
            raise InputError(f"{flag}: required (or give it in the config's study section)")
        if given is None:  # from the study section, in the parameter's unit
            check_parameter_angle(param, v, f"study.{flag[2:]}")
    if start == stop:  # echoed as given ('30 deg'), not converted
        shown = args.start if args.start is not None else f"{start:g}"
        raise InputError(f"--from and --to must differ, got {shown} twice")
    ds = _pick(args.ds, study, "ds", 0.05)
    ds_max = _pick(args.ds_max, study, "ds_max", None)
    max_points = _pick(args.max_points, study, "max_points", 2000)
    if not ds > 0 or not (ds_max is None or ds_max > 0):
        raise InputError(f"--ds, --ds-max: must be > 0, got {ds:g}, {ds_max!r}")
    if max_points < 2:
        raise InputError(f"--max-points: must be >= 2, got {max_points}")
    switch = bool(_pick(args.switch, study, "switch", False))
    straight = bool(_pick(args.straight, study, "straight", False))
    stop_at_touch = bool(_pick(args.stop_at_touch, study, "stop_at_touch", False))

    import numpy as np

    from actuator_design.continuation.branch_accuracy import branch_options
    from actuator_design.continuation.follow import continue_branch
    from actuator_design.io.save import dumps_json
    from actuator_design.physics.parameters import set_value as set_param

    with bad_input(f"--param {param}: "):
        set_param(scene, param, start)
        set_param(scene, param, stop)
    with stdout_to_stderr(args.json):
        initial = None
        if straight:  # the straight rod θ ≡ θ0 as the Newton start
            from actuator_design.equilibrium.solver import get_solver
            theta0 = start if param == "theta0" else scene.theta0
            options = branch_options(scene, param, (start, stop), options)  # the mesh the branch would have
            n = get_solver(set_param(scene, param, start), options).transcription.nodes.size
            initial = np.full(n, theta0)
        try:
            res = continue_branch(scene, param, start, stop, options=options, initial=initial, ds=ds,
                                  ds_max=ds_max, max_points=max_points, switch=switch,
                                  through_contact=not stop_at_touch)
        except RuntimeError as err:
            print(f"actuator-design: error: {err}", file=sys.stderr)
            return EXIT_NOT_CONVERGED
        except ValueError as err:
            raise InputError(str(err)) from err
    payload = res.to_dict()
    add_units(payload, res, units)
    written = None
    if args.out is not None:
        from actuator_design.viz.landscape import plot_branches
        from actuator_design.viz.style import png_bytes
        with stdout_to_stderr(args.json):
            cp = res.contact_path
            ax = plot_branches([res.branch] + res.secondary, title=f"continuation in {param}")
            if cp is not None:  # the contact states, a line of their own
                ax.plot([q.param for q in cp.points], [q.tip["angle"] for q in cp.points], color="C3", lw=1.8,
                        label="with contact (loading path from the touch)")
                ax.legend(fontsize="small")
            from actuator_design.viz.units import parameter_axis  # h in mT, loads in N, ...
            parameter_axis(ax, parameter(param), units, param, "x",
                           data_max=max([float(np.max(b.lam)) for b in [res.branch] + res.secondary]
                                        + ([q.param for q in cp.points] if cp is not None else [])))
            files = {"branch.json": dumps_json({**payload, "config": raw}, indent=1) + "\n",
                     "branch.csv": _csv(res, units), "branch.png": png_bytes(ax, dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        br = res.branch
        from actuator_design.io.unit_results import value_text

        def mT(v):  # the value in the parameter's unit: " (mu0 H = 25 mT)", " (p = 1e-3 N)"
            text = value_text(param, v, units) if units is not None else None
            return f" ({text})" if text else ""
        print(f"branch in {param}: {len(br)} points from {br.lam[0]:.6g}{mT(br.lam[0])} to "
              f"{br.lam[-1]:.6g}{mT(br.lam[-1])} ({br.status}: {br.message}); {br.stats['time_s']:.3f} s")
        from actuator_design.io.display import critical_value_note
        for cp in br.folds + br.branch_points:
            print(f"  {cp.kind.replace('_', ' ')} at {param} = {cp.value:.12g}{mT(cp.value)}, tip angle "
                  f"{cp.tip['angle']:+.8f} rad (Morse index {cp.morse_before} -> {cp.morse_after}"
                  f"{critical_value_note(cp.value, cp.value_error, cp.located)})")
        for s in res.secondary:
            print(f"  secondary branch from {s.origin}: {len(s)} points to {param} = {s.lam[-1]:.6g}"
                  f"{mT(s.lam[-1])}")
        for line in _contact_lines(res, param, mT, units):
            print(line)
        for note in res.notes:
            print(f"  note        : {note}")
        if units is not None:
            from actuator_design.io.unit_results import physical_header, scene_text, state_text, units_line
            k = len(br) - 1
            print(f"  {'touch state' if res.contact_path is not None else 'end state  '} : {state_text({'x': br.tips[k, 1], 'y': br.tips[k, 2]}, br.energy[k], units, br.gamma[k])}")
            given = scene_text(res.scene, units)
            print(f"  user units  : {units_line(units)}" + (f"; start scene: {given}" if given else ""))
            for note in physical_header(units, [param])["notes"]:
                print(f"  note        : {note}")
    if written is not None:
        print_written(written, args.json)
    if not res.complete:
        print(f"actuator-design: warning: the continuation stopped early: {res.branch.message}",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if not res.accurate:
        print(f"actuator-design: warning: the branch misses its accuracy: {res.accuracy}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _contact_lines(res, param: str, value_text, units) -> list:
    """The text of the loading path with contact on from the first touch: its events, snaps and
    end (``value_text(v)`` the parameter value in the user's unit, " (...)" or "")."""
    cp = res.contact_path
    if cp is None:
        return []
    from actuator_design.io.display import number

    u, length = ("l", float) if units is None else (units.length_unit, units.length)
    noise = length(1e-12)
    lines = [f"  with contact: {len(cp.points)} states from {param} = {cp.points[0].param:.10g}"
             f"{value_text(cp.points[0].param)} to {cp.points[-1].param:.10g}{value_text(cp.points[-1].param)} "
             f"({'converged' if cp.success else 'FAILED'}: {cp.message})"]
    for e in cp.contact_events:
        on = "on" if e["kind"] == "touch-down" else "from"
        at = "" if e["s"] is None else f" at s = {number(length(e['s']), '.6g', noise=length(1e-8))} {u}"
        lines.append(f"    {e['kind']} {on} the {e['obstacle_text']} at {param} = {e['param']:.10g}"
                     f"{value_text(e['param'])}{at}" + ("" if e["located"] else " (at the step; not located)"))
    for j in cp.jumps:
        lines.append(f"    snap ({j.kind}) at {param} = {j.param:.10g}{value_text(j.param)}: tip angle "
                     f"{j.from_state.tip['angle']:+.8f} -> {j.to_state.tip['angle']:+.8f} rad")
    end = cp.points[-1]
    lines.append(f"    end: tip ({number(length(end.tip['x']), '.6g', noise)}, {number(length(end.tip['y']), '.6g', noise)})"
                 f" {u}, angle {number(end.tip['angle'], '.8f', 1e-12)} rad, "
                 f"{'stable' if end.stable else f'Morse index {end.morse_index}'}")
    return lines
