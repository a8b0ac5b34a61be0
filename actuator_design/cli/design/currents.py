"""``design --target-tip X,Y`` on a scene whose field comes from coils: the least-power coil currents
(A) within each driver's limit that put the tip on the target
(:func:`~actuator_design.hardware.current_design.design_currents`), printed in A, W, mT and the
rod's length unit, and written as design.json, shape.csv and shape.png."""
from __future__ import annotations

import math
import sys
from typing import Optional

from actuator_design.cli.common import (EXIT_NOT_VERIFIED, EXIT_OK, EXIT_UNREACHABLE, InputError, bad_input,
                                        stdout_to_stderr)
from actuator_design.cli.common import emit

__all__ = ["run_currents", "run_current_shape", "run_current_stiffness", "finish_stiffness", "tail_lines", "finish", "progress_line", "refuse_flags"]

_NOT_FOR_HARDWARE = ("h_max", "p_max", "alpha_max_deg", "alpha_terms", "margin", "time_limit", "clearance", "rate",
                     "rotation_rate")


def refuse_flags(args, vary, what: str, limits: str) -> None:
    """--vary and the flags of an ideal-field design do not apply to a design over hardware."""
    if vary is not None:
        raise InputError(f"--vary: on this scene the design varies {what}; leave --vary out")
    for flag in _NOT_FOR_HARDWARE:
        if getattr(args, flag, None) is not None:
            raise InputError(f"--{flag.replace('_', '-')}: does not apply to a design over {what} ({limits})")


def run_currents(args, scene, options, raw, target, vary, settings) -> int:
    """Design, print, write; exit 0 success, 3 not verified or not robust, 4 unreachable."""
    from actuator_design.hardware.current_design import coil_problem, design_currents

    refuse_flags(args, vary, "the coils' currents (each within its max_current)",
                 "the coils' max_current, resistance, max_power and max_field are its limits")
    with bad_input():  # the request is checked up front: what fails later is the design's, not the input's
        coil_problem(scene, target)
    with stdout_to_stderr(args.json):
        res = design_currents(scene, target, tolerances=settings.tolerances, options=options,
                              verify=not args.no_verify, progress=progress_line())
    return finish(args, res, scene.scales.length, _summary, "designed state (coil currents)")


def run_current_shape(args, scene, options, raw, vary, settings) -> int:
    """``design --target-shape`` on a coil scene: the currents whose rod passes nearest the points
    (:func:`~actuator_design.hardware.current_shape.design_current_shape`); exit codes as for a tip."""
    from actuator_design.cli.design.shape import read_points
    from actuator_design.hardware.current_design import coil_problem
    from actuator_design.hardware.current_shape import design_current_shape

    refuse_flags(args, vary, "the coils' currents (each within its max_current)",
                 "the coils' max_current, resistance, max_power and max_field are its limits")
    pts = read_points(args.target_shape, args.target_units or "rod", scene)
    with bad_input():
        coil_problem(scene, pts[-1, 1:])
    with stdout_to_stderr(args.json):
        res = design_current_shape(scene, pts, tolerances=settings.tolerances, options=options,
                                   verify=not args.no_verify, accept_tol=settings.accept_tol,
                                   progress=progress_line())
    return finish(args, res, scene.scales.length, _shape_summary, "designed state (coil currents)")


def run_current_stiffness(args, scene, options, raw, target, vary, settings, stiffness) -> int:
    """``design --target-stiffness`` on a coil scene (with or without ``--target-tip``): the
    least-power currents with that tip stiffness
    (:func:`~actuator_design.hardware.current_stiffness.design_current_stiffness`); exit codes as for a tip."""
    from actuator_design.hardware.current_design import coil_problem
    from actuator_design.hardware.current_stiffness import design_current_stiffness

    refuse_flags(args, vary, "the coils' currents (each within its max_current)",
                 "the coils' max_current, resistance, max_power and max_field are its limits")
    with bad_input():
        coil_problem(scene, target if target is not None else (0.0, 0.0))
    with stdout_to_stderr(args.json):
        res = design_current_stiffness(scene, stiffness, target, tolerances=settings.tolerances, options=options,
                                       verify=not args.no_verify, accept_tol=settings.accept_tol,
                                       progress=progress_line())
    return finish_stiffness(args, res, scene, _summary, "designed state (coil currents)")


