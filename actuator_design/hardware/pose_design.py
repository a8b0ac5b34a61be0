"""A permanent magnet's pose as the design: where to put the magnet (position, m; axis angle, rad),
within its stage's travel, so that the tip of the rod, loaded from rest, lands on a target (issue 19
item 2).

The scene's field comes from sources (``field: {type: magnet}``) and one magnet has a ``travel``
(each of x, y, axis angle a range; a coordinate without one is held). Its fitted field is moved
rigidly (``SourceField.placements``: NLP parameters, one solver for every pose), and the design:

1. screens a grid over the travel (each pose's state reached from rest), and starts from the
   configured pose and the two poses nearest the target;
2. moves the pose by the trust-region SQP of the current design (:mod:`actuator_design.hardware.current_sqp`) on the forward
   map (:class:`~actuator_design.hardware.map.HardwareMap`, exact implicit derivatives) to the pose nearest the
   configured one — each coordinate's move as a fraction of its half travel, squared and summed —
   that meets the target to ``tip_tol``, with the rod kept outside every source's fitted region
   (the sphere about the magnet where its field is not represented holds the magnet itself);
3. is **verified** independently: magpylib's field of the magnet at the designed pose is fitted
   anew (a fixed magnet's fit, its own H0 and groups), and ``solve`` loads that scene from rest;
4. is **judged over the lab's tolerances**: the magnet's position off by ±``position_tolerance`` in
   x and y, its axis by ±``tolerances.angle``, its remanence by ±``tolerances.field_rel`` (and E,
   χ̄, the fibres, the clamp as given), every corner switched on from rest and landing on the
   designed branch, stable.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, List, Optional, Tuple

import numpy as np

from actuator_design import forked
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.hardware.current_sqp import CurrentProblem, within_limits
from actuator_design.hardware.design import HardwareDesign, judge, run_starts
from actuator_design.hardware.design import verify as verify_on
from actuator_design.hardware.map import HardwareMap
from actuator_design.hardware.pose_problem import (COORDS, TIP_TOL, PoseVariables, at_pose, check_position_tolerance,
                                                   clearance, pose_problem, scene_at_pose)
from actuator_design.model.field_sources import MagnetSource
from actuator_design.model.scene import Scene
from actuator_design.model.units import MU0
from actuator_design.physics.fields import field_model
from actuator_design.robust.tolerances import Tolerances, apply_deltas

__all__ = ["design_pose", "PoseDesign", "PoseVariables", "pose_problem", "scene_at_pose", "corner_states",
           "pose_map", "POSITION_TOLERANCE"]

#: the default half-width of the magnet's position error (m): a stage placed by hand or a printed jig
POSITION_TOLERANCE = 0.5e-3
#: screening levels per coordinate, by the number of coordinates that move
SCREEN_LEVELS = {1: 9, 2: 5, 3: 3}
#: SQP starts (the configured pose and the best screened poses)
STARTS = 3


@dataclass(repr=False)
class PoseDesign(HardwareDesign):
    """The result of :func:`design_pose` (positions in m, angles in rad, the tip in rod lengths; the
    common attributes: :class:`~actuator_design.hardware.design.HardwareDesign`).

    Attributes
    ----------
    status : str
        ``"unreachable"``: no pose within the travel meets the target (the nearest tip found is
        reported); else as :class:`~actuator_design.hardware.design.HardwareDesign`.
    position, start_position : (float, float)
        The magnet's centre, designed and configured, m.
    axis_angle, start_axis_angle : float
        Its axis (north pole), rad from the rod axis.
    travel : dict
        The travel, in mm and deg.
    move : float
        Σ (Δ_c / half travel_c)² of the moving coordinates (the effort minimised).
    least_move : bool
        The search ended at a first-order least-move point (not only on the target).
    position_tolerance : float
        Half-width of the magnet's position error in the box, m.
    """

    position: tuple = (math.nan, math.nan)
    axis_angle: float = math.nan
    start_position: tuple = (math.nan, math.nan)
    start_axis_angle: float = math.nan
    travel: dict = field(default_factory=dict)
    move: float = math.nan
    least_move: bool = False
    position_tolerance: float = POSITION_TOLERANCE

    def _repr_parts(self) -> List[str]:
        return [f"position_mm=({self.position[0] * 1e3:.6g}, {self.position[1] * 1e3:.6g})",
                f"axis_deg={math.degrees(self.axis_angle):.6g}", f"move={self.move:.4g}", *super()._repr_parts()]

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``design --json`` on a scene with a moving magnet."""
        mm = lambda p: [v * 1e3 for v in p]
        out = self.common_dict()
        out.update({
            "least_move": self.least_move, "position_mm": mm(self.position),
            "axis_angle_deg": math.degrees(self.axis_angle), "start_position_mm": mm(self.start_position),
            "start_axis_angle_deg": math.degrees(self.start_axis_angle), "travel": self.travel, "move": self.move})
        if self.tolerances is not None:  # (h_rel and phi_deg as everywhere; here they are these)
            out["tolerances"].update(position_mm=self.position_tolerance * 1e3,
                                     remanence_rel=self.tolerances.field_rel,
                                     axis_deg=math.degrees(self.tolerances.angle))
        return out


