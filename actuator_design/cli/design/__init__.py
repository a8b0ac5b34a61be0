"""Find the field (and, if needed, the fibre layout or tip load) that puts the tip at a target.

Without CONFIG the scene is THEORY §5's dimensionless cantilever: uniform field, vertical tip load
p (zero unless designed), fibre layout alpha(s), clamp angle 0, no weight. The design is always
verified independently: a fresh forward solve and a quasi-static loading path from zero field that
must reach the designed state without a snap, ending stable.

Targets are in rod lengths l (clamp at the origin, rod initially along +x); with --target-units
mm or m (physical scenes only) in those units. The optional third value is the tip angle in degrees,
taken modulo 360 (reported in [-180, 180]). The field acts on its axis: phi and phi + 180 deg are
one field, and the text output says so where it prints one of them.

A physical scene (`type: physical`) also speaks the user's units: target and tip in the length unit
of the YAML, the field in mT (mu0 H) and A/m, every schedule step with field_A_per_m, field_mT and
angle_deg, and with --rate 5mT/s and/or --rotation-rate 30deg/s the time of each step (time_s);
with rod.density (and rod.damping_ratio, default 0.05) each timed step is compared with the rod's
relaxation time (relaxation_time_s, quasi_static: a step faster than it leaves the rod lagging).

Every design must hold over the lab's tolerance box (--tolerance, default field ±5 %, angle ±2 deg):
the tool makes the target exact at the nominal field and minimises the worst-case tip error over
the box, then follows the design's branch over the box and to the nearest snap and reports both.

With obstacles in the scene (one pose, --target-tip), the design keeps the whole rod clear of them
(its centre line half the thickness, plus --clearance, away) at the design and over the tolerance box, and is verified
by a loading path from zero field that keeps clear of them too (or, once, through touch-down and
lift-off): configs/contact_channel_design.yaml.
With obstacles in the scene, --target-force F designs instead the field magnitude at which the rod,
loaded from rest, presses an obstacle (--obstacle K) with force F (N on a physical scene), verified by
a forward solve from rest, with the force's range over the tolerance box.
Exit codes: 0 verified design that holds over the tolerance box, 2 bad input, 3 reachable but not
a verified success (no snap-free path, not stable, or the verified tip or stiffness outside the
tolerance: the note says which), 4 unreachable target (the nearest reachable pose is reported) or
no design that holds over the whole tolerance box (the most robust one found is reported, with the
largest box it holds).
"""
from __future__ import annotations

import argparse
import dataclasses
import math

from actuator_design.cli.common import (EXIT_NOT_VERIFIED, EXIT_OK, EXIT_UNREACHABLE, InputError,
                                        add_rate_args, bad_input, check_out_dir, finite_float, load_config,
                                        parse_rates, repeatable, stdout_to_stderr, table_csv_text)
from actuator_design.io.display import degrees, number
from actuator_design.physics.parameters import designable, parameters
from actuator_design.cli.design.units import (add_schedule_units, positive_target, profile_terms_help,
                                              quasi_static_line, refuse_unknown_keys, unit_labels, vary_help)
from actuator_design.cli.common import print_written, write_out
from actuator_design.cli.scene_args import add_set_arg, apply_set_flags, check_flags

__all__ = ["HELP", "add_args", "run"]

HELP = "inverse design: the field (and fibres, load) that puts the tip at a target, verified"

_VARIABLES = tuple(designable())  # the lens entries flagged designable: h, phi, alpha, p, magnetization


