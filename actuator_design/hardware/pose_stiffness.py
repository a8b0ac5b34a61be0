"""A magnet's pose for a tip stiffness (issue 19 item 2: a stiffness target in real fields): where to
put the magnet, within its stage's travel, so that the rod loaded from rest has the vertical tip
stiffness K = dp/dv1 asked for, with the tip on a target too if one is given.

The pose design (:mod:`actuator_design.hardware.pose_design`) with one more equation: the SQP meets
log(c·K_target) = 0 (c the compliance, exact with its derivative in the pose:
:class:`~actuator_design.hardware.stiffness_map.StiffnessMap`) beside the tip's coordinates, within
the travel and clear of the magnet, with the least move from the configured pose. Verified on
magpylib's field refitted at the pose (the tip from rest to 1e-6, the stiffness by central
differences of two independent solves to ``accept_tol`` relative); judged over the pose design's
box (position, axis, remanence, mount), each corner's stiffness reported.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Optional

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.hardware.design import judge, run_starts
from actuator_design.hardware.pose_design import (POSITION_TOLERANCE, PoseDesign, _active, _band, _better,
                                                  _field_report, _screen, _travel_dict, corner_states, pose_map)
from actuator_design.hardware.pose_problem import check_position_tolerance, pose_problem, scene_at_pose
from actuator_design.hardware.stiffness_map import (ACCEPT_TOL, AT_TARGET, StiffnessFit, StiffnessMap, check_stiffness,
                                                    stiffness_message, stiffness_missed, verify_stiffness)
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.robust.tolerances import Tolerances

__all__ = ["design_pose_stiffness", "PoseStiffnessDesign"]


@dataclass(repr=False)
class PoseStiffnessDesign(PoseDesign, StiffnessFit):
    """The result of :func:`design_pose_stiffness`: a pose design's attributes
    (:class:`~actuator_design.hardware.pose_design.PoseDesign`; ``target`` the tip's targeted
    coordinates, empty for a stiffness alone) and the stiffness's
    (:class:`~actuator_design.hardware.stiffness_map.StiffnessFit`)."""

    def to_dict(self) -> dict:
        """Plain data: the keys of a pose design and ``stiffness``."""
        return {**super().to_dict(), "stiffness": self.stiffness_dict()}


def design_pose_stiffness(scene: Scene, stiffness: float, target=None, *, tolerances: Optional[Tolerances] = None,
                          position_tolerance: float = POSITION_TOLERANCE, options: Optional[SolverOptions] = None,
                          verify: bool = True, accept_tol: float = ACCEPT_TOL,
                          progress: Optional[Callable[[str], None]] = None) -> PoseStiffnessDesign:
    """The magnet pose nearest the configured one, within its travel, that gives the tip stiffness
    ``stiffness`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene whose field has one magnet with a ``travel`` (the configured pose starts); a
        vertical tip load term is added at zero load if absent (the stiffness is at the scene's load).
    stiffness : float
        Target K = dp/dv1, units of B0/ℓ³ (× ``scene.scales.stiffness`` in N/m), > 0.
    target : sequence of 2 or 3 floats, optional
        Tip x, y in rod lengths (and angle in rad) to meet as well.
    tolerances : Tolerances, optional
        The lab's box: ``field_rel`` on the remanence, ``angle`` on the magnet's axis (default ±5 %,
        ±2°), and E, χ̄, fibres, clamp as given.
    position_tolerance : float
        Half-width of the magnet's position error in x and y, m (default 0.5 mm; 0: none).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solves from rest (a design without it is not a success).
    accept_tol : float
        The verified stiffness's relative tolerance of a success.

    Returns
    -------
    PoseStiffnessDesign
        Never raises for a stiffness out of reach (``status="unreachable"``); raises ValueError for a
        stiffness that is not a finite number > 0, a target that is not x, y[, angle] or a scene
        without a moving magnet.
    """
    t0 = time.perf_counter()
    tip_target = check_stiffness(stiffness, target, accept_tol)
    check_position_tolerance(scene, position_tolerance)
    scene = lens.parameter("p").require(scene)
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    var, tip_prob = pose_problem(scene, tip_target if tip_target.size else [math.nan, math.nan])
    prob = replace(tip_prob, target=np.concatenate([tip_target, [AT_TARGET]]))
    magnet = scene.field.sources[var.source]
    out = PoseStiffnessDesign(success=False, status="not_converged", message="", target=tuple(tip_target.tolist()),
                              start_position=tuple(magnet.position), start_axis_angle=magnet.axis_angle,
                              travel=_travel_dict(magnet), tolerances=tol, position_tolerance=float(position_tolerance),
                              stiffness_target=float(stiffness), accept_tol=accept_tol)
    pmap, out.message = pose_map(scene, var, options)
    if pmap is None:
        return out
    smap = StiffnessMap(pmap, stiffness, tip_target.size)
    starts = _screen(pmap, tip_prob, var.coords, progress, miss=None if tip_target.size else smap.miss)
    sqp = run_starts(smap, prob, starts, lambda a, b: _better(prob, a, b), progress, restore_first=True)
    if sqp is None:
        out.message = "no start pose within the travel gave a stable state from rest clear of the magnet"
        return out
    v, pt = sqp.w, sqp.point
    out.position, out.axis_angle = var.pose(magnet, v)
    out.move = float(np.dot(prob.cost, v * v))
    out.state, out.tip = pmap.result(v, pt["z"]), pt["tip_point"]
    out.achieved_stiffness = float(pt["stiffness"])
    out.tip_error = (float(np.max(np.abs(pt["tip_point"][:tip_target.size] - tip_target))) if tip_target.size
                     else math.nan)  # a stiffness alone: no tip target to miss
    out.iterations, out.least_move = sqp.iterations, bool(sqp.converged)
    out.field_at_clamp, out.max_rod_field = _field_report(pmap.at(scene, v), out.state)
    out.limits_active = _active(var, prob, v, pt)
    if not sqp.reached:
        stiffness_missed(out, sqp, "pose within the travel",
                         _band(pt["tip_jac"][:2] * prob.half) if tip_target.size else "")
        out.solves, out.seconds = pmap.solves, time.perf_counter() - t0
        return out
    if verify:
        verify_stiffness(out, scene_at_pose(scene, out.position, out.axis_angle), options, tip_target, accept_tol)
    ref = tip_target if tip_target.size else np.asarray(out.tip, float)[:2]
    judge(out, [{"offsets": offsets, "tip": {"x": c["tip"][0], "y": c["tip"][1], "angle": c["tip"][2]},
                 "tip_error": float(np.max(np.abs(c["tip"][:ref.size] - ref))),
                 **smap.corner_stiffness(c, offsets),
                 "success": c["reached"], "stable": c["stable"], "same_branch": c["same_branch"],
                 **({"region": c["region"]} if "region" in c else {})}
                for offsets, c in corner_states(pmap, var, v, out.state, tol, position_tolerance)])
    out.record_box_stiffness()
    out.solves, out.seconds = pmap.solves, time.perf_counter() - t0
    out.message = stiffness_message(out, f"the magnet at ({out.position[0] * 1e3:.6g}, {out.position[1] * 1e3:.6g}) "
                                         f"mm, axis at {math.degrees(out.axis_angle):.6g} deg")
    return out
