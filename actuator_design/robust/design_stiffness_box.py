"""The tip stiffness of a design over the lab's tolerance box (a stiffness target's robustness).

A design for a stiffness k_target is a state on one branch; over the tolerance box
(:mod:`actuator_design.robust.tolerances`) the real actuator stays on that branch, so its stiffness there is the
stiffness of the branch's state at the perturbed scene. The branch is followed from the nominal
state to every point of a grid over the box (:func:`~actuator_design.robust.robustness.follow_segment`, warm Newton
steps, every state stable), and at each point the vertical tip stiffness dp/dv1 is taken by
central differences of two forward solves warm-started on that state
(:func:`~actuator_design.inverse.verify.stiffness_by_differences`: the verification's own method, never the
design NLP's sensitivity).

The grid: every combination of −1, 0, +1 of each active half-width (3^k points: the centre, the
corners, the edge midpoints and the face centres) for up to three active tolerances; beyond, the
centre, the corners and the 2k axis points. The midpoints matter: at φ = 0 the stiffness is even in
the field angle, so along an edge of the box it is extreme at the edge's midpoint, not at a corner.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import get_solver
from actuator_design.inverse.verify import stiffness_by_differences
from actuator_design.model.scene import Scene
from actuator_design.robust.robustness import follow_segment
from actuator_design.robust.tolerances import Tolerances, bending_scale, perturb

__all__ = ["StiffnessOverBox", "stiffness_over_box", "box_grid"]


@dataclass
class StiffnessOverBox:
    """The stiffness dp/dv1 (units of B0/ℓ³) on a grid over the tolerance box.

    target : the stiffness asked for.
    points : per grid point, ``offset`` (signed fractions of the half-widths), ``reached`` (the
        branch was followed there on stable states), ``stiffness`` (None where not reached or
        the difference solves failed) and ``rel_error`` (stiffness / target − 1).
    """

    target: float
    points: List[Dict[str, object]] = field(default_factory=list)

    @property
    def values(self) -> List[float]:
        return [float(p["stiffness"]) for p in self.points if p["stiffness"] is not None]

    @property
    def complete(self) -> bool:
        """Every grid point was reached and has a finite stiffness."""
        return bool(self.points) and len(self.values) == len(self.points)

    @property
    def worst_rel_error(self) -> Optional[float]:
        """max |k / k_target − 1| over the grid points evaluated (None: none)."""
        v = self.values
        return max(abs(k / self.target - 1.0) for k in v) if v else None

    def to_dict(self) -> Dict[str, object]:
        v = self.values
        return {"target": self.target, "min": min(v) if v else None, "max": max(v) if v else None,
                "worst_rel_error": self.worst_rel_error, "complete": self.complete,
                "method": "central differences of forward solves on the branch followed to each point",
                "grid": "3 levels per active tolerance (corners, edge midpoints, centre)", "points": self.points}

    def sentence(self) -> str:
        v = self.values
        if not v:
            return "the stiffness could not be evaluated over the box"
        text = (f"stiffness over the box {min(v):.4g} to {max(v):.4g} B0/l^3 (at {len(v)} points: corners, "
                f"edge midpoints, centre; at most {100 * self.worst_rel_error:.3g} % from the target)")
        missing = len(self.points) - len(v)
        return text + (f"; {missing} of {len(self.points)} points not reached on the branch" if missing else "")


def box_grid(tol: Tolerances) -> List[Dict[str, float]]:
    """The grid points as signed unit offsets over the active tolerances (the centre first)."""
    act = tol.active
    if len(act) <= 3:
        pts = [dict(zip(act, c)) for c in itertools.product((0.0, -1.0, 1.0), repeat=len(act))]
    else:
        pts = [{a: 0.0 for a in act}] + tol.corners()
        pts += [{a: (s if a == b else 0.0) for a in act} for b in act for s in (-1.0, 1.0)]
    return pts


def stiffness_over_box(scene: Scene, z: np.ndarray, tol: Tolerances, options: SolverOptions,
                       target: float) -> StiffnessOverBox:
    """Follow the design's branch to each point of :func:`box_grid` and take its stiffness there.

    Parameters
    ----------
    scene : Scene
        The nominal design scene (with a tip-force term).
    z : ndarray, shape (n_nodes,)
        The design's equilibrium on the mesh of ``options`` (θ at the nodes, rad).
    tol : Tolerances
    options : SolverOptions
        The design mesh.
    target : float
        The stiffness asked for (B0/ℓ³).

    Returns
    -------
    StiffnessOverBox
    """
    solver = get_solver(scene, options)
    P0 = solver.parameter_vector(scene)
    out = StiffnessOverBox(float(target))
    for off in box_grid(tol):
        at = perturb(scene, tol, off) if any(off.values()) else scene
        zc, reached = np.asarray(z, float), True
        if any(off.values()):
            seg = follow_segment(solver, zc, P0, solver.parameter_vector(at))
            reached, zc = seg.completed, seg.z_end
        # (a moved E changes the unit of the moved scene's stiffness: back to B0/l^3)
        k = (stiffness_by_differences(at, options, zc) * bending_scale({a: v * getattr(tol, a) for a, v in off.items()})
             if reached else float("nan"))
        ok = reached and math.isfinite(k)
        out.points.append({"offset": {a: float(v) for a, v in off.items()}, "reached": bool(reached),
                           "stiffness": float(k) if ok else None,
                           "rel_error": float(k / target - 1.0) if ok else None})
    return out
