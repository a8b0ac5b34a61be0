"""``design`` with several poses (``--target-tip 'X1,Y1;X2,Y2'``): text, JSON and files.

One actuator (one fibre layout) and one field per pose; see :mod:`actuator_design.analysis.design_poses`.
Exit codes as for one pose: 0 every pose verified and holding over the tolerance box, 2 bad input,
3 not verified, 4 a pose unreachable or not holding over the box.
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math

from .common import EXIT_OK, bad_input, stdout_to_stderr
from .output import emit

__all__ = ["run_poses", "summary"]

EXIT_NOT_VERIFIED, EXIT_UNREACHABLE = 3, 4


def summary(res) -> str:
    """The text report: the shared layout, then one block of lines per pose."""
    lines = ["actuator-design: inverse design, one actuator for several poses",
             f"  variables   : {', '.join(res.vary)} (alpha shared, the others one per pose)"]
    a = res.alpha
    if a:
        lines.append(f"  fibres      : alpha(s) from {math.degrees(a['value'][0]):.3g} deg (clamp) to "
                     f"{math.degrees(a['value'][-1]):.3g} deg (tip), Legendre coefficients "
                     f"{', '.join(f'{c:.4g}' for c in a['legendre_coefficients'])} rad")
    for k, p in enumerate(res.poses, start=1):
        t = p.target
        lines.append(f"  pose {k:<6} : target x = {t[0]:.6g}, y = {t[1]:.6g}"
                     + (f", angle = {math.degrees(t[2]):.4g} deg" if len(t) > 2 else "") + "  [rod lengths]")
        lines.append(f"    field     : h = {p.design['h']:.8g}, phi = {math.degrees(p.design['phi']):.6g} deg "
                     f"(field axis), p = {p.design['p']:.6g}")
        lines.append(f"    achieved  : x = {p.achieved['x']:.10f}, y = {p.achieved['y']:.10f}; error {p.error:.3e}; "
                     f"verified {p.verified}, stable {p.stable}, snap-free {p.snap_free}")
        if p.robustness is not None:
            r = p.robustness
            lines.append(f"    robustness: {'holds' if r.holds else 'does NOT hold'} over the box "
                         f"({r.tolerances.describe()}): worst tip error {r.worst_tip_error:.3g}; "
                         f"{r.fold_distance.sentence()}")
    if res.transitions:
        lines.append("  schedule    : " + f"{len(res.schedule)} steps from zero field through the poses in order")
        lines += [f"    {t}" for t in res.transitions]
    lines.append(f"  time        : {res.timings.get('total', float('nan')):.2f} s")
    lines.append(f"  note        : {res.message}")
    lines.append("  RESULT      : " + ("SUCCESS — every pose verified, stable, snap-free and holding over the box"
                                      if res.success else "NOT a success (see note)"))
    return "\n".join(lines)


def _files(res, raw) -> dict:
    from ..io import dumps_json, scene_to_dict, shape_csv_text
    from ..viz.design import poses_figure

    payload = res.to_dict()
    payload["scene"] = scene_to_dict(res.scene)
    payload["config"] = raw
    sched = _io.StringIO()
    w = csv.writer(sched)
    w.writerow(["step", "pose", "h", "phi_rad"])
    for k, s in enumerate(res.schedule):
        w.writerow([k, s.get("pose", ""), repr(float(s["h"])), repr(float(s["phi"]))])
    files = {"design.json": dumps_json(payload, indent=1) + "\n", "schedule.csv": sched.getvalue(),
             "design.png": poses_figure(res)}
    for k, p in enumerate(res.poses, start=1):
        if p.state is not None and p.state.success:
            files[f"shape_pose{k}.csv"] = shape_csv_text(p.state)
    return files


def run_poses(args: argparse.Namespace, scene, options, raw, targets, vary, settings) -> int:
    from ..analysis.design_poses import design_poses

    with stdout_to_stderr(args.json), bad_input():
        res = design_poses(targets, scene=scene, vary=vary, options=options, settings=settings,
                           verify=not args.no_verify)
    emit(args, res, lambda: _files(res, raw), summary)
    if res.success:
        return EXIT_OK
    if not res.poses or not res.reachable or not res.robust:
        return EXIT_UNREACHABLE
    return EXIT_NOT_VERIFIED