def finish_stiffness(args, res, scene, summary, title: str) -> int:
    """:func:`finish` for a stiffness design over hardware: ``summary``'s lines (the tip design's)
    with the stiffness in B0/l^3 and N/m, and the stiffness in N/m under the JSON's ``physical``."""
    k = scene.scales.stiffness
    return finish(args, res, scene.scales.length, lambda r, length: _stiffness_summary(r, length, k, summary),
                  title, physical={"target_stiffness_N_per_m": res.stiffness_target * k,
                                   "achieved_stiffness_N_per_m": res.achieved_stiffness * k,
                                   "verified_stiffness_N_per_m": res.verification.get("stiffness", math.nan) * k})


def progress_line():
    """Progress on stderr, one line a stage, when it is a terminal (else None)."""
    return (lambda line: print(line, file=sys.stderr, flush=True)) if sys.stderr.isatty() else None


def finish(args, res, length: float, summary, title: str, physical: Optional[dict] = None) -> int:
    """Print (or write, with --json) a design over hardware with its tip in the rod's unit (and the
    values of ``physical`` under the JSON's ``physical`` key), write its files, and give the exit
    code: 0 success, 3 not verified or not robust, 4 unreachable."""
    from actuator_design.cli.design.force import state_files

    payload = res.to_dict()
    payload["physical"] = {"tip_mm": [v * length * 1e3 for v in res.tip[:2]],
                           "target_mm": [v * length * 1e3 for v in res.target[:2]],
                           "tip_error_mm": res.tip_error * length * 1e3,
                           "worst_tip_error_mm": res.worst_tip_error * length * 1e3, **(physical or {})}
    shape = payload.get("shape")
    if shape is not None:  # a shape target: its fit in mm too, and the fit's table
        payload["physical"].update(rms_error_mm=shape["rms_error"] * length * 1e3,
                                   max_error_mm=shape["max_error"] * length * 1e3)

    def files():
        out = state_files(payload, res.state, title)
        if shape is not None:
            out["shape_fit.csv"] = _fit_table(res, length)
        return out
    emit(args, res, files, lambda r: summary(r, length), payload=payload)
    if res.success:
        return EXIT_OK
    return EXIT_UNREACHABLE if res.status == "unreachable" else EXIT_NOT_VERIFIED


def _summary(res, length: float) -> str:
    mm = lambda v: f"{v * length * 1e3:.6g} mm"
    amps = ", ".join(f"{i:.6g} A" for i in res.currents) if res.currents else "none"
    limits = ", ".join(f"{i:.4g} A" for i in res.max_current)
    if not res.currents:  # no design: what failed, and nothing else
        return "\n".join(["actuator-design: coil currents for a tip position",
                          f"  note        : {res.message}", f"  RESULT      : {res.status.upper()}"])
    effort = (f"power {res.power:.6g} W" if res.effort == "power" else
              f"sum of squared currents {sum(i * i for i in res.currents):.6g} A^2")
    lines = ["actuator-design: coil currents for a tip position"]
    if res.target:
        lines.append(f"  target      : x = {res.target[0]:.6g}, y = {res.target[1]:.6g} rod lengths "
                     f"({mm(res.target[0])}, {mm(res.target[1])})")
    lines += [f"  currents    : {amps}  (limits {limits}; started from "
             + ", ".join(f"{i:.4g} A" for i in res.start_currents) + ")",
             f"  effort      : {effort}" + ("  (least found)" if res.least_effort else ""),
             f"  field       : mu0 H = {res.field_at_clamp[0] * 1e3:.6g} mT at the clamp, at "
             f"{math.degrees(res.field_at_clamp[1]):.4g} deg; at most {res.max_rod_field * 1e3:.6g} mT on the rod"]
    axes = f"{res.tolerances.describe()}; currents each, the mount by the angle" if res.tolerances else ""
    return "\n".join(lines + tail_lines(res, length, axes))