def design_pose(scene: Scene, target, *, tolerances: Optional[Tolerances] = None,
                position_tolerance: float = POSITION_TOLERANCE, options: Optional[SolverOptions] = None,
                verify: bool = True, tip_tol: float = TIP_TOL,
                progress: Optional[Callable[[str], None]] = None) -> PoseDesign:
    """The magnet pose nearest the configured one, within its travel, that puts the tip on
    ``target`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene whose field has one magnet with a ``travel`` (the configured pose starts).
    target : sequence of 2 or 3 floats
        Tip x, y in rod lengths, optionally its angle in rad.
    tolerances : Tolerances, optional
        The lab's box: ``field_rel`` on the remanence, ``angle`` on the magnet's axis (default
        ±5 %, ±2°), and E, χ̄, fibres, clamp as given.
    position_tolerance : float
        Half-width of the magnet's position error in x and y, m (default 0.5 mm; 0: none).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solve from rest (a design without it is not a success).
    tip_tol : float
        Tip tolerance of the design, rod lengths.

    Returns
    -------
    PoseDesign
        Never raises for an unreachable target; raises ValueError for a scene without a moving magnet.
    """
    t0 = time.perf_counter()
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    target = np.asarray(target, float)
    if target.size not in (2, 3) or not np.all(np.isfinite(target)):
        raise ValueError(f"design: the target is x, y[, angle] (finite numbers), got {target.tolist()}")
    check_position_tolerance(scene, position_tolerance)
    var, prob = pose_problem(scene, target, tip_tol)
    magnet = scene.field.sources[var.source]
    out = PoseDesign(success=False, status="not_converged", message="", target=tuple(target.tolist()),
                     start_position=tuple(magnet.position), start_axis_angle=magnet.axis_angle,
                     travel=_travel_dict(magnet), tolerances=tol, position_tolerance=float(position_tolerance))
    pmap, out.message = pose_map(scene, var, options)
    if pmap is None:
        return out
    at = pmap.at
    starts = _screen(pmap, prob, var.coords, progress)

    sqp = run_starts(pmap, prob, starts, lambda a, b: _better(prob, a, b), progress, restore_first=True)
    if sqp is None:
        out.message = "no start pose within the travel gave a stable state from rest clear of the magnet"
        return out
    v, pt = sqp.w, sqp.point
    out.position, out.axis_angle = var.pose(magnet, v)
    out.move = float(np.dot(prob.cost, v * v))
    out.state, out.tip = pmap.result(v, pt["z"]), pt["tip"]
    out.tip_error = float(np.max(np.abs(pt["tip"][:target.size] - target)))
    out.iterations, out.least_move = sqp.iterations, bool(sqp.converged)
    out.field_at_clamp, out.max_rod_field = _field_report(at(scene, v), out.state)
    out.limits_active = _active(var, prob, v, pt)
    if not sqp.reached:
        out.missed(sqp, "pose within the travel", _band(pt["tip_jac"][:2] * prob.half))
        out.solves, out.seconds = pmap.solves, time.perf_counter() - t0
        return out
    if verify:
        verify_on(out, scene_at_pose(scene, out.position, out.axis_angle), options)
    judge(out, _box(pmap, var, v, out.state, tol, position_tolerance, target))
    out.solves, out.seconds = pmap.solves, time.perf_counter() - t0
    out.message = _message(out)
    return out


def pose_map(scene: Scene, var: PoseVariables, options: SolverOptions) -> Tuple[Optional[HardwareMap], str]:
    """(the map over the pose offsets from the configured pose's state from rest, ""), or (None,
    why there is none: that state did not converge)."""
    v0 = np.zeros(len(var.coords))
    at = at_pose(var)
    start = solve(at(scene, v0), options)
    if not (start.success and start.stable):
        return None, f"the state from rest at the configured pose did not converge: {start.message}"
    return HardwareMap(scene, start, v0, var.names, at, clearance(scene, var)), ""


