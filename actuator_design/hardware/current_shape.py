"""Coil currents for a target shape (issue 19 item 2 beyond the tip): the currents within each
driver's limit whose rod, loaded from rest, passes nearest the points (s_i, x_i, y_i), in least
squares (the fit of :mod:`actuator_design.hardware.shape_fit`), within the limits of the tip design
(|I_k| ≤ I_max,k; Σ R_k I_k² ≤ P_max; |μ0 H| ≤ B_max on the rod), on the forward map over the coil
weights w (:class:`~actuator_design.hardware.current_map.CurrentMap`, I_k = w_k × the configured
current). With more coils than the points fix, the least power among the fits as good. Verified on
magpylib's field refitted at the currents and judged over the lab's tolerance box (each current
±5 %, the mount ±2°: the tip design's corners), as the tip design is
(:mod:`actuator_design.hardware.current_design`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Optional

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.hardware.current_design import (CurrentDesign, _corners, _even, _screen, coil_problem,
                                                     current_map, effort_notes, first_coil_positive, record_setting,
                                                     scene_at_currents)
from actuator_design.hardware.current_map import at_weights
from actuator_design.hardware.shape_fit import (ACCEPT_TOL, ShapeFit, ShapeMap, best_fit, check_points, corner_fit,
                                                fit_message, judge_fit, least_effort_fit, record_fit, verify_points)
from actuator_design.model.scene import Scene
from actuator_design.robust.tolerances import Tolerances, apply_deltas

__all__ = ["design_current_shape", "CurrentShapeDesign"]


@dataclass(repr=False)
class CurrentShapeDesign(CurrentDesign, ShapeFit):
    """The result of :func:`design_current_shape`: a coil design's attributes (currents in A,
    :class:`~actuator_design.hardware.current_design.CurrentDesign`) and the fit's
    (:class:`~actuator_design.hardware.shape_fit.ShapeFit`). ``effort`` names what was minimised:
    ``"fit"``, or the power (``"power"``, ``"current_squared"``) when more coils than the points fix
    left a family of fits to choose from."""

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``design --target-shape`` on a coil scene (the keys of
        a coil design, and ``shape``)."""
        return {**super().to_dict(), "shape": self.shape_dict()}


def design_current_shape(scene: Scene, points, *, tolerances: Optional[Tolerances] = None,
                         options: Optional[SolverOptions] = None, verify: bool = True,
                         accept_tol: float = ACCEPT_TOL,
                         progress: Optional[Callable[[str], None]] = None) -> CurrentShapeDesign:
    """The coil currents whose rod passes nearest ``points`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene with a coil field (the configured currents start the design).
    points : array_like, shape (k, 3)
        s ∈ (0, 1], x, y (rod lengths) of each target point
        (:func:`~actuator_design.inverse.shape.read_shape_points` reads them from a CSV).
    tolerances : Tolerances, optional
        The lab's tolerance box (default ±5 % on each current, ±2° on the mount).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solve from rest (a design without it is not a success).
    accept_tol : float
        The rms fit a success needs (rod lengths).

    Returns
    -------
    CurrentShapeDesign
        Never raises for a shape out of reach (``status="unreachable"``); raises ValueError for
        points that are not (s, x, y) rows, a scene without coils or a coil without a current limit.
    """
    t0 = time.perf_counter()
    pts = check_points(points, accept_tol, "currents")
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    tip_prob = coil_problem(scene, pts[-1, 1:])  # the screen ranks its starts by the last point
    prob = replace(tip_prob, target=np.concatenate([pts[:, 1], pts[:, 2]]))
    coils = scene.field.sources
    i0 = np.array([c.current for c in coils])
    out = CurrentShapeDesign(success=False, status="not_converged", message="", target=tuple(pts[-1, 1:].tolist()),
                             coils=tuple(getattr(c, "name", "") or f"coil {j + 1}" for j, c in enumerate(coils)),
                             start_currents=tuple(i0.tolist()), max_current=tuple(c.max_current for c in coils),
                             resistance=tuple(c.resistance for c in coils), tolerances=tol, points=pts,
                             accept_tol=accept_tol, effort="fit")
    cmap, out.message = current_map(scene, options)
    if cmap is None:
        return out
    smap = ShapeMap(cmap, pts[:, 0])
    best = best_fit(prob, smap, _screen(cmap, tip_prob, _even(scene), progress), accept_tol)
    if best is None:
        out.message = ("no start currents within the limits gave a stable state from rest (the configured "
                       "currents and the screen's ramps)")
        return out
    w, pt, out.iterations, settled = best
    w, pt, out.iterations, out.least_effort, descended = least_effort_fit(prob, smap, w, pt, out.iterations,
                                                                          accept_tol, progress)
    if descended:  # (only then was an effort minimised)
        out.effort = "power" if prob.power is not None else "current_squared"
        out.notes += effort_notes(coils)
    w, pt = first_coil_positive(scene, w, pt, i0, smap.evaluate)
    record_setting(out, scene, cmap, prob, w, pt, i0)
    record_fit(out, pt)
    if verify:
        verify_points(out, scene_at_currents(scene, w * i0), options)
    k = len(pts)
    out.box = _box(smap, w, out.state, tol, pts, pt["tip_jac"][[k - 1, 2 * k - 1]], i0)
    judge_fit(out, prob, w, pt, settled)
    out.solves, out.seconds = cmap.solves, time.perf_counter() - t0
    out.message = fit_message(out, "currents " + ", ".join(f"{i:.6g} A" for i in out.currents),
                              "setting of the currents within the limits")
    return out


def _box(smap: ShapeMap, w, state, tol: Tolerances, pts: np.ndarray, last_jac: np.ndarray, currents0) -> list:
    """Every corner of the tip design's box switched on from rest: its fit
    (:func:`~actuator_design.hardware.shape_fit.corner_fit`), ``success`` (reached), ``stable``,
    ``same_branch``."""
    cmap, out = smap.hmap, []
    for signs, mount, deltas in _corners(tol, w, last_jac, 2):
        wc = w * (1 + tol.field_rel * signs)
        sc = apply_deltas(at_weights(cmap.scene, wc), deltas) if deltas else at_weights(cmap.scene, wc)
        sc = replace(sc, theta0=sc.theta0 + mount)
        c = cmap.corner(sc, state.z)
        tip = c["tip"]
        out.append({"currents_A": list(wc * currents0), "mount_deg": math.degrees(mount), **deltas,
                    "tip": {"x": tip[0], "y": tip[1], "angle": tip[2]}, **corner_fit(smap, c, pts),
                    "success": c["reached"], "stable": c["stable"], "same_branch": c["same_branch"]})
    return out
