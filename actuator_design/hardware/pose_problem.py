"""The problem of a design over a magnet's pose (:mod:`actuator_design.hardware.pose_design`): the moving magnet and its
travel as offsets from the configured pose, the scene at an offset (the fitted field moved rigidly,
``SourceField.placements``), the rod's clearance from every source's fitted region as the map's
pointwise quantity, the SQP data (the least move, each coordinate over its half travel), and the
verification's scene (magpylib refitted with the magnet placed there)."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from actuator_design.model.field_sources import MagnetSource
from actuator_design.model.scene import Scene
from actuator_design.hardware.current_sqp import CurrentProblem
from actuator_design.hardware.design import refitted

__all__ = ["PoseVariables", "pose_variables", "at_pose", "clearance", "pose_problem", "scene_at_pose", "TIP_TOL",
           "check_position_tolerance", "COORDS", "angle_offsets"]

#: the design's tip tolerance (rod lengths; 2 nm on a 20 mm strip, where the stage's ±0.5 mm moves
#: the tip by ~1e-2): the tips a bent strip reaches form a thin band across which the tip moves up
#: to 1e5 times less than the magnet (σ2/σ1 of the tip's Jacobian), so a tighter tolerance asks for
#: the pose to digits no stage has
TIP_TOL = 1e-7
#: the pose's coordinates, in the order of a travel
COORDS = ("x", "y", "angle")


@dataclass(frozen=True)
class PoseVariables:
    """The moving magnet of a scene and its travel, in the units of the design.

    Attributes
    ----------
    source : int
        Index of the magnet among the field's sources.
    coords : tuple of int
        Which of x (0), y (1), angle (2) move, in that order.
    lower, upper : ndarray, shape (n,)
        The travel as offsets from the configured pose: units of ℓ for x, y; rad for the angle.
    length : float
        ℓ, m (positions in metres are ℓ × the offsets plus the configured position).
    """

    source: int
    coords: tuple
    lower: np.ndarray
    upper: np.ndarray
    length: float

    @property
    def names(self) -> tuple:
        k = self.source
        return tuple((f"source_dx_{k}", f"source_dy_{k}", f"source_turn_{k}")[c] for c in self.coords)

    def placement(self, v) -> tuple:
        """(dx, dy, turn) of the magnet at offsets ``v`` (n,)."""
        out = [0.0, 0.0, 0.0]
        for c, value in zip(self.coords, v):
            out[c] = float(value)
        return tuple(out)

    def pose(self, magnet: MagnetSource, v) -> tuple:
        """((x, y) m, axis angle rad) of the magnet moved by ``v``."""
        dx, dy, turn = self.placement(v)
        return ((magnet.position[0] + dx * self.length, magnet.position[1] + dy * self.length),
                magnet.axis_angle + turn)


def pose_variables(scene: Scene) -> PoseVariables:
    """The moving magnet of ``scene`` (ValueError naming what is missing)."""
    f = scene.field
    if getattr(f, "kind", "") != "sources" or scene.scales is None:
        raise ValueError("design over a magnet's pose: the scene's field must come from a magnet (a physical "
                         "scene with `field: {type: magnet}`)")
    if scene.obstacles:
        raise ValueError("design over a magnet's pose: the scene has obstacles; a design over the pose keeps no "
                         "clearance from them yet (solve and path model the rod in contact)")
    moving = [k for k, s in enumerate(f.sources) if isinstance(s, MagnetSource) and s.travel]
    if not moving:
        raise ValueError("design over a magnet's pose: the magnet has no travel; give the range its stage can "
                         "move it (e.g. `travel: {x: [10 mm, 40 mm], y: [-30 mm, -12 mm], angle: [0 deg, 180 deg]}`)")
    if len(moving) > 1:
        raise ValueError("design over a magnet's pose: more than one magnet has a travel; one magnet's pose is "
                         "designed at a time (give the others no travel)")
    k = moving[0]
    magnet, length = f.sources[k], f.length
    configured = (magnet.position[0], magnet.position[1], magnet.axis_angle)
    coords = tuple(c for c in range(3) if magnet.travel[c] is not None)
    ranges = [angle_offsets(magnet.travel[c], configured[c]) if c == 2 else
              ((magnet.travel[c][0] - configured[c]) / length, (magnet.travel[c][1] - configured[c]) / length)
              for c in coords]
    return PoseVariables(k, coords, np.array([r[0] for r in ranges]), np.array([r[1] for r in ranges]), float(length))


def angle_offsets(travel, angle: float) -> tuple:
    """The axis angle's travel as offsets (rad) from the configured ``angle``: a whole turn is
    ±π about it (every axis once, each reached the short way); a shorter range is taken in the
    turn that holds the configured angle (angles are equal modulo 2π)."""
    lo, hi = travel
    if hi - lo >= 2 * math.pi - 1e-9:
        return -math.pi, math.pi
    shift = 2 * math.pi * math.floor((angle - lo) / (2 * math.pi))
    return lo + shift - angle, hi + shift - angle


def at_pose(variables: PoseVariables):
    """``at(scene, v)``: the scene with the magnet moved by offsets ``v``."""

    def at(scene: Scene, v) -> Scene:
        places = list(scene.field.source_placements())
        places[variables.source] = variables.placement(v)
        return replace(scene, field=replace(scene.field, placements=tuple(places)))
    return at


def clearance(scene: Scene, variables: PoseVariables):
    """``pointwise(x, y, v)``: per source R²/ρ² (exterior fits) or ρ²/R² (interior), ≤ 1 where the
    rod is where the source's fit holds (ρ the distance from its centre, moved by ``v``, R its
    fit's ``valid_radius``)."""
    import casadi as ca

    terms = scene.field.terms

    def pointwise(x, y, v):
        rows = []
        for k, t in enumerate(terms):
            dx = dy = 0.0
            if k == variables.source:
                idx = {c: i for i, c in enumerate(variables.coords)}
                dx = v[idx[0]] if 0 in idx else 0.0
                dy = v[idx[1]] if 1 in idx else 0.0
            rho2 = (x - t.centre[0] - dx) ** 2 + (y - t.centre[1] - dy) ** 2
            r2 = t.valid_radius ** 2
            rows.append(r2 / rho2 if t.kind == "exterior" else rho2 / r2)
        return ca.vertcat(*rows)
    return pointwise


