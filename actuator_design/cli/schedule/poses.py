"""``schedule`` on a scene whose magnet has a travel: the magnet's pose (position mm, axis deg) in
time that moves the tip through the waypoints within the stage's travel, speed and turn rate
(:mod:`actuator_design.schedules.pose_schedule`).

Outputs with --out DIR: schedule.json, schedule.csv (every step: time, the pose, the tip),
waypoints.csv and schedule.png. Exit codes: 0 verified schedule, 2 bad input, 3 not verified,
4 a waypoint no pose within the travel reaches.
"""
from __future__ import annotations

import argparse
import math
import sys

from actuator_design.config.studies.commands import SCHEDULE_KEYS
from actuator_design.cli.common import InputError, bad_input, stdout_to_stderr, table_csv_text
from actuator_design.cli.design.units import (closing_lines, finish_schedule, hold_path, refuse_unknown_keys,
                                              substeps_arg, tip_columns)

__all__ = ["run_poses", "STUDY_KEYS"]

#: The `study:` keys of this schedule (:data:`~actuator_design.config.studies.commands.SCHEDULE_KEYS`).
STUDY_KEYS = SCHEDULE_KEYS["pose"]


def _rate(args, study, flag: str, key: str, dimension: str, example: str, needed: bool):
    """The rate given by ``flag`` or the study's ``key`` in SI, or None when not given and not needed."""
    from actuator_design.model.units import parse_quantity

    value = getattr(args, key) if getattr(args, key) is not None else study.get(key)
    name = flag if getattr(args, key) is not None else f"study.{key}"
    if value is None and not needed:
        return None
    if value is None:
        raise InputError(f"{flag}: a schedule over a magnet's pose needs its stage's {key.replace('_', ' ')}, e.g. "
                         f"{flag} {example} (or `{key}:` in the study)")
    with bad_input():
        r = parse_quantity(value, dimension, name)
    if not r > 0:
        raise InputError(f"{name}: must be > 0, got {value!r}")
    return r


def run_poses(args: argparse.Namespace, scene, options, raw, study: dict, waypoints, path_tol=None) -> int:
    """The pose schedule of ``waypoints`` (rod lengths); ``study`` without its ``type``."""
    for flag, value in (("--rate", args.rate), ("--rotation-rate", args.rotation_rate), ("--h-rate", args.h_rate),
                        ("--rate-weight", args.rate_weight), ("--slew-rate", args.slew_rate),
                        ("--optimal-control", args.optimal_control), ("--nodes", args.nodes)):
        if value is not None:
            raise InputError(f"{flag}: the scene's magnet has a travel, whose pose is scheduled; give the stage's "
                             "--stage-speed (e.g. 10mm/s) and --turn-rate (e.g. 90deg/s) instead")
    refuse_unknown_keys(study, STUDY_KEYS, "a schedule over a magnet's pose")
    moving = next(s.travel for s in scene.field.sources if getattr(s, "travel", ()))
    speed = _rate(args, study, "--stage-speed", "stage_speed", "speed", "10mm/s",
                  moving[0] is not None or moving[1] is not None)
    turn = _rate(args, study, "--turn-rate", "turn_rate", "angular_rate", "90deg/s", moving[2] is not None)
    substeps = substeps_arg(args, study)

    from actuator_design.schedules.pose_schedule import pose_schedule
    from actuator_design.io.user_units import user_units

    units = user_units(scene, raw)
    say = (lambda line: print(line, file=sys.stderr, flush=True)) if sys.stderr.isatty() else None
    with stdout_to_stderr(args.json), bad_input():
        res = pose_schedule(scene, waypoints, speed, turn, substeps=substeps, options=options, progress=say)
    payload = res.to_dict()
    hold_path(res, waypoints, path_tol, payload)
    return finish_schedule(args, res, payload, lambda: _files(res, payload, raw, units), _summary)


def _summary(res, payload) -> list:
    lines = ["actuator-design: a magnet's pose through tip waypoints",
             f"  {'wp':>3} {'target x':>10} {'target y':>10} {'time/s':>9} {'x/mm':>9} {'y/mm':>9} {'axis/deg':>9}"
             f" {'error':>9} {'margin':>8}"]
    for r in payload["rows"]:
        t = res.times[res.waypoint_index[r["waypoint"]]]
        lines.append(f"  {r['waypoint']:>3} {r['target_x']:>10.6f} {r['target_y']:>10.6f} {t:>9.4g} {r['x_mm']:>9.5g} "
                     f"{r['y_mm']:>9.5g} {r['axis_angle_deg']:>9.5g} {r['error']:>9.2e} {r['margin']:>8.4g}")
    if res.times:
        rates = [f"{res.speed * 1e3:.4g} mm/s" if math.isfinite(res.speed) else "",
                 f"{math.degrees(res.turn_rate):.4g} deg/s" if math.isfinite(res.turn_rate) else ""]
        lines.append(f"  moves: straight in (x, y, axis), each axis at most {' and '.join(r for r in rates if r)}: "
                     f"{res.duration:.4g} s in all")
    return lines + closing_lines(res, f" ({res.solves} solves)", payload.get("path"))


def _files(res, payload, raw, units) -> dict:
    from actuator_design.io.save import dumps_json
    from actuator_design.viz.pose_schedule import pose_schedule_figure
    from actuator_design.viz.style import png_bytes

    files = {"schedule.json": dumps_json(dict(payload, config=raw), indent=1) + "\n"}
    states = res.verification.states if res.verification is not None else []
    steps = []
    for k, row in enumerate(payload["schedule"]):
        steps.append(dict(row, **tip_columns(states[k], units)) if k < len(states) else row)
    if steps:
        files["schedule.csv"] = table_csv_text(steps, list(steps[-1]))
    if payload["rows"]:
        files["waypoints.csv"] = table_csv_text(payload["rows"], list(payload["rows"][0]))
    if states:
        files["schedule.png"] = png_bytes(pose_schedule_figure(res, units), dpi=150)
    return files