def add_args(parser: argparse.ArgumentParser) -> None:
    from actuator_design.cli.design.hardware import add_hardware_args
    from actuator_design.inverse.design import DesignSettings
    from actuator_design.robust.tolerances import axis_examples

    d = DesignSettings()
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene (and optional `study: {type: design, target: [x, y], ...}`); "
                             "omit for the default scene")
    parser.add_argument("--target-tip", metavar="X,Y[,ANGLE_DEG]", action=repeatable(";"),
                        help="target tip position (rod lengths unless --target-units) and optional "
                             "tip angle in degrees; several poses separated by ';' (one actuator: one "
                             "fibre layout, one field per pose), e.g. '0.3,0.5;0.6,0.2', or the flag once per pose")
    parser.add_argument("--target-shape", metavar="FILE.csv",
                        help="a target shape instead of a tip: a CSV with header s,x,y (s in (0, 1], x, y in "
                             "rod lengths unless --target-units), fitted in least squares")
    parser.add_argument("--target-units", choices=("rod", "mm", "m"), default=None,
                        help="units of X,Y (default rod lengths; mm/m need a physical scene)")
    parser.add_argument("--target-stiffness", metavar="K",
                        help="target vertical tip stiffness dp/dv1: a number in units of B0/l^3, or a "
                             "quantity such as '1.2 N/m' for a physical scene; alone or with --target-tip (on a scene "
                             "of coils: the least-power currents; with a magnet on a stage: its pose)")
    parser.add_argument("--target-force", metavar="F",
                        help="with obstacles in the scene: the field magnitude at which the rod, loaded from "
                             "rest, presses an obstacle with this force (a gripper): a number in B0/l^2, or a "
                             "quantity such as '50 uN' for a physical scene; the field angle is the scene's")
    parser.add_argument("--clearance", metavar="D",
                        help="with obstacles and --target-tip: the distance the designed rod keeps from every "
                             "obstacle beyond half its thickness, at the design and over the tolerance box (a "
                             "number in rod lengths, or a length such as '0.2 mm' on a physical scene; default 0)")
    parser.add_argument("--obstacle", type=int, metavar="K",
                        help="with --target-force: which obstacle of scene.obstacles (index, default 0)")
    parser.add_argument("--vary", metavar="LIST", action=repeatable(","), help=vary_help())
    g = parser.add_argument_group("bounds and tolerances (dimensionless, THEORY §5)")
    g.add_argument("--h-max", type=finite_float, help=f"largest field group h (default {d.h_max:g})")
    g.add_argument("--p-max", type=finite_float, help=f"largest |p| when p is designed (default {d.p_max:g})")
    g.add_argument("--alpha-max-deg", type=finite_float,
                   help=f"largest |fibre angle|, degrees (default {math.degrees(d.alpha_max):g})")
    g.add_argument("--alpha-terms", type=int, help=profile_terms_help(d.alpha_terms))
    g.add_argument("--margin", type=finite_float,
                   help=f"required stability margin: smallest eigenvalue >= margin (default {d.margin:g})")
    g.add_argument("--tolerance", metavar="SPEC", action=repeatable(","),
                   help="the lab's tolerance box the design must hold over, e.g. 'field=5%%,angle=2deg' "
                        f"(the default); also {axis_examples().replace('%', '%%')} (the flag repeated adds to "
                        "the list); 'none' for the nominal design only")
    g.add_argument("--time-limit", type=finite_float, metavar="S",
                   help=f"wall-clock budget of the search in seconds (default {d.time_limit:g}); once spent, "
                        "no further starting design is optimised")
    s = parser.add_argument_group("solver")
    s.add_argument("--elements", type=int, metavar="N", help="elements of the forward transcription")
    s.add_argument("--degree", type=int, metavar="D", help="degree per element")
    s.add_argument("--no-verify", action="store_true",
                   help="skip the independent verification (the result is then never 'success')")
    add_rate_args(parser), add_hardware_args(parser), add_set_arg(parser)
    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print exactly one JSON object (the design contract)")
    o.add_argument("--out", metavar="DIR", help="write design.json, schedule.csv, shape.csv and design.png")


