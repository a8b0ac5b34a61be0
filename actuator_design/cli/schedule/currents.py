"""``schedule`` on a scene whose field comes from coils: the coils' currents (A) in time that move the
tip through the waypoints within each driver's current and slew limits and the field's power and
field limits, with the least energy (J) or in the least time (:mod:`actuator_design.schedules.current_schedule`).

Outputs with --out DIR: schedule.json, schedule.csv (every step: time, each coil's current, the
power, the tip), waypoints.csv and schedule.png. Exit codes: 0 verified schedule, 2 bad input,
3 not verified, 4 a waypoint no currents within the limits reach.
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math
import sys

from actuator_design.config.studies.commands import SCHEDULE_KEYS
from actuator_design.cli.common import InputError, bad_input, stdout_to_stderr, table_csv_text
from actuator_design.cli.design.units import (closing_lines, finish_schedule, hold_path, refuse_unknown_keys,
                                              substeps_arg, tip_columns)

__all__ = ["run_currents", "STUDY_KEYS"]

#: The `study:` keys of this schedule (:data:`~actuator_design.config.studies.commands.SCHEDULE_KEYS`).
STUDY_KEYS = SCHEDULE_KEYS["currents"]


def _slew(value, n_coils: int, name: str):
    """Each coil's slew rate (A/s) from '20 A/s', '20 A/s, 10 A/s' or a YAML list: one for all or one
    per coil, each > 0."""
    from actuator_design.model.units import parse_quantity

    items = value if isinstance(value, (list, tuple)) else [v for v in str(value).split(",") if v.strip()]
    if len(items) not in (1, n_coils):
        raise InputError(f"{name}: give one rate for every coil or one per coil ({n_coils}), got {len(items)}")
    rates = []
    for item in items:
        with bad_input():
            r = parse_quantity(item, "current_rate", name)
        if not r > 0:
            raise InputError(f"{name}: must be > 0, got {item!r}")
        rates.append(r)
    return rates * n_coils if len(rates) == 1 else rates


def run_currents(args: argparse.Namespace, scene, options, raw, study: dict, waypoints, path_tol=None) -> int:
    """The coil schedule of ``waypoints`` (rod lengths); ``study`` without its ``type``."""
    for flag, value in (("--rate", args.rate), ("--rotation-rate", args.rotation_rate), ("--h-rate", args.h_rate),
                        ("--rate-weight", args.rate_weight)):
        if value is not None:
            raise InputError(f"{flag}: the scene's field comes from coils, whose currents are scheduled; give each "
                             "driver's limit with --slew-rate (e.g. 20A/s) instead")
    for key in ("rate", "rotation_rate", "h_rate", "rate_weight"):
        if key in study:
            raise InputError(f"study.{key}: not for a field from coils, whose currents are scheduled; give "
                             "slew_rate (e.g. 20 A/s)")
    refuse_unknown_keys(study, STUDY_KEYS, "a schedule over coil currents")
    coils = scene.field.sources
    slew_text = args.slew_rate if args.slew_rate is not None else study.get("slew_rate")
    if slew_text is None:
        raise InputError("--slew-rate: a schedule over coil currents needs each driver's largest rate of change, "
                         "e.g. --slew-rate 20A/s (or `slew_rate:` in the study)")
    slew = _slew(slew_text, len(coils), "--slew-rate" if args.slew_rate is not None else "study.slew_rate")
    objective = args.optimal_control or study.get("optimal_control") or "energy"
    if objective not in ("time", "energy"):
        raise InputError(f"study.optimal_control: must be 'time' or 'energy', got {objective!r}")
    nodes_name = "--nodes" if args.nodes is not None else "study.nodes"
    from actuator_design.schedules.schedule_ocp import MAX_NODES

    nodes = args.nodes if args.nodes is not None else study.get("nodes", 40)
    if not (isinstance(nodes, int) and len(waypoints) + 1 <= nodes <= MAX_NODES):
        raise InputError(f"{nodes_name}: must be a whole number in [{len(waypoints) + 1}, {MAX_NODES}] (one more than "
                         f"the {len(waypoints)} waypoints at least), got {nodes!r}")
    substeps = substeps_arg(args, study)

    from actuator_design.schedules.current_schedule import current_schedule
    from actuator_design.io.user_units import user_units

    units = user_units(scene, raw)
    say = (lambda line: print(line, file=sys.stderr, flush=True)) if sys.stderr.isatty() else None
    with stdout_to_stderr(args.json), bad_input():
        res = current_schedule(scene, waypoints, slew, objective=objective, nodes=nodes, substeps=substeps,
                               options=options, progress=say)
    payload = res.to_dict()
    hold_path(res, waypoints, path_tol, payload)
    if units is not None:
        payload["physical"] = {"length_unit": units.length_unit, "waypoints": [
            {"waypoint": r["waypoint"], "target_x": units.length(r["target_x"]), "target_y": units.length(r["target_y"]),
             "x": units.length(r["x"]), "y": units.length(r["y"]), "error": units.length(r["error"])}
            for r in payload["rows"]]}
    return finish_schedule(args, res, payload, lambda: _files(res, payload, raw, units), _summary)


def _summary(res, payload) -> list:
    unit = "J" if res.effort == "energy" else "A^2 s"
    what = "energy" if res.effort == "energy" else "integral of sum I^2 dt"
    lines = ["actuator-design: coil currents through tip waypoints",
             f"  {'wp':>3} {'target x':>10} {'target y':>10} {'time/s':>9}  currents/A" + " " * 14 + f"{'error':>9} {'margin':>8}"]
    for r in payload["rows"]:
        t = res.times[res.waypoint_index[r["waypoint"]]]
        cur = ", ".join(f"{c:.5g}" for c in r["currents_A"])
        lines.append(f"  {r['waypoint']:>3} {r['target_x']:>10.6f} {r['target_y']:>10.6f} {t:>9.4g}  {cur:<24}"
                     f"{r['error']:>9.2e} {r['margin']:>8.4g}")
    phys = payload.get("physical")
    if phys and phys["waypoints"]:
        u = phys["length_unit"]
        lines.append("  waypoints in " + u + ": " + "; ".join(f"({w['target_x']:.5g}, {w['target_y']:.5g})"
                                                           for w in phys["waypoints"]))
    if math.isfinite(res.greedy_duration):
        lines.append(f"  schedules ({res.objective} minimised, {res.nodes} nodes): reported {res.duration:.4g} s, "
                     f"{what} {res.energy:.4g} {unit}; greedy {res.greedy_duration:.4g} s, {res.greedy_energy:.4g} {unit}")
    if res.extremes:
        e = res.extremes
        parts = [f"current {e['current']:.3g}", f"slew {e['slew']:.3g}"]
        parts += [f"{k} {e[k]:.3g}" for k in ("power", "field") if k in e]
        lines.append(f"  limits used (largest over the steps, 1 = at the limit): {', '.join(parts)}; largest field "
                     f"on the rod {e['largest_field_mT']:.4g} mT")
    return lines + closing_lines(res, path=payload.get("path"))


def _files(res, payload, raw, units) -> dict:
    from actuator_design.io.save import dumps_json
    from actuator_design.viz.current_schedule import current_schedule_figure
    from actuator_design.viz.style import png_bytes

    files = {"schedule.json": dumps_json(dict(payload, config=raw), indent=1) + "\n"}
    states = res.verification.states if res.verification is not None else []
    resist = [c.resistance for c in res.verification.scene.field.sources] if res.verification is not None else []
    steps, n = [], len(res.max_current)
    for k, (t, cur) in enumerate(zip(res.times, res.currents)):
        row = {"step": k, "time_s": t, **{f"I{j + 1}_A": cur[j] for j in range(n)}}
        if res.effort == "energy":
            row["power_W"] = sum(r * c * c for r, c in zip(resist, cur))
        if k < len(states):
            row.update(tip_columns(states[k], units))
        row.update(res.step_relaxation(k))
        steps.append(row)
    if steps:
        files["schedule.csv"] = table_csv_text(steps, list(steps[-1]))
    if payload["rows"]:
        buf = _io.StringIO()
        rows = [{**{k: v for k, v in r.items() if k != "currents_A"},
                 **{f"I{j + 1}_A": r["currents_A"][j] for j in range(n)}} for r in payload["rows"]]
        wr = csv.DictWriter(buf, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
        files["waypoints.csv"] = buf.getvalue()
    if res.verification is not None and res.verification.states:
        files["schedule.png"] = png_bytes(current_schedule_figure(res, units), dpi=150)
    return files
