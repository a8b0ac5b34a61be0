"""A magnet's pose for a target shape (issue 19 item 2 beyond the tip): where to put the magnet on its
stage, within the travel, so that the rod, loaded from rest, passes nearest the points
(s_i, x_i, y_i), in least squares (the fit of :mod:`actuator_design.hardware.shape_fit`), the rod
kept outside every source's fitted region, on the forward map over the pose offsets
(:class:`~actuator_design.hardware.map.HardwareMap` with the pose design's variables,
:mod:`actuator_design.hardware.pose_problem`). With more moving coordinates than the points fix (one
point, the magnet free in x, y and angle), the least move among the fits as good. Verified on
magpylib's field refitted at the pose and judged over the pose design's box (position, axis,
remanence, mount: :func:`~actuator_design.hardware.pose_design.corner_states`), as the tip design
is (:mod:`actuator_design.hardware.pose_design`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Optional

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.hardware.pose_design import (POSITION_TOLERANCE, PoseDesign, _active, _field_report, _screen,
                                                  _travel_dict, corner_states, pose_map)
from actuator_design.hardware.pose_problem import check_position_tolerance, pose_problem, scene_at_pose
from actuator_design.hardware.shape_fit import (ACCEPT_TOL, ShapeFit, ShapeMap, best_fit, check_points, corner_fit,
                                                fit_message, judge_fit, least_effort_fit, record_fit, verify_points)
from actuator_design.model.scene import Scene
from actuator_design.robust.tolerances import Tolerances

__all__ = ["design_pose_shape", "PoseShapeDesign"]


@dataclass(repr=False)
class PoseShapeDesign(PoseDesign, ShapeFit):
    """The result of :func:`design_pose_shape`: a pose design's attributes (positions in m, angles
    in rad, :class:`~actuator_design.hardware.pose_design.PoseDesign`) and the fit's
    (:class:`~actuator_design.hardware.shape_fit.ShapeFit`); ``least_move`` says whether the least
    move among equally good fits was settled (only where the pose has more freedom than the points fix)."""

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``design --target-shape`` on a scene with a moving magnet
        (the keys of a pose design, and ``shape``)."""
        return {**super().to_dict(), "shape": self.shape_dict()}


def design_pose_shape(scene: Scene, points, *, tolerances: Optional[Tolerances] = None,
                      position_tolerance: float = POSITION_TOLERANCE, options: Optional[SolverOptions] = None,
                      verify: bool = True, accept_tol: float = ACCEPT_TOL,
                      progress: Optional[Callable[[str], None]] = None) -> PoseShapeDesign:
    """The magnet pose within its travel whose rod passes nearest ``points`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene whose field has one magnet with a ``travel`` (the configured pose starts).
    points : array_like, shape (k, 3)
        s ∈ (0, 1], x, y (rod lengths) of each target point.
    tolerances : Tolerances, optional
        The lab's box: ``field_rel`` on the remanence, ``angle`` on the magnet's axis (default ±5 %,
        ±2°), and E, χ̄, fibres, clamp as given.
    position_tolerance : float
        Half-width of the magnet's position error in x and y, m (default 0.5 mm; 0: none).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solve from rest (a design without it is not a success).
    accept_tol : float
        The rms fit a success needs (rod lengths).

    Returns
    -------
    PoseShapeDesign
        Never raises for a shape out of reach; raises ValueError for points that are not (s, x, y)
        rows or a scene without a moving magnet.
    """
    t0 = time.perf_counter()
    pts = check_points(points, accept_tol, "a magnet's pose")
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    check_position_tolerance(scene, position_tolerance)
    var, tip_prob = pose_problem(scene, pts[-1, 1:])  # the screen ranks its starts by the last point
    prob = replace(tip_prob, target=np.concatenate([pts[:, 1], pts[:, 2]]))
    magnet = scene.field.sources[var.source]
    out = PoseShapeDesign(success=False, status="not_converged", message="", target=tuple(pts[-1, 1:].tolist()),
                          start_position=tuple(magnet.position), start_axis_angle=magnet.axis_angle,
                          travel=_travel_dict(magnet), tolerances=tol, position_tolerance=float(position_tolerance),
                          points=pts, accept_tol=accept_tol)
    pmap, out.message = pose_map(scene, var, options)
    if pmap is None:
        return out
    at = pmap.at
    smap = ShapeMap(pmap, pts[:, 0])
    best = best_fit(prob, smap, _screen(pmap, tip_prob, var.coords, progress), accept_tol)
    if best is None:
        out.message = "no start pose within the travel gave a stable state from rest clear of the magnet"
        return out
    v, pt, out.iterations, settled = best
    v, pt, out.iterations, out.least_move, _ = least_effort_fit(prob, smap, v, pt, out.iterations, accept_tol,
                                                                progress)
    out.position, out.axis_angle = var.pose(magnet, v)
    out.move = float(np.dot(prob.cost, v * v))
    out.state, out.tip = pmap.result(v, pt["z"]), pt["tip_point"]
    record_fit(out, pt)
    out.field_at_clamp, out.max_rod_field = _field_report(at(scene, v), out.state)
    out.limits_active = _active(var, prob, v, pt)
    if verify:
        verify_points(out, scene_at_pose(scene, out.position, out.axis_angle), options)
    out.box = [{"offsets": offsets, "tip": {"x": c["tip"][0], "y": c["tip"][1], "angle": c["tip"][2]},
                **corner_fit(smap, c, pts), "success": c["reached"], "stable": c["stable"],
                "same_branch": c["same_branch"], **({"region": c["region"]} if "region" in c else {})}
               for offsets, c in corner_states(pmap, var, v, out.state, tol, position_tolerance)]
    judge_fit(out, prob, v, pt, settled)
    out.solves, out.seconds = pmap.solves, time.perf_counter() - t0
    out.message = fit_message(out, f"the magnet at ({out.position[0] * 1e3:.6g}, {out.position[1] * 1e3:.6g}) mm, "
                                   f"axis at {math.degrees(out.axis_angle):.6g} deg",
                              "pose within the travel")
    return out
