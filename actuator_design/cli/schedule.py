"""Design a field schedule (magnitude h and angle phi over time) that moves the tip through waypoints.

Every state along the schedule is a stable quasi-static equilibrium reached continuously from the
previous one; the schedule starts from zero field and minimises field effort and rate of change.
It is verified by following the whole schedule quasi-statically (no snap, every state stable, each
waypoint reached). Waypoints are in rod lengths (clamp at the origin, rod initially along +x).

Outputs with --out DIR: schedule.json, schedule.csv (every schedule point), waypoints.csv (one row
per waypoint), schedule.png (the rod along the path) and schedule.gif (an animation).
Exit codes: 0 verified schedule, 2 bad input, 3 no verified schedule (the message says why).
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math
from pathlib import Path

from .common import EXIT_OK, InputError, bad_input, check_out_dir, finite_float, load_config, stdout_to_stderr
from .output import print_written, write_out

__all__ = ["HELP", "add_args", "run"]

HELP = "a field schedule (h, phi) that moves the tip through waypoints, verified snap-free"
EXIT_NOT_VERIFIED = 3


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene (and optional `study: {type: schedule, waypoints: [[x, y], ...]}`)")
    parser.add_argument("--waypoints", metavar="X1,Y1;X2,Y2;...",
                        help="tip waypoints in rod lengths, in visiting order")
    parser.add_argument("--path-csv", metavar="FILE",
                        help="a sampled tip path: CSV with columns x, y (rod lengths), one row per point")
    parser.add_argument("--rate-weight", type=finite_float, default=None,
                        help="weight of the field's rate of change against its magnitude (default 1)")
    parser.add_argument("--substeps", type=int, default=None,
                        help="schedule points between consecutive waypoints (default 8)")
    parser.add_argument("--json", action="store_true", help="print exactly one JSON object")
    parser.add_argument("--out", metavar="DIR", help="write schedule.json/.csv/.png/.gif and waypoints.csv")


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


def _output_files(res, raw) -> dict:
    """schedule.json, schedule.csv, waypoints.csv, schedule.png and (with states) schedule.gif,
    in memory."""
    from ..io import dumps_json
    from ..viz.design import schedule_figure, schedule_gif_bytes
    from ..viz.style import png_bytes

    payload = dict(res.to_dict(), config=raw)
    text = dumps_json(payload, indent=1) + "\n"
    sched, rows = _io.StringIO(), _io.StringIO()
    w = csv.writer(sched)
    w.writerow(["step", "h", "phi_rad", "tip_x", "tip_y", "tip_angle_rad", "stable"])
    for k, s in enumerate(res.schedule):
        st = res.states[k] if k < len(res.states) else None
        w.writerow([k, repr(s["h"]), repr(s["phi"])] + ([repr(st.tip["x"]), repr(st.tip["y"]),
                                                          repr(st.tip["angle"]), st.stable] if st else ["", "", "", ""]))
    if res.rows:
        wr = csv.DictWriter(rows, fieldnames=list(res.rows[0]))
        wr.writeheader()
        wr.writerows(res.rows)
    files = {"schedule.json": text, "schedule.csv": sched.getvalue(), "waypoints.csv": rows.getvalue(),
             "schedule.png": png_bytes(schedule_figure(res), dpi=130)}
    if res.states:
        files["schedule.gif"] = schedule_gif_bytes(res)
    return files


def run(args: argparse.Namespace) -> int:
    check_out_dir(args.out)
    from ..scene import default_scene
    from ..options import SolverOptions

    study, raw = {}, None
    if args.config is None:
        scene, options = default_scene(h=0.0), SolverOptions()
    else:
        scene, options, raw = load_config(args.config)
        study = dict((raw or {}).get("study") or {})
        if study and study.get("type") != "schedule":
            raise InputError(f"study.type: expected 'schedule' for this command, got {study.get('type')!r}")
        study.pop("type", None)
        unknown = sorted(set(study) - {"waypoints", "rate_weight", "substeps"})
        if unknown:
            raise InputError(f"study.{unknown[0]}: unknown key (allowed: waypoints, rate_weight, substeps)")
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
    rate = args.rate_weight if args.rate_weight is not None else float(study.get("rate_weight", 1.0))
    sub = args.substeps if args.substeps is not None else int(study.get("substeps", 8))
    if not (rate >= 0):
        raise InputError(f"--rate-weight: must be >= 0, got {rate}")
    if not (1 <= sub <= 200):
        raise InputError(f"--substeps: must lie in [1, 200], got {sub}")

    from ..analysis.schedule import field_schedule
    from ..io import dumps_json

    with stdout_to_stderr(args.json), bad_input():
        res = field_schedule(wps, scene=scene, options=options, rate_weight=rate, substeps=sub)
    written = None
    if args.out is not None:
        written = write_out(args.out, _output_files(res, raw), args.json)
    if args.json:
        print(dumps_json(res.to_dict()))
    else:
        print("actuator-design: field schedule through tip waypoints")
        print(f"  {'wp':>3} {'target x':>10} {'target y':>10} {'h':>10} {'phi/deg':>9} {'error':>9} {'margin':>8}")
        for r in res.rows:
            print(f"  {r['waypoint']:>3} {r['target_x']:>10.6f} {r['target_y']:>10.6f} {r['h']:>10.6f} "
                  f"{math.degrees(r['phi']):>9.3f} {r['error']:>9.2e} {r['margin']:>8.4g}")
        print(f"  schedule: {len(res.schedule)} points from zero field; {res.message}")
        print(f"  time: {res.timings.get('total', float('nan')):.2f} s")
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK if res.success else EXIT_NOT_VERIFIED
