"""What a loading path returns: points, jumps, continuous bifurcations and the whole path.

The JSON contract of ``path --json`` (:meth:`LoadingPath.to_dict`) and the printed summary live
here; :func:`~actuator_design.continuation.loading.follow_path` builds them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

from actuator_design.equilibrium.result import EquilibriumResult

__all__ = ["PathPoint", "Jump", "Bifurcation", "LoadingPath"]


@dataclass
class PathPoint:
    """One state on the path.

    Attributes
    ----------
    t : float
        Path coordinate: segment index + λ (schedule point k is at t = k).
    param : float
        Value of the ramped parameter for a one-parameter schedule, else ``t``.
    values : dict
        All scheduled parameter values at this point.
    tip : dict
        x, y (units of ℓ), angle (rad).
    energy : float
        Units of B0/ℓ.
    stable : bool
    min_eigenvalue : float
        Smallest reduced-Hessian eigenvalue (THEORY §7); 0 at a critical point.
    morse_index : int
    branch : int
        Counts the jumps before this point (a new branch after each snap).
    direction : int
        Sign of the change of the ramped parameter along this segment (one-parameter schedules;
        0 otherwise).
    kind : str
        "start", "step", "schedule" (a schedule point), "critical" (fold or bifurcation), "landing".
    """

    t: float
    param: float
    values: Dict[str, float]
    tip: Dict[str, float]
    energy: float
    stable: bool
    min_eigenvalue: float
    morse_index: int
    branch: int
    direction: int
    kind: str

    def to_dict(self) -> dict:
        return {"t": self.t, "param": self.param, "values": dict(self.values), "tip": dict(self.tip),
                "energy": self.energy, "stable": self.stable, "min_eigenvalue": self.min_eigenvalue,
                "morse_index": self.morse_index, "branch": self.branch, "direction": self.direction,
                "kind": self.kind}


def _state_dict(r: EquilibriumResult) -> dict:
    return {"tip": {k: float(v) for k, v in r.tip.items()}, "energy": float(r.energy),
            "stable": bool(r.stable), "min_eigenvalue": float(r.eigenvalues[0]),
            "morse_index": int(r.morse_index), "gamma": r.gamma}


@dataclass
class Jump:
    """A snap-through: the followed state lost stability and the rod jumped to another one.

    Attributes
    ----------
    t, param : float
        Where (path coordinate; value of the ramped parameter, or t).
    values : dict
        Parameter values at the jump.
    direction : int
        Sign of the ramp there (one-parameter schedules).
    kind : str
        "fold" (saddle-node) or "subcritical" (a bifurcation without a nearby stable branch).
    from_state, to_state : EquilibriumResult
        Both at the jump's parameter values (the critical state and the stable state it jumps to).
    energy_released : float
        from_state.energy − to_state.energy, units of B0/ℓ (≥ 0).
    """

    t: float
    param: float
    values: Dict[str, float]
    direction: int
    kind: str
    from_state: EquilibriumResult
    to_state: EquilibriumResult
    energy_released: float

    def to_dict(self) -> dict:
        return {"t": self.t, "param": self.param, "values": dict(self.values),
                "direction": self.direction, "kind": self.kind,
                "from": _state_dict(self.from_state), "to": _state_dict(self.to_state),
                "energy_released": self.energy_released}


@dataclass
class Bifurcation:
    """A continuous loss of stability (supercritical bifurcation): the rod leaves the followed
    branch without a jump, onto one of the bifurcating stable branches (chosen by the sign of
    the unstable eigenvector: positive at the tip, ``sign``) — or, with ``sign`` 0, the followed
    branch ends on a branch that is stable past the branch point (nothing to choose). ``located``:
    False when only the engine's step bracketed it (a merge whose own branch point was not found
    again: the value is the step's)."""

    t: float
    param: float
    values: Dict[str, float]
    direction: int
    state: EquilibriumResult
    sign: int
    located: bool = True

    def to_dict(self) -> dict:
        return {"t": self.t, "param": self.param, "values": dict(self.values),
                "direction": self.direction, "state": _state_dict(self.state), "sign": self.sign,
                "located": bool(self.located)}