def _parse_target(text: str, units: str, scene):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"--target-tip: expected X,Y or X,Y,ANGLE_DEG numbers, got {text!r}")
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise InputError(f"--target-tip: expected 2 or 3 finite numbers X,Y[,ANGLE_DEG], got {text!r}")
    if units in ("mm", "m"):
        if scene.scales is None:
            raise InputError(f"--target-units {units}: needs a physical scene (this one is dimensionless)")
        factor = (1e-3 if units == "mm" else 1.0) / scene.scales.length
        values[0] *= factor
        values[1] *= factor
    if len(values) == 3:  # an angle modulo 360 deg (remainder is exact for any finite magnitude)
        values[2] = math.radians(math.remainder(values[2], 360.0))
    return tuple(values)


def _inputs(args):
    from actuator_design.inverse.design import DesignSettings
    from actuator_design.equilibrium.options import SolverOptions
    from actuator_design.model.scene import default_scene
    from actuator_design.config.studies.commands import DESIGN_KEYS

    study = {}
    if args.config is None:
        scene, options, raw = default_scene(h=0.0), SolverOptions(), None
    else:
        scene, options, raw = load_config(args.config)
        study = dict((raw or {}).get("study") or {})
        if study and study.get("type") != "design":
            raise InputError(f"study.type: expected 'design' for this command, got {study.get('type')!r}")
    scene = apply_set_flags(scene, args)
    study.pop("type", None)
    allowed = {*DESIGN_KEYS, *[f.name for f in dataclasses.fields(DesignSettings)]}
    refuse_unknown_keys(study, sorted(allowed))
    target_text = args.target_tip
    if target_text is None and "target" in study:
        target_text = ",".join(str(v) for v in study["target"])
    if target_text is None and "targets" in study:  # several poses: [[x, y], [x, y, angle], ...]
        if not isinstance(study["targets"], list) or not all(isinstance(t, list) for t in study["targets"]):
            raise InputError("study.targets: expected a list of [x, y] or [x, y, angle_deg] poses")
        target_text = ";".join(",".join(str(v) for v in t) for t in study["targets"])
    stiffness = _parse_stiffness(args.target_stiffness if args.target_stiffness is not None
                                 else study.get("stiffness"), scene)
    from actuator_design.cli.design.force import parse_force
    force = parse_force(args.target_force if args.target_force is not None else study.get("force"), scene)
    if force is not None and (target_text is not None or stiffness is not None
                              or getattr(args, "target_shape", None) is not None):
        raise InputError("--target-force: give it alone (not with --target-tip, --target-stiffness or --target-shape)")
    if force is None and getattr(args, "target_shape", None) is not None:
        if target_text is not None or stiffness is not None:
            raise InputError("--target-shape: give either a shape or --target-tip/--target-stiffness, not both")
        target_text = None
    elif force is None and target_text is None and stiffness is None:
        raise InputError("--target-tip: required unless --target-stiffness is given (or `study: {type: "
                         "design, target: [x, y]}` in CONFIG)")
    units = args.target_units or study.get("target_units", "rod")
    if target_text is not None and ";" in target_text:  # several poses, one actuator
        if stiffness is not None:
            raise InputError("--target-stiffness: not available with several poses (--target-tip X1,Y1;X2,Y2)")
        target = [_parse_target(t.strip(), units, scene) for t in target_text.split(";") if t.strip()]
    else:
        target = None if target_text is None else _parse_target(target_text, units, scene)
    vary_text = args.vary if args.vary is not None else study.get("vary")
    vary = None
    if vary_text is not None:
        vary = [v.strip() for v in (vary_text.split(",") if isinstance(vary_text, str) else vary_text)]
        bad = [v for v in vary if v not in _VARIABLES]
        if bad or not vary:
            raise InputError(f"--vary: unknown design variable {bad[0] if bad else ''!r} "
                             f"(allowed: {', '.join(_VARIABLES)})")
    settings_kw = {k: study[k] for k in study if k not in DESIGN_KEYS}
    for flag, key, conv in (("h_max", "h_max", float), ("p_max", "p_max", float),
                            ("alpha_max_deg", "alpha_max", math.radians), ("alpha_terms", "alpha_terms", int),
                            ("margin", "margin", float), ("time_limit", "time_limit", float)):
        if getattr(args, flag) is not None:
            settings_kw[key] = conv(getattr(args, flag))
    if getattr(args, "clearance", None) is not None:
        settings_kw["clearance"] = positive_target(args.clearance, scene, "--clearance", "length", "length",
                                                   "rod lengths")
    with bad_input("design settings: "):
        from actuator_design.robust.tolerances import parse_tolerances
        if args.tolerance is not None:
            settings_kw["tolerances"] = parse_tolerances(args.tolerance)
        elif "tolerances" in settings_kw:
            settings_kw["tolerances"] = parse_tolerances(settings_kw["tolerances"])
        settings = DesignSettings(**settings_kw)  # validates itself: one line naming the setting
        changes = {k: getattr(args, k) for k in ("elements", "degree") if getattr(args, k) is not None}
        options = dataclasses.replace(options, **changes)
    if changes or args.set_values:  # the flags changed the scene or the mesh after CONFIG was checked
        check_flags(scene, options)
    return scene, options, raw, target, vary, settings, stiffness, force


