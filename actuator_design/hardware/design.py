"""What the designs over hardware share (issue 19 item 2): coil currents (:mod:`actuator_design.hardware.current_design`)
and a magnet's pose (:mod:`actuator_design.hardware.pose_design`) are both a search on a :class:`~actuator_design.hardware.map.HardwareMap`
by the SQP of :mod:`actuator_design.hardware.current_sqp` from a few starts (each in a forked copy of this process: the same
answer either way), an independent verification on magpylib's field refitted at the answer, and a
judgement over the lab's tolerance box, every corner switched on from rest. Here: the result's
common part, the runs from the starts, the verification and the judgement, and the closing message.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, List, Optional, Sequence

import numpy as np

from actuator_design import forked
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.hardware.current_sqp import (CurrentProblem, SQPOutcome, least_effort_currents,
                                                  within_limits)
from actuator_design.hardware.map import HardwareMap
from actuator_design.model.field_sources import source_field
from actuator_design.physics.parameters import scale_field
from actuator_design.robust.tolerances import Tolerances

__all__ = ["HardwareDesign", "run_starts", "verify", "judge", "refitted", "VERIFY_TOL"]

#: the independent verification's tip tolerance (rod lengths)
VERIFY_TOL = 1e-6


@dataclass
class HardwareDesign:
    """The part of a design over hardware every kind shares (the tip in rod lengths).

    Attributes
    ----------
    success : bool
        The target met to the design's tip tolerance within every limit, stable, verified from
        rest on a refitted field, and on the designed branch and stable at every corner of the box.
    status : str
        ``"success"``, ``"unreachable"`` (the search ended at a nearest tip, which is reported
        with the limits that bind there), ``"not_verified"``, ``"not_robust"`` or
        ``"not_converged"`` (no start, or the search stopped short in a thin band of tips).
    field_at_clamp : (float, float)
        |μ0 H| (T) and its angle (rad) at the clamp.
    max_rod_field : float
        Largest |μ0 H| (T) over the rod.
    tip, tip_error : ndarray (3,), float
        The design state's tip (x, y, angle) and its miss of the target (rod lengths).
    verification : dict
        The independent solve from rest on the refitted field: ``tip``, ``error``, ``stable``.
    box : list of dict
        Every corner: its offsets, tip, miss, ``success``, ``stable`` and ``same_branch``.
    worst_tip_error : float
        Largest miss over the box (rod lengths); nan where a corner was not reached (no state from
        rest there to measure).
    """

    success: bool
    status: str
    message: str
    target: tuple
    field_at_clamp: tuple = (math.nan, math.nan)
    max_rod_field: float = math.nan
    tip: np.ndarray = field(default_factory=lambda: np.full(3, math.nan))
    tip_error: float = math.nan
    state: Optional[EquilibriumResult] = None
    verified: bool = False
    verification: dict = field(default_factory=dict)
    box: List[dict] = field(default_factory=list)
    worst_tip_error: float = math.nan
    holds_over_box: bool = False
    iterations: int = 0
    solves: int = 0
    seconds: float = 0.0
    limits_active: List[str] = field(default_factory=list)
    tolerances: Optional[Tolerances] = None
    notes: List[str] = field(default_factory=list)

    def __repr__(self) -> str:
        """One line: the kind, the verdict, the setting and how well it meets its target."""
        return f"{type(self).__name__}({', '.join([f'status={self.status!r}', f'success={self.success}', *self._repr_parts()])})"

    def _repr_parts(self) -> List[str]:
        """The repr's fields after the verdict: the kinds (:class:`~actuator_design.hardware.current_design.CurrentDesign`, ...)
        put their setting first; a shape or stiffness fit (a mixin later in the order) adds its own."""
        more = getattr(super(), "_repr_parts", lambda: [])()
        return [f"tip_error={self.tip_error:.3g}", *more, f"verified={self.verified}",
                f"holds_over_box={self.holds_over_box}"]

    def common_dict(self) -> dict:
        """The keys every design over hardware writes to its JSON contract."""
        out = {k: getattr(self, k) for k in ("success", "status", "message", "verified", "holds_over_box",
                                             "iterations", "solves", "limits_active", "notes")}
        out.update({
            "target": list(self.target),
            "field_at_clamp_mT": self.field_at_clamp[0] * 1e3, "field_at_clamp_deg": math.degrees(self.field_at_clamp[1]),
            "max_rod_field_mT": self.max_rod_field * 1e3,
            "tip": {"x": self.tip[0], "y": self.tip[1], "angle": self.tip[2]}, "tip_error": self.tip_error,
            "verification": self.verification, "box": self.box, "worst_tip_error": self.worst_tip_error,
            "tolerances": None if self.tolerances is None else self.tolerances.to_dict(), "time_s": self.seconds})
        return out

    def missed(self, sqp: SQPOutcome, what: str, extra: str = "") -> None:
        """Record that the search ended off the target: ``"unreachable"`` at a nearest tip (a
        local search, not certified the nearest), ``"not_converged"`` where it stopped short in a
        thin band of tips with no limit binding (the target may be reachable). ``what`` names the
        hardware."""
        binds = f" ({', '.join(self.limits_active)} at the limit)" if self.limits_active else ""
        if sqp.stopped_short:
            self.status = "not_converged"
            self.message = (f"the search stopped {self.tip_error:.3g} rod lengths short of the target, in a thin band "
                            f"of reachable tips with no limit binding: the target may be reachable by a {what}, but "
                            "none was found" + extra)
        else:
            self.status = "unreachable"
            self.message = (f"no {what} puts the tip on the target: the nearest tip found (a local search, not "
                            f"certified the nearest) misses it by {self.tip_error:.3g} rod lengths{binds}" + extra)

    def not_robust(self) -> str:
        """The sentence of a design that does not hold over its box: at how many corners."""
        bad = sum(not (c["success"] and c["stable"] and c["same_branch"]) for c in self.box)
        return (f"; NOT robust: at {bad} of {len(self.box)} corners of the tolerance box the rod, switched on from "
                "rest, is not on the designed branch (or not stable)")

    def closing_message(self, text: str, what: str = "tip") -> str:
        """``text`` (what the design is and its miss) with the verification's and the box's verdicts;
        ``what`` names what misses (``"tip"``, or ``"points"`` for a shape)."""
        if not self.verified:
            v = self.verification
            return text + (f"; NOT verified: the refitted field solved from rest gives {'a tip' if what == 'tip' else what} "
                           f"{v.get('error', math.nan):.3g} rod lengths off ({v.get('status', 'not run')}, stable "
                           f"{v.get('stable')})" if v else "; not verified (verification off)")
        text += f"; verified from rest on the refitted field (miss {self.verification['error']:.2g})"
        if not self.holds_over_box:
            return text + self.not_robust()
        return text + (f"; over the box ({len(self.box)} corners) the {what} miss{'es' * (what == 'tip')} by at most "
                       f"{self.worst_tip_error:.3g} rod lengths")


def refitted(scene, sources, weights: tuple = ()):
    """``scene`` with its field built anew from ``sources`` (SI): magpylib's field refitted (its own
    H0; the fit tolerance and the limits kept, the source weights set to ``weights``) and the groups
    h, h_pos, h_r (each ∝ H0, THEORY §5, §9) rescaled — a verification's scene."""
    f = scene.field
    new, h0 = source_field(tuple(sources), f.length, f.fit_tolerance)
    new = replace(new, fit_tolerance=f.fit_tolerance, max_power=f.max_power, max_field=f.max_field, weights=weights)
    k = h0 / scene.scales.field
    return scale_field(replace(scene, field=new, scales=replace(scene.scales, field=h0)), k)