@dataclass
class LoadingPath:
    """A quasi-static loading path (result of :func:`follow_path`).

    Attributes
    ----------
    names : list of str
        Scheduled parameter names.
    schedule : ndarray, shape (n_schedule, len(names))
    param : str or None
        The ramped parameter for one-parameter schedules (the only name that changes), else None.
    points : list of PathPoint
        Every accepted state in path order (critical states and landings included).
    jumps : list of Jump
    bifurcations : list of Bifurcation
    snap_free : bool
        True when the whole path converged and the rod never jumped.
    hysteresis : dict
        ``width`` (distance in the parameter between the two jumps of a loop), ``area`` (of the loop
        in the (param, tip angle) plane, units of param × rad) — of the first loop; ``loops``: every
        loop (a jump followed by a jump in the opposite ramp direction) with its ``width``, ``area``,
        ``jumps`` (the two parameter values), ``branch_before`` and ``branch_between`` (the two
        stable branches of the loop as [param, tip angle] pairs, sorted by param) and ``complete``
        (both branches cover the loop).
        Zeros and an empty list when there is no loop.
    states : list of EquilibriumResult
        The state at each schedule point.
    final : EquilibriumResult
        The state at the last schedule point (the last schedule point reached when ``success`` is
        False).
    success : bool
        Every step converged (a non-converged step stops the path: ``message`` says where).
    message : str
    contact_events : list of dict
        Paths through contact (:mod:`actuator_design.contact.path`): each touch-down and lift-off in path order,
        with ``kind``, ``t``, ``param``, ``values``, ``obstacle`` (index) and ``obstacle_text``,
        ``s`` (arc length of the touching point, ℓ) and ``located`` (False: at the step only).
    """

    names: List[str]
    schedule: np.ndarray
    param: Optional[str]
    points: List[PathPoint]
    jumps: List[Jump]
    bifurcations: List[Bifurcation]
    snap_free: bool
    hysteresis: dict
    states: List[EquilibriumResult]
    final: EquilibriumResult
    success: bool
    message: str
    contact_events: List[dict] = field(default_factory=list)

    def column(self, key: str) -> np.ndarray:
        """A column of ``points``: "t", "param", "x", "y", "angle", "energy", "stable",
        "min_eigenvalue", "branch", "direction"."""
        if key in ("x", "y", "angle"):
            return np.array([p.tip[key] for p in self.points])
        return np.array([getattr(p, key) for p in self.points])

    def reaches(self, target: EquilibriumResult, tol: float = 1e-6) -> bool:
        """Whether the final state is ``target`` (max nodal |Δθ| ≤ tol on equal discretisations)."""
        a, b = self.final.z, target.z
        return bool(a is not None and b is not None and a.shape == b.shape
                    and np.max(np.abs(a - b)) <= tol)

    def to_dict(self) -> dict:
        """The JSON contract of ``actuator-design path --json``: ``points``, ``jumps``, ``snap_free``,
        ``hysteresis`` (and more)."""
        return {"param": self.param, "names": list(self.names),
                "schedule": [dict(zip(self.names, map(float, row))) for row in self.schedule],
                "success": self.success, "message": self.message, "snap_free": self.snap_free,
                "points": [p.to_dict() for p in self.points],
                "jumps": [j.to_dict() for j in self.jumps],
                "bifurcations": [b.to_dict() for b in self.bifurcations],
                "hysteresis": self.hysteresis, "final": _state_dict(self.final),
                "contact_events": [dict(e) for e in self.contact_events],
                "units": {"tip": "x, y in rod lengths l, angle in rad", "energy": "B0/l",
                          "angles": "rad"}}

    def summary(self) -> str:
        lines = [f"loading path over {', '.join(self.names)} ({len(self.schedule)} schedule points, "
                 f"{len(self.points)} states): {'converged' if self.success else 'FAILED'} — {self.message}",
                 f"  snap-free: {'yes' if self.snap_free else 'no'}"]
        for j in self.jumps:
            lines.append(f"  jump ({j.kind}) at {self.param or 't'} = {j.param:.10g}: tip angle "
                         f"{j.from_state.tip['angle']:.6f} -> {j.to_state.tip['angle']:.6f} rad, "
                         f"energy released {j.energy_released:.6g} B0/l")
        for b in self.bifurcations:
            how = f"branch sign {b.sign:+d}" if b.sign else "onto the one stable branch"
            how += "" if b.located else "; at the step, not located"
            lines.append(f"  continuous bifurcation at {self.param or 't'} = {b.param:.10g} ({how})")
        for e in self.contact_events:
            where = f" at s = {e['s']:.6g}" if e["s"] is not None else ""
            how = "" if e["located"] else " (at the step; not located)"
            when = (f"{self.param} = {e['param']:.10g}" if self.param else
                    ", ".join(f"{k} = {v:.10g}" + (" rad" if k in ("phi", "alpha", "theta0") else "")
                              for k, v in e["values"].items()))
            lines.append(f"  {e['kind']} {'on' if e['kind'] == 'touch-down' else 'from'} {e['obstacle_text']} at "
                         f"{when}{where}{how}")
        hy = self.hysteresis
        if hy.get("loops"):
            lines.append(f"  hysteresis: width {hy['width']:.8g}, loop area {hy['area']:.6g} "
                         f"({len(hy['loops'])} loop(s))")
        f = self.final
        label = "final state" if self.success else (
            f"state at the last schedule point reached (t = {len(self.states) - 1})")
        lines.append(f"  {label}: tip ({f.tip['x']:.6f}, {f.tip['y']:.6f}), angle {f.tip['angle']:.6f} rad, "
                     f"energy {f.energy:.8g}, {'stable' if f.stable else 'UNSTABLE'}")
        return "\n".join(lines)
