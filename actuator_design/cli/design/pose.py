"""``design --target-tip X,Y`` on a scene with a magnet on a stage (a magnet with a ``travel``): the
pose within the travel nearest the configured one that puts the tip on the target
(:func:`~actuator_design.hardware.pose_design.design_pose`), printed in mm, deg, mT and the rod's
length unit, and written as design.json, shape.csv and shape.png."""
from __future__ import annotations

import math

from actuator_design.cli.common import InputError, bad_input, stdout_to_stderr
from actuator_design.cli.design.currents import finish, finish_stiffness, progress_line, refuse_flags, tail_lines

__all__ = ["run_pose", "run_pose_shape", "run_pose_stiffness"]


def run_pose(args, scene, options, raw, target, vary, settings) -> int:
    """Design, print, write; exit 0 success, 3 not verified or not robust, 4 unreachable."""
    from actuator_design.hardware.pose_design import design_pose

    position_tolerance = _checked_request(args, scene, vary, target)
    with stdout_to_stderr(args.json):
        res = design_pose(scene, target, tolerances=settings.tolerances, position_tolerance=position_tolerance,
                          options=options, verify=not args.no_verify, progress=progress_line())
    return finish(args, res, scene.scales.length, _summary, "designed state (magnet pose)")


def run_pose_shape(args, scene, options, raw, vary, settings) -> int:
    """``design --target-shape`` on a scene with a moving magnet: the pose whose rod passes nearest
    the points (:func:`~actuator_design.hardware.pose_shape.design_pose_shape`); exit codes as for a tip."""
    from actuator_design.cli.design.shape import read_points
    from actuator_design.hardware.pose_shape import design_pose_shape

    refuse_flags(args, vary, "the magnet's pose (within its travel)", "the magnet's travel is its limit")
    pts = read_points(args.target_shape, args.target_units or "rod", scene)
    position_tolerance = _checked_request(args, scene, vary, pts[-1, 1:])
    with stdout_to_stderr(args.json):
        res = design_pose_shape(scene, pts, tolerances=settings.tolerances, position_tolerance=position_tolerance,
                                options=options, verify=not args.no_verify, accept_tol=settings.accept_tol,
                                progress=progress_line())
    return finish(args, res, scene.scales.length, _summary, "designed state (magnet pose)")


def run_pose_stiffness(args, scene, options, raw, target, vary, settings, stiffness) -> int:
    """``design --target-stiffness`` on a scene with a moving magnet (with or without
    ``--target-tip``): the pose with that tip stiffness
    (:func:`~actuator_design.hardware.pose_stiffness.design_pose_stiffness`); exit codes as for a tip."""
    from actuator_design.hardware.pose_stiffness import design_pose_stiffness

    position_tolerance = _checked_request(args, scene, vary, target if target is not None else (0.0, 0.0))
    with stdout_to_stderr(args.json):
        res = design_pose_stiffness(scene, stiffness, target, tolerances=settings.tolerances,
                                    position_tolerance=position_tolerance, options=options,
                                    verify=not args.no_verify, accept_tol=settings.accept_tol,
                                    progress=progress_line())
    return finish_stiffness(args, res, scene, _summary, "designed state (magnet pose)")


def _checked_request(args, scene, vary, target) -> float:
    """The flags refused, the scene and the position tolerance checked up front (what fails later
    is the design's, not the input's); the position tolerance, m."""
    from actuator_design.hardware.pose_design import POSITION_TOLERANCE, pose_problem
    from actuator_design.model.units import parse_quantity

    refuse_flags(args, vary, "the magnet's pose (within its travel)", "the magnet's travel is its limit")
    position_tolerance = POSITION_TOLERANCE
    if args.position_tolerance is not None:
        try:
            position_tolerance = parse_quantity(args.position_tolerance, "length", "--position-tolerance")
        except ValueError as exc:
            raise InputError(str(exc)) from None
    with bad_input():
        pose_problem(scene, target)
        if not (math.isfinite(position_tolerance) and 0.0 <= position_tolerance <= 0.1 * scene.field.length):
            raise ValueError(f"--position-tolerance: must be in [0, {0.1 * scene.field.length * 1e3:g} mm] (a tenth "
                             f"of the rod), got {position_tolerance * 1e3:g} mm")
    return position_tolerance


def _summary(res, length: float) -> str:
    mm = lambda v: f"{v * length * 1e3:.6g} mm"
    shape = hasattr(res, "points")
    head = f"actuator-design: a magnet's pose for a {'target shape' if shape else 'tip position'}"
    if not math.isfinite(res.position[0]):  # no design: what failed, and nothing else
        return "\n".join([head, f"  note        : {res.message}", f"  RESULT      : {res.status.upper()}"])
    travel = ", ".join(f"{k.rsplit('_', 1)[0]} {v[0]:.6g} to {v[1]:.6g} {k.rsplit('_', 1)[1]}"
                       for k, v in res.travel.items())
    target = (f"  points      : {len(res.points)} (s, x, y) along the centreline" if shape else
              f"  target      : x = {res.target[0]:.6g}, y = {res.target[1]:.6g} rod lengths "
              f"({mm(res.target[0])}, {mm(res.target[1])})" if res.target else "")
    lines = [head] + [target] * bool(target) + [
             f"  magnet      : at ({res.position[0] * 1e3:.6g}, {res.position[1] * 1e3:.6g}) mm, axis "
             f"{math.degrees(res.axis_angle):.6g} deg  (started from ({res.start_position[0] * 1e3:.6g}, "
             f"{res.start_position[1] * 1e3:.6g}) mm, {math.degrees(res.start_axis_angle):.6g} deg; travel {travel})",
             f"  move        : {res.move:.6g} (each coordinate's move over its half travel, squared and summed)"
             + ("  (least found)" if res.least_move else ""),
             f"  field       : mu0 H = {res.field_at_clamp[0] * 1e3:.6g} mT at the clamp, at "
             f"{math.degrees(res.field_at_clamp[1]):.4g} deg; at most {res.max_rod_field * 1e3:.6g} mT on the rod"]
    axes = (f"position ±{res.position_tolerance * 1e3:g} mm, axis ±{math.degrees(res.tolerances.angle):g} deg, "
            f"remanence ±{100 * res.tolerances.field_rel:g} %{_others(res.tolerances)}") if res.tolerances else ""
    if shape:
        lines.append(f"  fit         : rms error {res.rms_error:.3e} ({mm(res.rms_error)}), largest {res.max_error:.3e} "
                     f"rod lengths ({mm(res.max_error)}); accepted up to {res.accept_tol:g} rms")
        tail = [line.replace("worst tip miss", "worst miss at a point") for line in tail_lines(res, length, axes)
                if not line.startswith("  achieved")]
        return "\n".join(lines + tail)
    return "\n".join(lines + tail_lines(res, length, axes))


def _others(tol) -> str:
    from actuator_design.robust.tolerances import Tolerances

    rest = Tolerances(field_rel=0.0, angle=0.0, youngs_rel=tol.youngs_rel, chi_rel=tol.chi_rel,
                      fibre_angle=tol.fibre_angle, clamp_angle=tol.clamp_angle)
    return "" if not rest.active else ", " + rest.describe()