def pose_problem(scene: Scene, target, tip_tol: float = TIP_TOL):
    """(PoseVariables, the SQP data) of a scene with a moving magnet and a target (x, y[, angle])."""
    var = pose_variables(scene)
    half = (var.upper - var.lower) / 2
    prob = CurrentProblem(target=np.asarray(target, float), cost=1.0 / half ** 2, bound=half, max_limit=1.0,
                          tip_tol=tip_tol, lower=var.lower, upper=var.upper, centre=np.zeros(half.size))
    return var, prob


def check_position_tolerance(scene: Scene, position_tolerance: float) -> None:
    """ValueError unless the magnet's position tolerance (m) is in [0, a tenth of the rod]."""
    if not (math.isfinite(position_tolerance) and 0.0 <= position_tolerance <= 0.1 * scene.field.length):
        raise ValueError(f"position tolerance: must be in [0, {0.1 * scene.field.length * 1e3:g} mm] (a tenth of the "
                         f"rod), got {position_tolerance * 1e3:g} mm")


def scene_at_pose(scene: Scene, position, axis_angle: float) -> Scene:
    """The scene with its moving magnet placed at ``position`` (m) and ``axis_angle`` (rad), built
    anew: magpylib's field refitted as a fixed magnet's (its own H0), and the groups h, h_pos, h_r
    (each ∝ H0, THEORY §5, §9) rescaled — the verification's scene."""
    var = pose_variables(scene)
    f = scene.field
    sources = list(f.sources)
    sources[var.source] = replace(sources[var.source], position=(float(position[0]), float(position[1])),
                                  axis_angle=float(axis_angle), travel=())
    return refitted(scene, sources, f.weights)