def run_starts(hmap: HardwareMap, prob: CurrentProblem, starts: Sequence[np.ndarray],
               better: Callable[[SQPOutcome, SQPOutcome], bool], progress=None,
               restore_first: bool = False) -> Optional[SQPOutcome]:
    """The SQP from each start (the first here, the others forked beside it), the best by
    ``better`` in the order of the starts (ties keep the first), or None where no start's state
    from rest keeps the limits. ``hmap.solves`` counts every run's solves, wherever it ran."""

    def run(ws):
        n0 = hmap.solves
        p0 = hmap.evaluate(ws)
        if p0 is None or not within_limits(prob, ws, p0):  # a start may not keep the limits
            return None, hmap.solves - n0
        return least_effort_currents(prob, hmap.evaluate, ws, progress, restore_first=restore_first), hmap.solves - n0

    base = hmap.solves
    beside = [forked.start(lambda ws=ws: run(ws)) for ws in starts[1:]]
    runs = [run(starts[0])] + [b.result() for b in beside]
    hmap.solves = base + sum(n for _, n in runs)
    best = None
    for run_k, _ in runs:
        if run_k is not None and (best is None or better(run_k, best)):
            best = run_k
    return best


def verify(out: HardwareDesign, refitted, options) -> None:
    """Solve ``refitted`` (the scene with magpylib's field fitted anew at the answer) from rest;
    record its tip, miss and verdict in ``out`` (verified to :data:`VERIFY_TOL`)."""
    target = np.asarray(out.target, float)
    r = solve(refitted, options)
    vt = np.array([r.tip["x"], r.tip["y"], r.tip["angle"]])
    err = float(np.max(np.abs(vt[:target.size] - target)))
    out.verification = {"tip": {"x": vt[0], "y": vt[1], "angle": vt[2]}, "error": err,
                        "success": bool(r.success), "stable": bool(r.stable), "status": r.status}
    out.verified = bool(r.success and r.stable and err <= VERIFY_TOL)


def judge(out: HardwareDesign, box: List[dict]) -> None:
    """Record the box's corners in ``out`` and the design's verdict: a success is verified and on
    the designed branch and stable at every corner."""
    out.box = box
    worst = [c["tip_error"] for c in box]
    out.worst_tip_error = (max(worst, default=out.tip_error) if all(math.isfinite(v) for v in worst)
                           else math.nan)  # a corner not reached: no worst miss to state
    out.holds_over_box = all(c["success"] and c["stable"] and c["same_branch"] for c in box)
    out.success = bool(out.verified and out.holds_over_box)
    out.status = "success" if out.success else ("not_verified" if not out.verified else "not_robust")
