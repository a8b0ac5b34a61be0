"""Coil currents for a tip stiffness (issue 19 item 2: a stiffness target in real fields): the
least-power currents within each driver's limit whose rod, loaded from rest, has the vertical tip
stiffness K = dp/dv1 asked for, with the tip on a target too if one is given.

The tip design (:mod:`actuator_design.hardware.current_design`) with one more equation: the SQP of
:mod:`actuator_design.hardware.current_sqp` meets log(c·K_target) = 0 (c the compliance, exact with its
derivative in the currents: :class:`~actuator_design.hardware.stiffness_map.StiffnessMap`) beside
the tip's coordinates, within the same limits (|I_k| ≤ I_max,k; Σ R_k I_k² ≤ P_max; |μ0 H| ≤ B_max
on the rod), spending the least power. A stiffness alone leaves a family of currents (one equation):
the least power among them. Verified on magpylib's field refitted at the currents: the tip from rest
(to 1e-6) and the stiffness by central differences of two independent solves (to ``accept_tol``
relative); judged over the lab's tolerance box as the tip design is, each corner's stiffness
reported.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Optional

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.hardware.current_design import (CurrentDesign, _better, _corners, _even, _screen, coil_problem,
                                                     current_map, effort_notes, first_coil_positive, record_setting,
                                                     scene_at_currents)
from actuator_design.hardware.current_map import at_weights
from actuator_design.hardware.design import judge, run_starts
from actuator_design.hardware.stiffness_map import (ACCEPT_TOL, AT_TARGET, StiffnessFit, StiffnessMap, check_stiffness, stiffness_message,
                                                    stiffness_missed, verify_stiffness)
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.robust.tolerances import Tolerances, apply_deltas

__all__ = ["design_current_stiffness", "CurrentStiffnessDesign"]


@dataclass(repr=False)
class CurrentStiffnessDesign(CurrentDesign, StiffnessFit):
    """The result of :func:`design_current_stiffness`: a coil design's attributes
    (:class:`~actuator_design.hardware.current_design.CurrentDesign`; ``target`` the tip's targeted
    coordinates, empty for a stiffness alone) and the stiffness's
    (:class:`~actuator_design.hardware.stiffness_map.StiffnessFit`)."""

    def to_dict(self) -> dict:
        """Plain data: the keys of a coil design and ``stiffness``."""
        return {**super().to_dict(), "stiffness": self.stiffness_dict()}


def design_current_stiffness(scene: Scene, stiffness: float, target=None, *, tolerances: Optional[Tolerances] = None,
                             options: Optional[SolverOptions] = None, verify: bool = True,
                             accept_tol: float = ACCEPT_TOL,
                             progress: Optional[Callable[[str], None]] = None) -> CurrentStiffnessDesign:
    """The least-power coil currents that give the tip stiffness ``stiffness`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene with a coil field (the configured currents start the design); a vertical tip
        load term is added at zero load if absent (the stiffness is at the scene's load).
    stiffness : float
        Target K = dp/dv1, units of B0/ℓ³ (× ``scene.scales.stiffness`` in N/m), > 0.
    target : sequence of 2 or 3 floats, optional
        Tip x, y in rod lengths (and angle in rad) to meet as well.
    tolerances : Tolerances, optional
        The lab's tolerance box (default ±5 % on each current, ±2° on the mount).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solves from rest (a design without it is not a success).
    accept_tol : float
        The verified stiffness's relative tolerance of a success.

    Returns
    -------
    CurrentStiffnessDesign
        Never raises for a stiffness out of reach (``status="unreachable"``); raises ValueError for a
        stiffness that is not a finite number > 0, a target that is not x, y[, angle], a scene
        without coils or a coil without a current limit.
    """
    t0 = time.perf_counter()
    tip_target = check_stiffness(stiffness, target, accept_tol)
    scene = lens.parameter("p").require(scene)
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    tip_prob = coil_problem(scene, tip_target if tip_target.size else [math.nan, math.nan])
    prob = replace(tip_prob, target=np.concatenate([tip_target, [AT_TARGET]]))
    coils = scene.field.sources
    i0 = np.array([c.current for c in coils])
    out = CurrentStiffnessDesign(
        success=False, status="not_converged", message="", target=tuple(tip_target.tolist()),
        coils=tuple(getattr(c, "name", "") or f"coil {k + 1}" for k, c in enumerate(coils)),
        start_currents=tuple(i0.tolist()), max_current=tuple(c.max_current for c in coils),
        resistance=tuple(c.resistance for c in coils), tolerances=tol,
        effort="power" if prob.power is not None else "current_squared",
        stiffness_target=float(stiffness), accept_tol=accept_tol)
    out.notes += effort_notes(coils)
    cmap, out.message = current_map(scene, options)
    if cmap is None:
        return out
    smap = StiffnessMap(cmap, stiffness, tip_target.size)
    # the starts: nearest the tip where one is targeted (the stiffness is then sought near it), else
    # nearest the stiffness
    starts = _screen(cmap, tip_prob, _even(scene), progress, miss=None if tip_target.size else smap.miss)
    sqp = run_starts(smap, prob, starts, lambda a, b: _better(prob, a, b), progress)
    if sqp is None:
        out.message = ("no start currents within the limits gave a stable state from rest (the configured "
                       "currents and the screen's ramps)")
        return out
    w, pt = first_coil_positive(scene, sqp.w, sqp.point, i0, smap.evaluate)
    record_setting(out, scene, cmap, prob, w, pt, i0)
    out.achieved_stiffness = float(pt["stiffness"])
    out.tip_error = (float(np.max(np.abs(pt["tip_point"][:tip_target.size] - tip_target))) if tip_target.size
                     else math.nan)  # a stiffness alone: no tip target to miss
    out.iterations, out.least_effort = sqp.iterations, bool(sqp.converged)
    if not sqp.reached:
        stiffness_missed(out, sqp, "setting of the currents within the limits")
        out.solves, out.seconds = cmap.solves, time.perf_counter() - t0
        return out
    if verify:
        verify_stiffness(out, scene_at_currents(scene, w * i0), options, tip_target, accept_tol)
    judge(out, _box(smap, w, out, tol, tip_target, pt["tip_jac"], i0))
    out.record_box_stiffness()
    out.solves, out.seconds = cmap.solves, time.perf_counter() - t0
    out.message = stiffness_message(out, "currents " + ", ".join(f"{i:.6g} A" for i in out.currents))
    return out


def _box(smap: StiffnessMap, w: np.ndarray, out: CurrentStiffnessDesign, tol: Tolerances, tip_target: np.ndarray,
         jac: np.ndarray, currents0: np.ndarray) -> list:
    """Every corner of the tip design's box (the currents' linearised worst corners taken for the
    targeted coordinates and the stiffness), switched on from rest: its tip and miss (of the target,
    or with none of the design's tip), its stiffness and |K/K_target − 1|."""
    cmap, corners = smap.hmap, []
    ref = tip_target if tip_target.size else np.asarray(out.tip, float)[:2]
    for signs, mount, deltas in _corners(tol, w, jac, jac.shape[0]):
        wc = w * (1 + tol.field_rel * signs)
        sc = apply_deltas(at_weights(cmap.scene, wc), deltas) if deltas else at_weights(cmap.scene, wc)
        sc = replace(sc, theta0=sc.theta0 + mount)
        c = cmap.corner(sc, out.state.z)
        tip = c["tip"]
        corners.append({"currents_A": list(wc * currents0), "mount_deg": math.degrees(mount), **deltas,
                        "tip": {"x": tip[0], "y": tip[1], "angle": tip[2]},
                        "tip_error": float(np.max(np.abs(tip[:ref.size] - ref))),
                        **smap.corner_stiffness(c, deltas),
                        "success": c["reached"], "stable": c["stable"], "same_branch": c["same_branch"]})
    return corners