def _rates(args, raw):
    """(field rate in A/m/s, rotation rate in rad/s), each None when not given: flags, else study."""
    study = (raw or {}).get("study") or {}
    return parse_rates(args.rate if args.rate is not None else study.get("rate"),
                       args.rotation_rate if args.rotation_rate is not None else study.get("rotation_rate"))


def check_rates(rates, units) -> None:
    """Up front, before any solve: a design schedule ramps the field from zero and rotates it, so
    timing it needs both rates (a change without its rate is never taken as instantaneous), and a
    field rate needs a physical scene.

    Raises
    ------
    InputError
        One line naming the flag that is missing or cannot be used.
    """
    field_rate, rotation_rate = rates
    if field_rate is not None and not (units is not None and units.has_field):
        raise InputError("--rate: a field rate needs a physical scene (`type: physical` CONFIG with a "
                         "magnetic group)")
    if field_rate is not None and rotation_rate is None:
        raise InputError("--rotation-rate: a design schedule rotates the field as well as ramping it; give "
                         "--rotation-rate (e.g. 30deg/s) with --rate (a rotation is never taken as "
                         "instantaneous)")
    if rotation_rate is not None and field_rate is None:
        raise InputError("--rate: a design schedule ramps the field from zero as well as rotating it; give "
                         "--rate (e.g. 5mT/s, a physical scene) with --rotation-rate")


def _parse_stiffness(value, scene):
    """A dimensionless stiffness (units of B0/l^3) or a quantity in N/m (physical scenes)."""
    return positive_target(value, scene, "--target-stiffness", "force_per_length", "stiffness", "B0/l^3")


