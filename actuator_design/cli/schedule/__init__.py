"""Design a field schedule (magnitude h and angle phi over time) that moves the tip through waypoints.

Every state along the schedule is a stable quasi-static equilibrium reached continuously from the
previous one; the schedule starts from zero field and minimises field effort and rate of change.
It is verified by following the whole schedule quasi-statically (no snap, every state stable, each
waypoint reached). Waypoints are in rod lengths (clamp at the origin, rod initially along +x).

Outputs with --out DIR: schedule.json, schedule.csv (every schedule point), waypoints.csv (one row
per waypoint), schedule.png (the rod along the path) and schedule.gif (an animation).

Physical scenes (`type: physical` CONFIG) speak the user's units too: every schedule step carries
field_A_per_m, field_mT (mu0 H) and angle_deg, the text shows waypoints and tips in the length unit
of the YAML and the field in mT, and --rate 5mT/s / --rotation-rate 30deg/s add the time of each
step (the slower of the field change and the rotation governs).
On a scene whose field comes from coils (`field: {type: coils}`) the coils' currents are scheduled
instead, within each driver's --slew-rate (A/s) and current limit (:mod:`.currents`); on a
scene whose magnet has a travel, the magnet's pose within the stage's --stage-speed and --turn-rate
(:mod:`.poses`).
Exit codes: 0 verified schedule, 2 bad input, 3 no verified schedule (the message says why), 4 (coils, a magnet)
a waypoint no currents (pose) within the limits (travel) reach.
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math
import sys
from pathlib import Path

from actuator_design.cli.common import (EXIT_NOT_VERIFIED, EXIT_OK, InputError, add_rate_args, bad_input,
                                        check_out_dir, finite_float, load_config, parse_rates,
                                        repeatable, stdout_to_stderr, table_csv_text)
from actuator_design.cli.design.units import (path_line, positive_target, quasi_static_line,
                                              refuse_unknown_keys)
from actuator_design.cli.common import print_written, write_out
from actuator_design.cli.scene_args import add_set_arg, apply_set_flags, check_flags

__all__ = ["HELP", "add_args", "run"]

HELP = "a field schedule (h, phi) that moves the tip through waypoints, verified snap-free"


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene (and optional `study: {type: schedule, waypoints: [[x, y], ...]}`)")
    parser.add_argument("--waypoints", metavar="X1,Y1;X2,Y2;...", action=repeatable(";"),
                        help="tip waypoints in rod lengths, in visiting order")
    parser.add_argument("--path-csv", metavar="FILE",
                        help="a sampled tip path: CSV with columns x, y (rod lengths), one row per point")
    parser.add_argument("--rate-weight", type=finite_float, default=None,
                        help="weight of the field's rate of change against its magnitude (default 1)")
    parser.add_argument("--substeps", type=int, default=None,
                        help="schedule points between consecutive waypoints (default 8)")
    parser.add_argument("--path-tolerance", metavar="TOL",
                        help="the waypoints are a path: the replayed tip must stay within TOL of the polyline "
                             "through them at every step from the first waypoint on (rod lengths, or a length such "
                             "as '0.5mm' on a physical scene)")
    add_rate_args(parser)
    o = parser.add_argument_group("optimal control (the whole schedule as one NLP over time nodes)")
    o.add_argument("--optimal-control", choices=("time", "energy"), default=None,
                   help="minimise the schedule's duration, or its field effort (integral of h^2 dt, the coils' "
                        "energy up to their constant), under the rate limits: needs --rotation-rate and "
                        "--rate (physical scenes) or --h-rate (dimensionless ones); on a scene of coils, "
                        "the currents' duration or energy (J) under --slew-rate (default energy); reported "
                        "only when verified from rest and no worse than the greedy schedule")
    o.add_argument("--h-rate", metavar="RATE",
                   help="largest rate of change of the field group h, per second, e.g. '2/s' (dimensionless scenes)")
    o.add_argument("--nodes", type=int, default=None, help="time nodes of the optimal-control problem (default 40)")
    o.add_argument("--slew-rate", metavar="RATE",
                   help="a scene whose field comes from coils: each driver's largest |dI/dt|, e.g. '20A/s' (one for "
                        "all coils, or one per coil: '20A/s,10A/s'); the currents (A) are scheduled, with the least "
                        "energy (default) or, with --optimal-control time, in the least time")
    m = parser.add_argument_group("a magnet on a stage (a scene whose magnet has a travel: its pose is scheduled)")
    m.add_argument("--stage-speed", metavar="SPEED", help="the stage's largest speed along each of x and y, e.g. "
                                                           "'10mm/s'")
    m.add_argument("--turn-rate", metavar="RATE", help="the stage's largest turn rate of the magnet's axis, e.g. "
                                                        "'90deg/s'")
    add_set_arg(parser)
    parser.add_argument("--json", action="store_true", help="print exactly one JSON object")
    parser.add_argument("--out", metavar="DIR", help="write schedule.json/.csv/.png/.gif and waypoints.csv "
                                                     "(no .gif for a scene of coils or a magnet's pose)")


def _points(items, source: str):
    """Finite (x, y) pairs from (label, x_text, y_text) items; at least two."""
    pts = []
    for label, xt, yt in items:
        try:
            x, y = float(xt), float(yt)
        except (TypeError, ValueError):
            raise InputError(f"{source}: {label}: x, y must be numbers, got {xt!r}, {yt!r}")
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError(f"{source}: {label}: x, y must be finite")
        pts.append((x, y))
    if len(pts) < 2:
        raise InputError(f"{source}: need at least two X,Y points, got {len(pts)}")
    return pts


def _parse_waypoints(text: str):
    items = []
    for k, item in enumerate(t for t in text.replace(" ", "").split(";") if t):
        parts = item.split(",")
        if len(parts) != 2:
            raise InputError(f"--waypoints: item {k} {item!r} is not X,Y (points are separated by ';')")
        items.append((f"item {k}", *parts))
    return _points(items, "--waypoints")


def _read_path_csv(path: str):
    p = Path(path)
    if not p.is_file():
        raise InputError(f"--path-csv: file not found: {path}")
    with p.open(newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.lstrip().startswith("#")))
    if not rows or not {"x", "y"} <= set(rows[0]):
        raise InputError(f"--path-csv: {path} needs columns x, y (rod lengths)")
    return _points(((f"row {i + 1}", r["x"], r["y"]) for i, r in enumerate(rows)), "--path-csv")


def _payload(res, units, table) -> dict:
    """``res.to_dict()`` with the user's units added (never renamed): each schedule step gains
    ``field_A_per_m``, ``field_mT``, ``angle_deg`` (physical scenes) and ``time_s`` (with a rate);
    ``physical`` holds the length unit and the waypoints and tips in it."""
    payload = res.to_dict()
    extra = [{k: v for k, v in row.items() if k not in ("step", "h", "phi_rad")} for row in table]
    if any(extra):
        payload["schedule"] = [dict(s, **e) for s, e in zip(payload["schedule"], extra)]
    if units is not None:
        L = units.length
        payload["physical"] = {
            "length_unit": units.length_unit,
            "waypoints": [{"waypoint": r["waypoint"], "target_x": L(r["target_x"]), "target_y": L(r["target_y"]),
                           "x": L(r["x"]), "y": L(r["y"]), "error": L(r["error"]),
                           **({"field_A_per_m": units.field_A_per_m(r["h"]), "field_mT": units.field_mT(r["h"])}
                              if units.has_field else {})} for r in res.rows]}
    return payload


def _output_files(res, raw, payload, table, units=None, optimal=None) -> dict:
    """schedule.json, schedule.csv, waypoints.csv, schedule.png and (with states) schedule.gif,
    in memory."""
    from actuator_design.io.save import dumps_json
    from actuator_design.viz.design import schedule_figure, schedule_gif_bytes
    from actuator_design.viz.style import png_bytes

    text = dumps_json(dict(payload, config=raw), indent=1) + "\n"
    rows = _io.StringIO()
    steps = []
    for k, row in enumerate(table):
        st = res.states[k] if k < len(res.states) else None
        tip = {"tip_x": float(st.tip["x"]), "tip_y": float(st.tip["y"]), "tip_angle_rad": float(st.tip["angle"]),
               "stable": st.stable} if st else {}
        if st is not None and units is not None:
            tip[f"tip_x_{units.length_unit}"] = units.length(st.tip["x"])
            tip[f"tip_y_{units.length_unit}"] = units.length(st.tip["y"])
        steps.append({**{c: row[c] for c in ("step", "h", "phi_rad")}, **tip,
                      **{c: v for c, v in row.items() if c not in ("step", "h", "phi_rad")}})
    columns = ["step", "h", "phi_rad", "tip_x", "tip_y", "tip_angle_rad", "stable"]
    columns += [c for s in steps[:1] for c in s if c not in columns]
    if res.rows:
        wr = csv.DictWriter(rows, fieldnames=list(res.rows[0]))
        wr.writeheader()
        wr.writerows(res.rows)
    files = {"schedule.json": text, "schedule.csv": table_csv_text(steps, columns), "waypoints.csv": rows.getvalue(),
             "schedule.png": png_bytes(schedule_figure(res, units=units, optimal=optimal), dpi=150)}
    if res.states:
        files["schedule.gif"] = schedule_gif_bytes(res)
    return files


def _physical_lines(payload, table) -> list:
    """Waypoints and tips in the scene's length unit, fields in mT, the schedule's duration."""
    lines = []
    phys = payload.get("physical")
    if phys and phys["waypoints"]:
        u = phys["length_unit"]
        has_field = any("field_mT" in w for w in phys["waypoints"])
        lines.append(f"  {'wp':>3} {'target x':>10} {'target y':>10} {'tip x':>10} {'tip y':>10}  [{u}]"
                     + (f" {'field/mT':>10} {'H/(A/m)':>11}" if has_field else ""))
        for w in phys["waypoints"]:
            lines.append(f"  {w['waypoint']:>3} {w['target_x']:>10.5g} {w['target_y']:>10.5g} {w['x']:>10.5g} "
                         f"{w['y']:>10.5g}  {'':{len(u) + 2}}"
                         + (f" {w['field_mT']:>10.5g} {w['field_A_per_m']:>11.5g}" if has_field else ""))
    if table and "time_s" in table[-1]:
        lines.append(f"  duration: {table[-1]['time_s']:.4g} s at the given rates (schedule.csv: time_s)")
    return lines


def run(args: argparse.Namespace) -> int:
    check_out_dir(args.out)
    from actuator_design.model.scene import default_scene
    from actuator_design.equilibrium.options import SolverOptions

    study, raw = {}, None
    if args.config is None:
        scene, options = default_scene(h=0.0), SolverOptions()
    else:
        scene, options, raw = load_config(args.config)
        study = dict((raw or {}).get("study") or {})
        if study and study.get("type") != "schedule":
            raise InputError(f"study.type: expected 'schedule' for this command, got {study.get('type')!r}")
        study.pop("type", None)
    if args.set_values:  # any lens value (a plug-in term's too); the schedule then sets the field
        scene = apply_set_flags(scene, args)
        check_flags(scene, options)
    coils = getattr(scene.field, "kind", "") == "sources" and any(hasattr(s, "max_current") for s in scene.field.sources)
    stage = getattr(scene.field, "kind", "") == "sources" and any(getattr(s, "travel", ()) for s in scene.field.sources)
    for flag, value in (("--stage-speed", args.stage_speed), ("--turn-rate", args.turn_rate)):
        if value is not None and not stage:
            raise InputError(f"{flag}: only for a scene whose magnet has a travel (`field: {{type: magnet, travel: "
                             "...}`), whose pose is scheduled")
    if args.slew_rate is not None and not coils:
        raise InputError("--slew-rate: only for a scene whose field comes from coils (`field: {type: coils}`); "
                         "an ideal field's schedule takes --rate and --rotation-rate")
    if study and not coils and not stage:
        from actuator_design.config.studies.commands import SCHEDULE_KEYS
        refuse_unknown_keys(study, SCHEDULE_KEYS["field"])
    if args.waypoints and args.path_csv:
        raise InputError("--waypoints and --path-csv: give one of them, not both")
    if args.waypoints:
        wps = _parse_waypoints(args.waypoints)
    elif args.path_csv:
        wps = _read_path_csv(args.path_csv)
    elif "waypoints" in study:
        wps = _parse_waypoints(";".join(f"{p[0]},{p[1]}" for p in study["waypoints"]))
    else:
        raise InputError("--waypoints: required (or --path-csv, or `study: {type: schedule, waypoints: ...}`)")
    tol_name = "--path-tolerance" if args.path_tolerance is not None else "study.path_tolerance"
    path_tol = positive_target(args.path_tolerance if args.path_tolerance is not None else study.get("path_tolerance"),
                               scene, tol_name, "length", "length", "rod lengths")
    study.pop("path_tolerance", None)
    if stage:  # the magnet's pose is scheduled
        from actuator_design.cli.schedule.poses import run_poses
        return run_poses(args, scene, options, raw, study, wps, path_tol)
    if coils:  # the coils' currents are scheduled
        from actuator_design.cli.schedule.currents import run_currents
        return run_currents(args, scene, options, raw, study, wps, path_tol)
    rate = args.rate_weight if args.rate_weight is not None else float(study.get("rate_weight", 1.0))
    sub = args.substeps if args.substeps is not None else int(study.get("substeps", 8))
    if not (rate >= 0):
        raise InputError(f"--rate-weight: must be >= 0, got {rate}")
    if not (1 <= sub <= 200):
        raise InputError(f"--substeps: must lie in [1, 200], got {sub}")

    from actuator_design.schedules.schedule import field_schedule, schedule_table
    from actuator_design.io.save import dumps_json
    from actuator_design.io.user_units import user_units

    rates = parse_rates(args.rate if args.rate is not None else study.get("rate"),
                        args.rotation_rate if args.rotation_rate is not None else study.get("rotation_rate"))
    units = user_units(scene, raw)
    with bad_input():
        schedule_table([], units, *rates)  # a field rate needs a physical scene: say so before solving
    ocp = _optimal_control_request(args, study, units, rates, len(wps))
    with stdout_to_stderr(args.json), bad_input():
        res = field_schedule(wps, scene=scene, options=options, rate_weight=rate, substeps=sub)
        if ocp is not None:
            from actuator_design.schedules.schedule_ocp import optimal_schedule
            say = (lambda line: print(line, file=sys.stderr, flush=True)) if sys.stderr.isatty() else None
            ocp = optimal_schedule(wps, ocp["limits"], options=options, objective=ocp["objective"],
                                   nodes=ocp["nodes"], greedy=res, progress=say)
            res = ocp.result
    path = None
    if path_tol is not None:
        from actuator_design.schedules.path_corridor import hold_to_path
        path = hold_to_path(res, wps, path_tol, optimised=ocp is not None and ocp.optimal)
    with bad_input():
        table = schedule_table(res.schedule, units, *(rates if ocp is None else (None, None)))
    if ocp is not None:  # each step's time is the optimal-control problem's (the greedy rule's for the greedy one)
        table = [dict(row, time_s=t) for row, t in zip(table, ocp.times)]
    timed = bool(table) and "time_s" in table[-1]
    qs = None
    if timed:  # each step against the rod's relaxation time (issue 19 item 4): adds the table's columns
        from actuator_design.schedules.dynamics import quasi_static
        qs = quasi_static(res.states, table, scene.scales)
    payload = _payload(res, units, table)
    if path is not None:
        payload["path"] = path
    if timed:
        payload["quasi_static"] = qs
    if ocp is not None:
        payload["optimal_control"] = ocp.to_dict()["optimal_control"]
        if units is not None and units.has_field:  # ∫B² dt in the lab's units (B = μ0 H ∝ h)
            mT2 = units.field_mT(1.0) ** 2
            payload["optimal_control"].update(effort_mT2_s=ocp.effort * mT2, greedy_effort_mT2_s=ocp.greedy_effort * mT2)
    written = None
    if args.out is not None:
        written = write_out(args.out, _output_files(res, raw, payload, table, units, ocp), args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        print("actuator-design: field schedule through tip waypoints")
        print(f"  {'wp':>3} {'target x':>10} {'target y':>10} {'h':>10} {'phi/deg':>9} {'error':>9} {'margin':>8}")
        for r in res.rows:
            print(f"  {r['waypoint']:>3} {r['target_x']:>10.6f} {r['target_y']:>10.6f} {r['h']:>10.6f} "
                  f"{math.degrees(r['phi']):>9.3f} {r['error']:>9.2e} {r['margin']:>8.4g}")
        for line in _physical_lines(payload, table):
            print(line)
        if timed:
            print(quasi_static_line(qs, scene.scales))
        if path is not None:
            print(path_line(path))
        print(f"  schedule: {len(res.schedule)} points from zero field; {res.message}")
        if ocp is not None:
            oc = payload["optimal_control"]
            key, unit, what = (("effort_mT2_s", "mT^2 s", "B^2") if "effort_mT2_s" in oc else
                               ("effort_h2_s", "h^2 s", "h^2"))
            print(f"  optimal control ({ocp.objective}, {ocp.nodes} nodes): reported schedule {ocp.time_s:.4g} s, "
                  f"field effort (integral of {what} dt) {oc[key]:.4g} {unit}; greedy schedule "
                  f"{ocp.greedy_time_s:.4g} s, {oc['greedy_' + key]:.4g} {unit}; {ocp.message}")
        print(f"  time: {res.timings.get('total', float('nan')):.2f} s")
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK if res.success else EXIT_NOT_VERIFIED


def _optimal_control_request(args, study, units, rates, n_waypoints: int):
    """``{"objective", "limits", "nodes"}`` of ``--optimal-control`` (or the study's
    ``optimal_control``), or None; one line naming the missing or bad flag."""
    objective = args.optimal_control or study.get("optimal_control")
    if objective is None:
        for flag, value in (("--h-rate", args.h_rate), ("--nodes", args.nodes)):
            if value is not None:
                raise InputError(f"{flag}: only with --optimal-control (time or energy)")
        return None
    if objective not in ("time", "energy"):
        raise InputError(f"study.optimal_control: must be 'time' or 'energy', got {objective!r}")
    from actuator_design.schedules.schedule_ocp import MAX_NODES, RateLimits

    field_rate, rotation_rate = rates
    h_rate_text = args.h_rate if args.h_rate is not None else study.get("h_rate")
    if rotation_rate is None:
        raise InputError("--rotation-rate: --optimal-control needs the largest rotation rate of the field, e.g. 30deg/s")
    if field_rate is not None and h_rate_text is not None:
        raise InputError("--h-rate: give --rate (a physical field rate) or --h-rate (the group h per second), not both")
    if field_rate is not None:
        h_rate = field_rate * units.h_per_field  # h ∝ H (THEORY §5)
    elif h_rate_text is not None:
        text = str(h_rate_text).replace(" ", "")
        try:
            h_rate = float(text[:-2] if text.endswith("/s") else text)
        except ValueError:
            raise InputError(f"--h-rate: expected a rate per second such as '2/s', got {h_rate_text!r}")
        if not (math.isfinite(h_rate) and h_rate > 0):
            raise InputError(f"--h-rate: must be a finite rate > 0 per second, got {h_rate_text!r}")
    else:
        raise InputError("--rate: --optimal-control needs the field's largest rate of change: --rate (e.g. 5mT/s, "
                         "physical scenes) or --h-rate (e.g. 2/s, the group h per second)")
    nodes = args.nodes if args.nodes is not None else study.get("nodes", 40)
    if not (isinstance(nodes, int) and n_waypoints + 1 <= nodes <= MAX_NODES):
        raise InputError(f"--nodes: must be a whole number in [{n_waypoints + 1}, {MAX_NODES}] (one more than the "
                         f"{n_waypoints} waypoints at least), got {nodes!r}")
    return {"objective": objective, "limits": RateLimits(h_rate, rotation_rate), "nodes": nodes}
