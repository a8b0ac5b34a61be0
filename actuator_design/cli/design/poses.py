"""``design`` with several poses (``--target-tip 'X1,Y1;X2,Y2'``): text, JSON and files.

One actuator (one fibre layout) and one field per pose; see :mod:`actuator_design.inverse.poses`.
Exit codes as for one pose: 0 every pose verified and holding over the tolerance box, 2 bad input,
3 not verified (or the mesh does not resolve the design or the search found nothing: status
inaccurate / failed), 4 a pose
unreachable or not holding over the box.
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math

from actuator_design.cli.common import (EXIT_NOT_VERIFIED, EXIT_OK, EXIT_UNREACHABLE, bad_input,
                                        stdout_to_stderr)
from actuator_design.cli.design.units import add_schedule_units, quasi_static_line, unit_labels
from actuator_design.cli.common import emit

__all__ = ["run_poses", "summary"]



def summary(res, units=None, table=None, qs=None) -> str:
    """The text report: the shared layout, then one block of lines per pose (targets, tips and
    fields also in the scene's units when it is physical)."""
    lines = ["actuator-design: inverse design, one actuator for several poses",
             f"  variables   : {', '.join(res.vary)} (alpha shared, the others one per pose)"]
    a = res.alpha
    if a:
        lines.append(f"  fibres      : alpha(s) from {math.degrees(a['value'][0]):.3g} deg (clamp) to "
                     f"{math.degrees(a['value'][-1]):.3g} deg (tip), Legendre coefficients "
                     f"{', '.join(f'{c:.4g}' for c in a['legendre_coefficients'])} rad")
    for k, p in enumerate(res.poses, start=1):
        t = p.target
        lab = (f" = ({units.length(t[0]):.6g}, {units.length(t[1]):.6g}) {units.length_unit}"
               if units is not None else "")
        lines.append(f"  pose {k:<6} : target x = {t[0]:.6g}, y = {t[1]:.6g}"
                     + (f", angle = {math.degrees(t[2]):.4g} deg" if len(t) > 2 else "") + f"  [rod lengths]{lab}")
        field = (f" ({units.field_mT(p.design['h']):.6g} mT)" if units is not None and units.has_field else "")
        lines.append(f"    field     : h = {p.design['h']:.8g}{field}, phi = {_phi_text(res, k, p.design['phi'])}, "
                     f"p = {p.design['p']:.6g}")
        tip = (f" = ({units.length(p.achieved['x']):.6g}, {units.length(p.achieved['y']):.6g}) {units.length_unit}"
               if units is not None else "")
        lines.append(f"    achieved  : x = {p.achieved['x']:.10f}, y = {p.achieved['y']:.10f}{tip}; error {p.error:.3e}; "
                     f"verified {p.verified}, stable {p.stable}, snap-free {p.snap_free}")
        if p.at_bound:
            lines.append(f"    bound     : {p.at_bound}")
        if p.robustness is not None:
            r = p.robustness
            lines.append(f"    robustness: {'holds' if r.holds else 'does NOT hold'} over the box "
                         f"({r.tolerances.describe()}): worst tip error {r.worst_tip_error:.3g}; "
                         f"{r.fold_distance.sentence()}")
    if res.transitions:
        timed = (f", {table[-1]['time_s']:.4g} s at the given rates" if table and "time_s" in table[-1] else "")
        lines.append("  schedule    : " + f"{len(res.schedule)} steps from zero field through the poses in order"
                     + timed)
        lines += [f"    {t}" for t in res.transitions]
        if table and "time_s" in table[-1]:
            lines.append(quasi_static_line(qs, res.scene.scales))
    lines.append(f"  time        : {res.timings.get('total', float('nan')):.2f} s")
    lines.append(f"  note        : {res.message}")
    lines.append("  RESULT      : " + ("SUCCESS — every pose verified, stable, snap-free and holding over the box"
                                      if res.success else "NOT a success (see note)"))
    return "\n".join(lines)


def _phi_text(res, k: int, phi: float) -> str:
    """Pose k's field angle as the schedule (and its figure) leaves the field there, and the design's
    representative in (-90, 90] deg when they differ (one field axis), as for one pose."""
    ends = [q["phi"] for q in res.schedule if q.get("pose") == k]
    end = ends[-1] if ends else phi
    text = f"{math.degrees(end):.6g} deg"
    if abs(end - phi) > 1e-9:
        text += f" (field axis, the same as {math.degrees(phi):.6g} deg)"
    return text


def payload_of(res, units=None, table=None) -> dict:
    """``res.to_dict()`` with the user's units added (never renamed), as for one pose: ``physical``
    (length unit; per pose the target, tip in it and the field in mT and A/m) and the schedule's
    steps with ``field_A_per_m``, ``field_mT``, ``angle_deg`` and ``time_s`` (with rates)."""
    payload = res.to_dict()
    if units is not None:
        poses = []
        for p in res.poses:
            q = {"target": {"x": units.length(p.target[0]), "y": units.length(p.target[1])},
                 "tip": {"x": units.length(p.achieved["x"]), "y": units.length(p.achieved["y"])}}
            if units.has_field:
                q.update(field_mT=units.field_mT(p.design["h"]), field_A_per_m=units.field_A_per_m(p.design["h"]),
                         angle_deg=math.degrees(p.design["phi"]))
            poses.append(q)
        payload["physical"] = {"length_unit": units.length_unit, "poses": poses, "units": unit_labels(units)}
    add_schedule_units(payload, table)
    return payload


def _files(res, raw, payload, table=None) -> dict:
    from actuator_design.io.save import dumps_json, scene_to_dict, shape_csv_text
    from actuator_design.viz.design import poses_figure

    payload = dict(payload)
    payload["scene"] = scene_to_dict(res.scene)
    payload["config"] = raw
    sched = _io.StringIO()
    w = csv.writer(sched)
    extra = [c for c in ("field_A_per_m", "field_mT", "angle_deg", "time_s", "relaxation_time_s", "quasi_static")
             if table and c in table[0]]
    w.writerow(["step", "pose", "h", "phi_rad"] + extra)
    for k, s in enumerate(res.schedule):
        w.writerow([k, s.get("pose", ""), repr(float(s["h"])), repr(float(s["phi"]))]
                   + [repr(table[k][c] if isinstance(table[k][c], bool) else float(table[k][c])) for c in extra])
    files = {"design.json": dumps_json(payload, indent=1) + "\n", "schedule.csv": sched.getvalue(),
             "design.png": poses_figure(res)}
    for k, p in enumerate(res.poses, start=1):
        if p.state is not None and p.state.success:
            files[f"shape_pose{k}.csv"] = shape_csv_text(p.state)
    return files


def run_poses(args: argparse.Namespace, scene, options, raw, targets, vary, settings, units=None,
              rates=(None, None)) -> int:
    from actuator_design.inverse.poses import design_poses
    from actuator_design.schedules.schedule import schedule_table

    with stdout_to_stderr(args.json), bad_input():
        res = design_poses(targets, scene=scene, vary=vary, options=options, settings=settings,
                           verify=not args.no_verify)
    table, qs = None, None
    if res.schedule and (units is not None or rates != (None, None)):
        with bad_input():
            table = schedule_table(res.schedule, units, *rates)
        if "time_s" in table[0] and scene.scales is not None and scene.scales.mass_per_length > 0:
            from actuator_design.schedules.dynamics import quasi_static, schedule_states
            qs = quasi_static(schedule_states(res.scene, res.schedule, options), table, scene.scales)
    payload = payload_of(res, units, table)
    if table and "time_s" in table[0]:
        payload["quasi_static"] = qs
    emit(args, res, lambda: _files(res, raw, payload, table), lambda r: summary(r, units, table, qs),
         payload=payload)
    if res.success:
        return EXIT_OK
    if res.status in ("inaccurate", "failed"):  # nothing established about reachability
        return EXIT_NOT_VERIFIED
    if not res.poses or not res.reachable or not res.robust:
        return EXIT_UNREACHABLE
    return EXIT_NOT_VERIFIED