def _summary(res, units=None, table=None, qs=None) -> str:
    d = res.design
    lines = [
        "actuator-design: inverse design",
        (f"  target      : x = {number(res.target[0])}, y = {number(res.target[1])}"
         + (f", angle = {degrees(res.target[2], '.4g')} deg" if len(res.target) > 2 else "") + "  [rod lengths]"
         if res.target else "  target      : (no tip pose)")
        + (f"; stiffness {res.stiffness_target:.8g} [B0/l^3]" if res.stiffness_target is not None else ""),
        f"  variables   : {', '.join(res.vary)}",
        f"  design      : h = {d.get('h', float('nan')):.8g}, phi = {_phi_text(res)}, "
        f"p = {number(d.get('p', float('nan')))}"
        # the other groups at the design field (a remanent rod's h_r, THEORY §9)
        + "".join(f", {k} = {v:.8g}" for k, v in d.items() if k not in ("h", "phi", "p") and isinstance(v, float)),
    ]
    for p in designable().values():  # the designed profiles: α(s), a remanent β(s)
        if p.per_point and p.name in res.vary and p.name in d:
            v = d[p.name]["value"]
            lines.append(f"  {p.profile_label:<12}: {p.slot}(s) from {degrees(v[0], '.3g')} deg (clamp) to "
                         f"{degrees(v[-1], '.3g')} deg (tip), Legendre coefficients "
                         f"{', '.join(number(c, '.4g') for c in d[p.name]['legendre_coefficients'])} rad")
    phys = res.to_dict().get("physical")
    if phys:
        lines.append(f"  field       : {phys['field_A_per_m']:.6g} A/m ({phys['field_mT']:.4g} mT as mu0 H)")
    lines += _physical_lines(res, units, table)
    if table and "time_s" in table[-1]:
        lines.append(quasi_static_line(qs, res.scene.scales))
    if res.achieved:
        lines.append(f"  achieved    : x = {number(res.achieved['x'], '.10f')}, y = {number(res.achieved['y'], '.10f')}, "
                     f"angle = {degrees(res.achieved['angle'])} deg; error {res.error:.3e}"
                     + (f" rod lengths ({units.length(res.error):.4g} {units.length_unit})"
                        if units is not None and res.target else ""))
    if res.stiffness_target is not None and res.achieved_stiffness is not None:
        lines.append(f"  stiffness   : achieved {res.achieved_stiffness:.10g} [B0/l^3] (central differences of "
                     f"independent forward solves)")
    stability = (f"stable {res.stable} (margin {res.stability_margin:.4g})" if not math.isnan(res.stability_margin)
                 else "stability not established (no verified state)")
    lines.append(f"  verdict     : reachable {res.reachable}, verified {res.verified}, {stability}, "
                 f"snap-free {res.snap_free}")
    if res.robustness is not None:
        lines.append(f"  robustness  : {res.robustness.sentence()}")
    elif res.tolerances is None:
        lines.append("  robustness  : not evaluated (no tolerance box: --tolerance none)")
    else:
        why = ("the target is not reached, so there is no design to hold" if not res.reachable
               else "see note")
        lines.append(f"  robustness  : NOT checked over the box ({res.tolerances.describe()}): {why}")
    for c in res.clearance or ():
        if units is None:
            lines.append(f"  clearance   : {c['min_distance']:.4g} rod lengths from the {c['obstacle_text']} "
                         f"(nearest at s = {c['s']:.3g})")
            continue
        lu = units.length_unit
        text = res.scene.obstacles[c["obstacle"]].describe(units.length(1.0), lu)
        lines.append(f"  clearance   : {units.length(c['min_distance']):.4g} {lu} from the {text} "
                     f"(nearest at s = {units.length(c['s']):.4g} {lu})")
    if res.schedule:
        last = res.schedule[-1]
        lines.append(f"  schedule    : {len(res.schedule)} steps from h = 0 to h = {last['h']:.6g}"
                     + "".join(f", {p.name} = {last[p.name]:.6g}" for p in parameters().values()
                               if p.remanent_field and p.name in last)
                     + f" at phi = {degrees(last['phi'])} deg")
    lines.append(f"  optima      : {len(res.optima)} distinct local optima (see --json 'optima')")
    lines.append(f"  time        : {res.timings.get('total', float('nan')):.2f} s")
    if res.message:
        lines.append(f"  note        : {res.message}")
    lines.append("  RESULT      : " + _verdict(res))
    return "\n".join(lines)


def _verdict(res) -> str:
    """The RESULT line: what was established, and nothing that was not computed."""
    from actuator_design.inverse.settings import status_of

    status = status_of(res)
    if status == "success":
        return ("SUCCESS — a verified, stable, snap-free design that holds over the tolerance box"
                if res.robustness is not None else
                "SUCCESS — a verified, stable, snap-free design (no tolerance box asked for)")
    return {"inaccurate": "INACCURATE — the mesh does not resolve the design's state (see note)",
            "failed": "FAILED — a design stage stopped on a numerical error (see note)",
            "unreachable": "unreachable target",
            "not_robust": "NO design holds over the whole tolerance box (the most robust found is reported)",
            "not_accepted": "verified, but NOT a success (see note)"}.get(status, "NOT verified")


