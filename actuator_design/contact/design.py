"""Design with contact, first case: the field that presses an obstacle with a given force (a gripper
finger on an object; issue 20 item 5).

The field magnitude h is the design variable, the field angle and everything else as the scene
gives them. The contact force on obstacle k along the loading path from rest, F_k(h) (the magnitude
of the total force the obstacle exerts, B0/ℓ²), is followed by :func:`~actuator_design.contact.path.follow_contact_path`
from h = 0 to ``h_max``; the first stable station past the target brackets it, and Brent's method on
F_k(h) − F (contact solves warm-started from the bracket's lower state, so on the same branch)
locates the design to ``xtol``. The design is then

* **verified** by an independent forward ``solve`` of the scene at the designed field, from rest
  (not from the path's states): its force must match the target to ``rtol`` and the state be stable;
* **judged over the tolerance box** (:class:`~actuator_design.robust.tolerances.Tolerances`: field ±5 %, angle ±2° by
  default): the force at every corner, each a forward solve from the design state, reported as a
  range, and whether the obstacle is still pressed at every corner.

A target above the largest force the path reaches (the rod pressed its hardest at ``h_max``, or the
contact lost) is ``status: "unreachable"`` with the largest force found.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import List, Optional

import numpy as np
from scipy.optimize import brentq

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.contact.path import follow_contact_path
from actuator_design.robust.tolerances import Tolerances, apply_deltas, bending_scale

__all__ = ["design_contact_force", "ContactForceDesign"]


@dataclass
class ContactForceDesign:
    """The result of :func:`design_contact_force` (forces in B0/ℓ², and N on a physical scene)."""

    success: bool
    status: str
    message: str
    target: float
    obstacle: int
    h: float = math.nan
    force: float = math.nan
    state: Optional[EquilibriumResult] = None
    verified: bool = False
    verification_force: float = math.nan
    box: List[dict] = field(default_factory=list)
    box_force_range: tuple = (math.nan, math.nan)
    holds_over_box: bool = False
    path_forces: List[tuple] = field(default_factory=list)

    def to_dict(self) -> dict:
        out = {k: getattr(self, k) for k in ("success", "status", "message", "target", "obstacle", "h", "force",
                                             "verified", "verification_force", "holds_over_box")}
        out["box_force_range"] = list(self.box_force_range)
        out["box"] = [dict(c) for c in self.box]
        out["path_forces"] = [list(p) for p in self.path_forces]
        out["units"] = {"force": "B0/l^2", "h": "dimensionless field group (THEORY §5)"}
        sc = self.state.scene.scales if self.state is not None else None
        if sc is not None:
            out["physical"] = {"target_N": self.target * sc.force, "force_N": self.force * sc.force,
                               "box_force_range_N": [v * sc.force for v in self.box_force_range]}
        return out


def obstacle_force(result: EquilibriumResult, k: int) -> float:
    """|Σ forces of obstacle k on the rod| (B0/ℓ²); 0 without contact."""
    pts = [p for p in (result.contact or {}).get("points", []) if p["obstacle"] == k and not p["weak"]]
    return float(np.hypot(*np.sum([p["force"] for p in pts], axis=0))) if pts else 0.0


def design_contact_force(scene, force: float, *, obstacle: int = 0, h_max: float = 10.0,
                         options: Optional[SolverOptions] = None, tolerances: Optional[Tolerances] = None,
                         steps: int = 20, xtol: float = 1e-10, rtol: float = 1e-6) -> ContactForceDesign:
    """The field magnitude h at which the rod, loaded from rest, presses ``obstacle`` with ``force``.

    Parameters
    ----------
    scene : Scene
        With obstacles and a field (uniform: the angle is the scene's); h itself is designed.
    force : float
        Target magnitude of the obstacle's total contact force, B0/ℓ² (> 0).
    obstacle : int
        Index into ``scene.obstacles``.
    h_max : float
        Largest field group searched (> 0).
    options : SolverOptions, optional
    tolerances : Tolerances, optional
        The lab's box (default field ±5 %, angle ±2°).
    steps : int
        Stations of the path from rest over [0, h_max].
    xtol, rtol : float
        Brent's tolerance on h; the relative force mismatch a verification accepts.

    Returns
    -------
    ContactForceDesign
        ``success`` only when the design is reached, verified from rest and stable.

    Raises
    ------
    ValueError
        No obstacles, an obstacle index out of range, a non-positive or non-finite force or h_max.
    """
    options = options or SolverOptions()
    tolerances = tolerances or Tolerances()
    if not scene.obstacles:
        raise ValueError("design_contact_force: the scene has no obstacles")
    if not (isinstance(obstacle, int) and 0 <= obstacle < len(scene.obstacles)):
        raise ValueError(f"obstacle: an index in [0, {len(scene.obstacles) - 1}], got {obstacle!r}")
    if not (math.isfinite(force) and force > 0):
        raise ValueError(f"force: must be a finite number > 0, got {force!r}")
    if not (math.isfinite(h_max) and h_max > 0):
        raise ValueError(f"h_max: must be a finite number > 0, got {h_max!r}")
    path = follow_contact_path(scene, options, {"h": [0.0, float(h_max)]}, max_step=1.0 / max(1, int(steps)))
    stations = [(p.param, r) for p, r in zip(path.points, path.point_states) if r.success and r.stable]
    forces = [(h, obstacle_force(r, obstacle)) for h, r in stations]
    out = ContactForceDesign(success=False, status="unreachable", message="", target=float(force),
                             obstacle=obstacle, path_forces=forces)
    below = None
    for (h, f), (_, r) in zip(forces, stations):
        if f >= force and below is not None:
            return _finish(out, scene, options, tolerances, below, (h, r), force, xtol, rtol)
        below = (h, r) if f < force else below
    best = max(forces, key=lambda hf: hf[1], default=(math.nan, 0.0))
    out.message = (f"no field up to h_max = {h_max:g} presses obstacle {obstacle} with {force:g} B0/l^2 along the "
                   f"loading path from rest: the largest force is {best[1]:.6g} at h = {best[0]:.6g}"
                   + ("" if path.success else f" (the path stopped: {path.message})"))
    return out


def _finish(out, scene, options, tolerances, below, above, force, xtol, rtol) -> ContactForceDesign:
    h_lo, r_lo = below
    h_hi, _ = above
    k = out.obstacle
    warm = {"state": r_lo}

    def mismatch(h):
        r = solve(replace(scene, h=h), options, initial=warm["state"])
        if not r.success:
            raise _Failed(r.message)
        return obstacle_force(r, k) - force

    try:
        h = brentq(mismatch, h_lo, h_hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
    except _Failed as err:
        out.status, out.message = "not_converged", f"a contact solve between h = {h_lo:.6g} and {h_hi:.6g} failed: {err}"
        return out
    state = solve(replace(scene, h=h), options, initial=r_lo)
    out.h, out.force, out.state = float(h), obstacle_force(state, k), state
    check = solve(replace(scene, h=h), options)  # from rest, independent of the path's states
    out.verification_force = obstacle_force(check, k)
    out.verified = bool(check.success and check.stable and abs(out.verification_force - force) <= rtol * force)
    box = []
    for corner in tolerances.corners():
        deltas = {a: s * getattr(tolerances, a) for a, s in corner.items()}
        r = solve(apply_deltas(replace(scene, h=h), deltas), options, initial=state)
        # (a corner with E moved is solved in its own units, b = 1: its force back in B0/l^2)
        box.append({"deltas": deltas, "force": obstacle_force(r, k) * bending_scale(deltas),
                    "success": bool(r.success), "stable": bool(r.stable)})
    fs = [c["force"] for c in box] or [out.force]
    out.box, out.box_force_range = box, (float(min(fs)), float(max(fs)))
    out.holds_over_box = bool(all(c["success"] and c["stable"] and c["force"] > 0 for c in box))
    out.success = bool(state.success and state.stable and out.verified)
    out.status = "success" if out.success else ("not_verified" if state.success else "not_converged")
    out.message = (f"h = {h:.8g} presses obstacle {k} with {out.force:.6g} B0/l^2 (target {force:g}); "
                   f"verified from rest: {out.verified} ({out.verification_force:.6g}); over the box "
                   f"({tolerances.describe()}): force {out.box_force_range[0]:.6g} to {out.box_force_range[1]:.6g}"
                   + ("" if out.holds_over_box else ", NOT pressed (or not stable) at every corner"))
    return out


class _Failed(Exception):
    pass