def _travel_dict(magnet: MagnetSource) -> dict:
    out = {}
    for name, lo_hi in zip(COORDS, magnet.travel):
        if lo_hi is not None:
            out[name + ("_deg" if name == "angle" else "_mm")] = [math.degrees(v) if name == "angle" else v * 1e3
                                                                  for v in lo_hi]
    return out


def _screen(pmap: HardwareMap, prob: CurrentProblem, coords, progress=None,
            miss: Optional[Callable[[np.ndarray, dict], float]] = None) -> List[np.ndarray]:
    """Start offsets for the SQP: the configured pose (v = 0) and the grid poses over the travel
    (:data:`SCREEN_LEVELS` per coordinate) nearest the target, mutually apart, at most :data:`STARTS`.
    ``miss(v, point)`` ranks the poses (default: the largest miss of the tip's coordinates)."""
    m, n = prob.target.size, prob.lo.size
    if miss is None:
        miss = lambda v, p: float(np.max(np.abs(p["tip"][:m] - prob.target)))
    levels = SCREEN_LEVELS[n]
    # (a coordinate whose travel is a whole turn has its two ends at one pose: sampled once)
    axes = [np.linspace(lo, hi, levels + 1)[:-1] if c == 2 and hi - lo >= 2 * math.pi - 1e-9 else
            np.linspace(lo, hi, levels) for c, lo, hi in zip(coords, prob.lo, prob.hi)]
    grid = [np.array(p) for p in itertools.product(*axes)]

    def walk(points):  # (offsets, miss) of each grid pose reached from rest, clear of the sources
        n0 = pmap.solves
        found = []
        for v in points:
            p = pmap.evaluate(v)
            if p is not None and within_limits(prob, v, p):
                found.append((v, miss(v, p)))
        return found, pmap.solves - n0

    base = pmap.solves
    half = forked.start(lambda: walk(grid[len(grid) // 2:]))
    (mine, n1), (theirs, n2) = walk(grid[:len(grid) // 2]), half.result()
    pmap.solves = base + n1 + n2
    ranked = sorted(mine + theirs, key=lambda c: c[1])
    if progress is not None and ranked:
        progress(f"screen: {len(grid)} poses over the travel, {len(ranked)} reached from rest, the nearest "
                 f"{ranked[0][1]:.3g} off the target")
    chosen = [np.zeros(n)]
    for v, _ in ranked:
        if len(chosen) >= STARTS:
            break
        if all(float(np.max(np.abs(v - c) / prob.half)) > 0.1 for c in chosen):
            chosen.append(v)
    return chosen[1:] + chosen[:1]


def _better(prob: CurrentProblem, a, b) -> bool:
    """One reaching the target beats one that does not; of two that reach it, the smaller move (to
    1e-6: equal moves keep the first start's, whatever the round-off); of two that do not, the
    smaller miss."""
    m = prob.target.size
    miss = lambda r: float(np.max(np.abs(r.point["tip"][:m] - prob.target)))
    if a.reached != b.reached:
        return a.reached
    if a.reached:
        return float(np.dot(prob.cost, a.w * a.w)) < float(np.dot(prob.cost, b.w * b.w)) * (1 - 1e-6)
    return miss(a) < miss(b) - 1e-9


def _band(jac: np.ndarray) -> str:
    """A note where the tips within reach form a thin band about the nearest tip found: the tip's
    Jacobian over the travel (2, n), singular values σ1 ≥ σ2, with σ2 < σ1/100."""
    s = np.linalg.svd(jac, compute_uv=False)
    if s.size < 2 or s[1] >= 0.01 * s[0]:
        return ""
    return (f"; the tips within reach form a thin band here (the tip moves {s[0] / max(s[1], 1e-300):.3g} times less "
            "across it than along it, as an inextensible rod's tip does at moderate bending): a target on the band, "
            "such as the nearest tip found, is within reach")


def _active(var: PoseVariables, prob: CurrentProblem, v: np.ndarray, pt: dict) -> List[str]:
    act = []
    for i, c in enumerate(var.coords):
        if v[i] >= prob.hi[i] - 1e-6 * prob.half[i] or v[i] <= prob.lo[i] + 1e-6 * prob.half[i]:
            if c == 2 and prob.hi[i] - prob.lo[i] >= 2 * math.pi - 1e-9:
                # a whole turn has no end: the search's window (±180 deg about the configured axis) does
                act.append("the axis 180 deg from the configured one (the seam of the search's whole turn: "
                           "configure another axis angle to search across it)")
            else:
                act.append(f"travel {COORDS[c]}")
    if float(np.max(pt["limit"])) >= 1 - 1e-6:
        act.append("clearance from the magnet")
    return act


def _field_report(scene: Scene, state: EquilibriumResult):
    """(|μ0 H| T and angle rad at the clamp, largest |μ0 H| over the rod's nodes T)."""
    model = field_model(scene.field)
    values = model.parameter_values(scene.field)
    x, y = np.asarray(state.x, float), np.asarray(state.y, float)
    h = model.evaluate(np.concatenate([[0.0], x]), np.concatenate([[0.0], y]), values)
    b0 = MU0 * scene.scales.field
    return (b0 * math.hypot(h[0, 0], h[1, 0]), math.atan2(h[1, 0], h[0, 0])), b0 * float(np.max(np.hypot(h[0], h[1])))


def _box(pmap: HardwareMap, var: PoseVariables, v: np.ndarray, state: EquilibriumResult, tol: Tolerances,
         position_tolerance: float, target: np.ndarray) -> List[dict]:
    """Every corner of the box, switched on from rest (:meth:`HardwareMap.corner`), with its tip's miss."""
    return [{"offsets": offsets, "tip": {"x": c["tip"][0], "y": c["tip"][1], "angle": c["tip"][2]},
             "tip_error": float(np.max(np.abs(c["tip"][:2] - target[:2]))),
             "success": c["reached"], "stable": c["stable"], "same_branch": c["same_branch"],
             **({"region": c["region"]} if "region" in c else {})}
            for offsets, c in corner_states(pmap, var, v, state, tol, position_tolerance)]


def corner_states(pmap: HardwareMap, var: PoseVariables, v: np.ndarray, state: EquilibriumResult, tol: Tolerances,
                  position_tolerance: float):
    """Each corner of the pose design's box, switched on from rest: (its offsets in the outputs'
    units, :meth:`HardwareMap.corner`'s answer)."""
    axes = {}
    if position_tolerance > 0:
        axes["dx"] = axes["dy"] = position_tolerance / var.length
    if tol.angle > 0:
        axes["turn"] = tol.angle
    if tol.field_rel > 0:
        axes["remanence"] = tol.field_rel
    others = {a: t for a, t in (("youngs_rel", tol.youngs_rel), ("chi_rel", tol.chi_rel),
                                ("fibre_angle", tol.fibre_angle)) if t > 0}
    if tol.clamp_angle > 0:
        axes["mount"] = tol.clamp_angle
    names = list(axes) + list(others)
    base = np.array(var.placement(v))
    for signs in itertools.product((-1.0, 1.0), repeat=len(names)):
        s = dict(zip(names, signs))
        place = base + np.array([s.get("dx", 0.0) * axes.get("dx", 0.0), s.get("dy", 0.0) * axes.get("dy", 0.0),
                                 s.get("turn", 0.0) * axes.get("turn", 0.0)])
        f = pmap.scene.field
        places = list(f.source_placements())
        places[var.source] = tuple(float(p) for p in place)
        weights = list(f.source_weights())
        weights[var.source] *= 1 + s.get("remanence", 0.0) * axes.get("remanence", 0.0)
        sc = replace(pmap.scene, field=replace(f, placements=tuple(places), weights=tuple(weights)))
        deltas = {a: s[a] * others[a] for a in others}
        sc = apply_deltas(sc, deltas) if deltas else sc
        sc = replace(sc, theta0=sc.theta0 + s.get("mount", 0.0) * axes.get("mount", 0.0))
        c = pmap.corner(sc, state.z)
        offsets = {}
        for a in names:  # in the outputs' units: mm, deg, fractions
            value = s[a] * (axes[a] if a in axes else others[a])
            key, convert = _OFFSET_UNITS.get(a, (a, lambda x, _: x))
            offsets[key] = convert(value, var.length)
        yield offsets, c


#: a box offset's key and value in the outputs' units (from rod lengths, rad)
_OFFSET_UNITS = {"dx": ("dx_mm", lambda v, ell: v * ell * 1e3), "dy": ("dy_mm", lambda v, ell: v * ell * 1e3),
                 "turn": ("turn_deg", lambda v, _: math.degrees(v)), "remanence": ("remanence_rel", lambda v, _: v),
                 "mount": ("mount_deg", lambda v, _: math.degrees(v)),
                 "fibre_angle": ("fibre_deg", lambda v, _: math.degrees(v))}


def _message(out: PoseDesign) -> str:
    return out.closing_message(
        f"the magnet at ({out.position[0] * 1e3:.6g}, {out.position[1] * 1e3:.6g}) mm, axis at "
        f"{math.degrees(out.axis_angle):.6g} deg puts the tip on the target (miss {out.tip_error:.2g} rod lengths)")