def _physical_lines(res, units, table) -> list:
    """The target and tip in the scene's length unit, the stiffness in N/m and the schedule in mT
    and seconds (physical scenes and timed schedules only)."""
    lines = []
    if units is not None:
        u = units.length_unit
        parts = []
        if res.target:
            parts.append(f"target ({units.length(res.target[0]):.6g}, {units.length(res.target[1]):.6g})")
        if res.achieved:
            parts.append(f"achieved ({units.length(res.achieved['x']):.6g}, "
                         f"{units.length(res.achieved['y']):.6g})")
        if parts:
            lines.append(f"  tip [{u}]{' ' * max(0, 6 - len(u))}: {', '.join(parts)}")
        if res.stiffness_target is not None:
            k = res.achieved_stiffness
            lines.append(f"  stiffness   : target {res.stiffness_target * units.stiffness_scale:.6g} N/m"
                         + (f", achieved {k * units.stiffness_scale:.6g} N/m" if k is not None else ""))
    if table:
        last = table[-1]
        text = f"  lab field   : {len(table)} steps"
        if "field_mT" in last:
            text += f" to {last['field_mT']:.6g} mT ({last['field_A_per_m']:.6g} A/m) at {last['angle_deg']:.6g} deg"
        if "time_s" in last:
            text += f", {last['time_s']:.4g} s at the given rates"
        if text.endswith("steps"):
            return lines
        lines.append(text)
    return lines


def _physical_payload(res, units, table) -> dict:
    """``res.to_dict()`` with the user's units added (never renamed): ``physical.length_unit``,
    ``physical.target``/``tip`` in that unit, and the schedule's steps with ``field_A_per_m``,
    ``field_mT``, ``angle_deg`` (physical scenes) and ``time_s`` (with a rate)."""
    payload = res.to_dict()
    if units is not None:
        phys = payload.setdefault("physical", {})
        phys["length_unit"] = units.length_unit
        phys["units"] = unit_labels(units)
        if res.target:
            phys["target"] = {"x": units.length(res.target[0]), "y": units.length(res.target[1])}
        if res.achieved:
            phys["tip"] = {"x": units.length(res.achieved["x"]), "y": units.length(res.achieved["y"])}
        if res.stiffness_target is not None:
            phys["target_stiffness_N_per_m"] = res.stiffness_target * units.stiffness_scale
        if res.clearance is not None:
            lu = units.length_unit
            phys["clearance"] = [{"obstacle": c["obstacle"], f"min_distance_{lu}": units.length(c["min_distance"]),
                                  f"s_{lu}": units.length(c["s"]), "obstacle_text":
                                  res.scene.obstacles[c["obstacle"]].describe(units.length(1.0), lu)}
                                 for c in res.clearance]
    add_schedule_units(payload, table)
    return payload


def _phi_text(res) -> str:
    """The field angle as the field is left at the end of the schedule, and, when the design's
    representative in (-90, 90] deg differs, the word that they are one field axis."""
    phi = res.design.get("phi", float("nan"))
    end = res.schedule[-1]["phi"] if res.schedule else phi
    text = f"{degrees(end)} deg"
    if math.isfinite(end) and abs(end - phi) > 1e-9:
        text += f" (field axis, the same as {degrees(phi)} deg)"
    return text


def _output_files(res, raw, payload, table, units=None) -> dict:
    """design.json, schedule.csv, design.png and (with a converged state) shape.csv, in memory."""
    from actuator_design.schedules.schedule import schedule_table
    from actuator_design.io.save import dumps_json, scene_to_dict, shape_csv_text
    from actuator_design.viz.design import design_png

    payload = dict(payload)
    payload["scene"] = scene_to_dict(res.design_scene) if res.design_scene is not None else None
    payload["config"] = raw
    text = dumps_json(payload, indent=1) + "\n"
    rows = table if table is not None else schedule_table(res.schedule)
    state = res.path.final if res.path is not None else res.forward
    if state is not None and state.success and res.achieved and res.path is None:
        # shape.csv is the state the text reports, or absent: an unverified design reports the
        # design NLP's state, and the fresh forward solve may have landed on another equilibrium
        if max(abs(state.tip["x"] - res.achieved["x"]), abs(state.tip["y"] - res.achieved["y"])) > 1e-6:
            state = None
    files = {"design.json": text, "schedule.csv": table_csv_text(rows, _columns(rows)),
             "design.png": design_png(res, units=units, dpi=150)}
    if state is not None and state.success:
        files["shape.csv"] = shape_csv_text(state)
    return files