def _stiffness_summary(res, length: float, scale: float, summary) -> str:
    """The summary of a design for a stiffness: the tip design's (``summary``), with the stiffness
    in B0/l^3 and N/m."""
    n_per_m = lambda k: f"{k:.6g} B0/l^3 = {k * scale:.6g} N/m"
    lines = summary(res, length).splitlines()
    lines[0] = lines[0].replace("a tip position", "a tip position and stiffness" if res.target else "a tip stiffness")
    if not math.isfinite(res.tip[0]):  # no design: what failed, and nothing else
        return "\n".join(lines)
    if not res.target:  # a stiffness alone: the tip has no target to miss, the verification's is the design's tip
        lines = [line.replace("(miss nan; ", "(").replace("worst tip miss", "the tip moves by at most")
                 .replace("from rest: miss", "from rest: tip off the design's by") for line in lines]
    v = res.verification.get("stiffness", math.nan)
    extra = [f"  stiffness   : target {n_per_m(res.stiffness_target)}; achieved {n_per_m(res.achieved_stiffness)}"
             + (f"; verified by differences {n_per_m(v)}" if math.isfinite(v) else "")]
    if res.box:
        extra.append(f"  over box    : stiffness off by at most {res.worst_stiffness_error:.3g} relative")
    at = next(k for k, line in enumerate(lines) if line.startswith("  field "))
    return "\n".join(lines[:at + 1] + extra + lines[at + 1:])


def _shape_summary(res, length: float) -> str:
    mm = lambda v: f"{v * length * 1e3:.6g} mm"
    if not res.currents:
        return "\n".join(["actuator-design: coil currents for a target shape",
                          f"  note        : {res.message}", f"  RESULT      : {res.status.upper()}"])
    amps = ", ".join(f"{i:.6g} A" for i in res.currents)
    limits = ", ".join(f"{i:.4g} A" for i in res.max_current)
    lines = ["actuator-design: coil currents for a target shape",
             f"  points      : {len(res.points)} (s, x, y) along the centreline",
             f"  currents    : {amps}  (limits {limits}; started from "
             + ", ".join(f"{i:.4g} A" for i in res.start_currents) + ")",
             f"  field       : mu0 H = {res.field_at_clamp[0] * 1e3:.6g} mT at the clamp, at "
             f"{math.degrees(res.field_at_clamp[1]):.4g} deg; at most {res.max_rod_field * 1e3:.6g} mT on the rod",
             f"  fit         : rms error {res.rms_error:.3e} ({mm(res.rms_error)}), largest {res.max_error:.3e} "
             f"rod lengths ({mm(res.max_error)}); accepted up to {res.accept_tol:g} rms"]
    axes = f"{res.tolerances.describe()}; currents each, the mount by the angle" if res.tolerances else ""
    tail = [line for line in tail_lines(res, length, axes) if not line.startswith("  achieved")]
    return "\n".join(lines + [line.replace("worst tip miss", "worst miss at a point") for line in tail])


def _fit_table(res, length: float) -> str:
    """shape_fit.csv: each point's target and fit, in rod lengths and mm."""
    rows = ["# units: s, x, y in rod lengths; *_mm in mm",
            "s,x_target,y_target,x_fitted,y_fitted,x_target_mm,y_target_mm,x_fitted_mm,y_fitted_mm"]
    for (s, x, y), (fx, fy) in zip(res.points, res.fitted):
        vals = [float(s), float(x), float(y), float(fx), float(fy)]
        rows.append(",".join(repr(v) for v in vals + [v * length * 1e3 for v in vals[1:]]))
    return "\n".join(rows) + "\n"


def tail_lines(res, length: float, box_axes: str) -> list:
    """The lines a design over hardware ends with: the tip achieved, the verification, the box (its
    axes named by ``box_axes``), the limits at work, the note, the time and the verdict."""
    mm = lambda v: f"{v * length * 1e3:.6g} mm"
    lines = []
    if math.isfinite(res.tip[0]):
        lines.append(f"  achieved    : x = {res.tip[0]:.10g}, y = {res.tip[1]:.10g} rod lengths "
                     f"(miss {res.tip_error:.2g}; {mm(res.tip[0])}, {mm(res.tip[1])})")
    if res.verification:
        v = res.verification
        lines.append(f"  verified    : {res.verified} (refitted field, from rest: miss {v['error']:.2g}, "
                     f"stable {v['stable']})")
    if res.box:
        lines.append(f"  robustness  : {len(res.box)} corners ({box_axes}): worst tip miss {res.worst_tip_error:.3g} "
                     f"rod lengths ({mm(res.worst_tip_error)}); on the designed branch at every corner: "
                     f"{res.holds_over_box}")
    if res.limits_active:
        lines.append(f"  limits      : at {', '.join(res.limits_active)}")
    return lines + [f"  note        : {res.message}", f"  time        : {res.seconds:.2f} s ({res.solves} solves)",
                    f"  RESULT      : {'SUCCESS' if res.success else res.status.upper()}"]