def _columns(rows) -> list:
    """The schedule table's columns (``SCHEDULE_COLUMNS`` in order, those present)."""
    from actuator_design.schedules.schedule import SCHEDULE_COLUMNS

    return [c for group in SCHEDULE_COLUMNS.values() for c in group if rows and c in rows[0]] or ["step", "h", "phi_rad"]


def run(args: argparse.Namespace) -> int:
    check_out_dir(args.out)
    scene, options, raw, target, vary, settings, stiffness, force = _inputs(args)
    if force is not None:
        from actuator_design.cli.design.force import run_force
        from actuator_design.io.user_units import user_units
        return run_force(args, scene, options, raw, force, settings, user_units(scene, raw))
    from actuator_design.cli.design.hardware import check_position_tolerance, hardware_design, hardware_shape
    check_position_tolerance(args, scene)
    if args.target_shape is not None and (rc := hardware_shape(args, scene, options, raw, vary, settings)) is not None:
        return rc
    if args.target_shape is not None:
        from actuator_design.cli.design.shape import run_shape
        return run_shape(args, scene, options, raw, vary, settings)
    if (rc := hardware_design(args, scene, options, raw, target, vary, settings, stiffness)) is not None:
        return rc
    from actuator_design.io.user_units import user_units

    rates = _rates(args, raw)
    units = user_units(scene, raw)
    check_rates(rates, units)
    if isinstance(target, list):
        from actuator_design.cli.design.poses import run_poses
        return run_poses(args, scene, options, raw, target, vary, settings, units, rates)
    from actuator_design.inverse.design import design, design_problem
    from actuator_design.schedules.schedule import schedule_table
    from actuator_design.io.save import dumps_json
    with bad_input():  # the request is checked up front: what fails later is the design's, not the input's
        design_problem(target, scene, vary, options, settings, stiffness, 0.0)
    if args.out is not None:  # the figure's modules load while the design waits for a forked search
        from actuator_design.forked import while_waiting
        from actuator_design.viz.style import preload_steps
        for step in preload_steps():
            while_waiting(step)
    with stdout_to_stderr(args.json):
        res = design(target, scene=scene, vary=vary, options=options, settings=settings,
                     verify=not args.no_verify, stiffness=stiffness)
    table, qs = None, None
    if res.schedule and (units is not None or rates != (None, None)):
        with bad_input():
            table = schedule_table(res.schedule, units, *rates)
        if res.path is not None:  # a timed schedule against the rod's relaxation time
            from actuator_design.schedules.dynamics import quasi_static
            qs = quasi_static(res.path.states, table, scene.scales)
    payload = _physical_payload(res, units, table)
    if table and "time_s" in table[0]:
        payload["quasi_static"] = qs
    written = None
    if args.out is not None:
        written = write_out(args.out, _output_files(res, raw, payload, table, units), args.json)
    print(dumps_json(payload) if args.json else _summary(res, units, table, qs))
    if written is not None:
        print_written(written, args.json)
    return exit_code(res)


def exit_code(res) -> int:
    """0 success; 3 inaccurate (the mesh does not resolve the design), failed (a stage stopped on a
    numerical error), not verified or not accepted; 4 unreachable or no design holding over the box."""
    from actuator_design.inverse.settings import status_of

    status = status_of(res)
    if status == "success":
        return EXIT_OK
    if status in ("unreachable", "not_robust"):
        return EXIT_UNREACHABLE
    return EXIT_NOT_VERIFIED
