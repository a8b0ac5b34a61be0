"""Coil currents as design variables: the least-power currents (A) within each driver's limit that
put the tip of the rod, loaded from rest, on a target (issue 19 item 2).

The scene's field comes from coils (``field: {type: coils}``); each coil's ``max_current`` (A) is
its driver's limit, and with every ``resistance`` (Ω) the effort is the coils' power Σ R_k I_k²
(W; else Σ I_k², A²). Optional limits: the total power ``max_power`` and the field the rod sees,
|μ0 H| ≤ ``max_field`` at every point of the rod. The design:

1. starts from the configured currents, the state reached from rest there;
2. moves the currents by a trust-region SQP (:mod:`actuator_design.hardware.current_sqp`) on the forward map
   (:mod:`actuator_design.hardware.current_map`: the equilibrium followed as the currents change, with exact implicit
   derivatives), to the least effort that meets the target to ``tip_tol``;
3. is **verified** independently: magpylib's field of the coils at the designed currents is fitted
   anew (its own H0 and groups), and ``solve`` loads that scene from rest on its own mesh; the tip
   must meet the target to ``verify_tol`` and the state be stable;
4. is **judged over the lab's tolerances** (:class:`~actuator_design.robust.tolerances.Tolerances`): each current off by
   ±``field_rel`` independently (a driver's accuracy), the rod's mount turned by ±``angle`` against
   the coils, and E, χ̄, the fibres as given; every corner must stay stable; the worst tip miss is
   reported.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from actuator_design import forked
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.hardware.current_map import CurrentMap, at_weights
from actuator_design.hardware.current_sqp import CurrentProblem, within_limits
from actuator_design.hardware.design import HardwareDesign, judge, refitted, run_starts
from actuator_design.hardware.design import verify as verify_on
from actuator_design.model.field_sources import CoilSource
from actuator_design.model.scene import Scene
from actuator_design.model.units import MU0
from actuator_design.physics import parameters as lens
from actuator_design.physics.fields import field_model
from actuator_design.robust.tolerances import Tolerances, apply_deltas

__all__ = ["design_currents", "CurrentDesign", "scene_at_currents", "coil_problem", "current_map", "effort_notes",
           "first_coil_positive", "record_setting"]

#: the design's tip tolerance (rod lengths)
TIP_TOL = 1e-8
#: with more tolerance axes than this, the currents' corners are the linearised worst ones
MAX_FULL_AXES = 6
#: fractions of the way to the current limit at which each screening ramp is sampled
SCREEN_FRACTIONS = (0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.65, 0.8, 1.0)
#: SQP starts (the best screened states and the configured currents)
STARTS = 3
#: up to this many coils the screen also ramps every pair of coils together
PAIRED_COILS = 4


@dataclass(repr=False)
class CurrentDesign(HardwareDesign):
    """The result of :func:`design_currents` (currents in A, the tip in rod lengths; the common
    attributes: :class:`~actuator_design.hardware.design.HardwareDesign`).

    Attributes
    ----------
    status : str
        ``"unreachable"``: no currents within the limits meet the target (the nearest tip is
        reported); else as :class:`~actuator_design.hardware.design.HardwareDesign`.
    currents, start_currents, max_current : tuple of float
        A, per coil.
    coils : tuple of str
        Each coil's name: a calibration map's column name, else "coil k" (k from 1).
    power : float
        Σ R_k I_k², W (nan without resistances); ``effort`` names what was minimised.
    least_effort : bool
        The SQP ended at a least-effort point (not only a feasible one).
    """

    currents: tuple = ()
    coils: tuple = ()
    start_currents: tuple = ()
    max_current: tuple = ()
    resistance: tuple = ()
    power: float = math.nan
    effort: str = "power"
    least_effort: bool = False

    def _repr_parts(self) -> List[str]:
        return [f"currents_A=({', '.join(f'{i:.6g}' for i in self.currents)})", f"power_W={self.power:.6g}",
                *super()._repr_parts()]

    def to_dict(self) -> dict:
        """Plain data: the JSON contract of ``design --json`` on a coil scene."""
        out = self.common_dict()
        out.update({
            "effort": self.effort, "least_effort": self.least_effort,
            "coils": list(self.coils),
            "currents_A": list(self.currents), "start_currents_A": list(self.start_currents),
            "max_current_A": list(self.max_current),
            "resistance_ohm": [None if not math.isfinite(r) else r for r in self.resistance],
            "power_W": None if not math.isfinite(self.power) else self.power})
        return out


def _coils(scene: Scene) -> Sequence[CoilSource]:
    f = scene.field
    if getattr(f, "kind", "") != "sources" or scene.scales is None:
        raise ValueError("design over currents: the scene's field must come from coils (a physical scene with "
                         "`field: {type: coils}`)")
    if scene.obstacles:
        raise ValueError("design over currents: the scene has obstacles; a design over coil currents keeps no "
                         "clearance from them yet (solve and path model the rod in contact)")
    if not all(isinstance(s, CoilSource) for s in f.sources):
        raise ValueError("design: a permanent magnet's field cannot be designed yet (its pose is not a design "
                         "variable); give coils (`field: {type: coils}`), whose currents are designed")
    for k, s in enumerate(f.sources):
        if s.current == 0.0:
            raise ValueError(f"design over currents: coil {k + 1}'s current is 0 A; the design starts from the "
                             "configured currents, so give it a nonzero one (its sign and size start the search)")
        if not math.isfinite(s.max_current):
            raise ValueError(f"design over currents: coil {k + 1} has no max_current; give each coil its driver's "
                             "limit (e.g. 'max_current: 8 A')")
    return f.sources


def current_map(scene: Scene, options: SolverOptions) -> Tuple[Optional[CurrentMap], str]:
    """(the map over the coil weights from the configured currents' state from rest, ""), or (None,
    why there is none: that state did not converge)."""
    w0 = np.ones(len(scene.field.sources))
    start = solve(at_weights(scene, w0), options)
    if not (start.success and start.stable):
        return None, f"the state from rest at the configured currents did not converge: {start.message}"
    return CurrentMap(scene, start, w0), ""


def coil_problem(scene: Scene, target, tip_tol: float = TIP_TOL) -> CurrentProblem:
    """The SQP data of a coil scene and a target (x, y[, angle]) in rod lengths (rad)."""
    coils, f = _coils(scene), scene.field
    i0 = np.array([c.current for c in coils])
    resist = np.array([c.resistance for c in coils])
    with_r = bool(np.all(np.isfinite(resist)))
    power = resist * i0 ** 2 if with_r else None
    return CurrentProblem(target=np.asarray(target, float), cost=power if with_r else i0 ** 2,
                          bound=np.array([c.max_current for c in coils]) / np.abs(i0), power=power,
                          max_power=f.max_power, max_limit=(f.max_field / scene.scales.field) ** 2, tip_tol=tip_tol)


def scene_at_currents(scene: Scene, currents: Sequence[float]) -> Scene:
    """The coil scene at ``currents`` (A) built anew: magpylib's field refitted, its own H0, and the
    groups h, h_pos, h_r (each ∝ H0, THEORY §5, §9) rescaled — the verification's scene."""
    return refitted(scene, (replace(s, current=float(i)) for s, i in zip(scene.field.sources, currents)))


def _field_report(scene: Scene, w: np.ndarray, h2: np.ndarray):
    """(|μ0 H| T and angle rad at the clamp, largest |μ0 H| over the rod T)."""
    model = field_model(scene.field)
    hx, hy = model.evaluate([0.0], [0.0], dict(zip(model.params, w)))[:, 0]
    b0 = MU0 * scene.scales.field
    return (b0 * math.hypot(hx, hy), math.atan2(hy, hx)), b0 * math.sqrt(float(np.max(h2)))


def _corners(tol: Tolerances, w: np.ndarray, tip_jac: np.ndarray, m: int):
    """Offsets per corner: (current signs (n,), mount sign, other deltas dict)."""
    others = {a: tol_v for a, tol_v in (("youngs_rel", tol.youngs_rel), ("chi_rel", tol.chi_rel),
                                         ("fibre_angle", tol.fibre_angle)) if tol_v > 0}
    mount = tol.angle + tol.clamp_angle
    other_axes = list(others) + (["mount"] if mount > 0 else [])
    n = w.size
    if tol.field_rel <= 0:
        current_signs = [np.zeros(n)]
    elif n + len(other_axes) <= MAX_FULL_AXES:
        current_signs = [np.array(s) for s in itertools.product((-1.0, 1.0), repeat=n)]
    else:  # the linearised worst corners of each tip coordinate, both ways
        # Δw_k = rel·w_k·s_k moves tip_i by rel·Σ J_ik w_k s_k: its extremes are s = ±sign(J_ik w_k)
        current_signs = [sg * np.where(tip_jac[i] * w >= 0, 1.0, -1.0) for i in range(m) for sg in (1.0, -1.0)]
    for signs in current_signs:
        for other in itertools.product((-1.0, 1.0), repeat=len(other_axes)):
            o = dict(zip(other_axes, other))
            yield signs, o.pop("mount", 0.0) * mount, {a: s * others[a] for a, s in o.items()}


def _box(cmap: CurrentMap, w: np.ndarray, state: EquilibriumResult, tol: Tolerances, target: np.ndarray,
         tip_jac: np.ndarray, currents0: np.ndarray) -> List[dict]:
    """Every corner of the box, switched on from rest (:meth:`CurrentMap.corner`)."""
    m, out = target.size, []
    for signs, mount, deltas in _corners(tol, w, tip_jac, min(m, 2)):
        wc = w * (1 + tol.field_rel * signs)
        sc = apply_deltas(at_weights(cmap.scene, wc), deltas) if deltas else at_weights(cmap.scene, wc)
        sc = replace(sc, theta0=sc.theta0 + mount)
        c = cmap.corner(sc, state.z)
        tip = c["tip"]
        out.append({"currents_A": list(wc * currents0), "mount_deg": math.degrees(mount), **deltas,
                    "tip": {"x": tip[0], "y": tip[1], "angle": tip[2]},
                    "tip_error": float(np.max(np.abs(tip[:2] - target[:2]))),
                    "success": c["reached"], "stable": c["stable"], "same_branch": c["same_branch"]})
    return out


def design_currents(scene: Scene, target, *, tolerances: Optional[Tolerances] = None,
                    options: Optional[SolverOptions] = None, verify: bool = True, tip_tol: float = TIP_TOL,
                    progress: Optional[Callable[[str], None]] = None) -> CurrentDesign:
    """The least-effort coil currents that put the tip on ``target`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        Physical scene with a coil field (the configured currents start the design).
    target : sequence of 2 or 3 floats
        Tip x, y in rod lengths, optionally its angle in rad.
    tolerances : Tolerances, optional
        The lab's tolerance box (default ±5 % on each current, ±2° on the mount).
    options : SolverOptions, optional
    verify : bool
        Verify by an independent refit and solve from rest (a design without it is not a success).
    tip_tol : float
        Tip tolerance of the design, rod lengths.

    Returns
    -------
    CurrentDesign
        Never raises for an unreachable target (``status="unreachable"``); raises ValueError for a
        scene that has no coils or a coil without a current limit.
    """
    t0 = time.perf_counter()
    tol = tolerances if tolerances is not None else Tolerances()
    options = options or SolverOptions()
    target = np.asarray(target, float)
    if target.size not in (2, 3) or not np.all(np.isfinite(target)):
        raise ValueError(f"design: the target is x, y[, angle] (finite numbers), got {target.tolist()}")
    prob = coil_problem(scene, target, tip_tol)
    coils = scene.field.sources
    i0 = np.array([c.current for c in coils])
    out = CurrentDesign(success=False, status="not_converged", message="", target=tuple(target.tolist()),
                        coils=tuple(getattr(c, "name", "") or f"coil {k + 1}" for k, c in enumerate(coils)),
                        start_currents=tuple(i0.tolist()), max_current=tuple(c.max_current for c in coils),
                        resistance=tuple(c.resistance for c in coils), tolerances=tol,
                        effort="power" if prob.power is not None else "current_squared")
    out.notes += effort_notes(coils)
    cmap, out.message = current_map(scene, options)
    if cmap is None:
        return out
    starts = _screen(cmap, prob, _even(scene), progress)

    sqp = run_starts(cmap, prob, starts, lambda a, b: _better(prob, a, b), progress)
    if sqp is None:
        out.message = ("no start currents within the limits gave a stable state from rest (the configured "
                       "currents and the screen's ramps)")
        return out
    w, pt = first_coil_positive(scene, sqp.w, sqp.point, i0, cmap.evaluate)
    record_setting(out, scene, cmap, prob, w, pt, i0)
    out.tip_error = float(np.max(np.abs(pt["tip"][:target.size] - target)))
    out.iterations, out.least_effort = sqp.iterations, bool(sqp.converged)
    if not sqp.reached:
        out.missed(sqp, "setting of the currents within the limits")
        out.solves, out.seconds = cmap.solves, time.perf_counter() - t0
        return out
    if verify:
        verify_on(out, scene_at_currents(scene, w * i0), options)
    judge(out, _box(cmap, w, out.state, tol, target, pt["tip_jac"], i0))
    out.solves, out.seconds = cmap.solves, time.perf_counter() - t0
    out.message = _message(out)
    return out


def first_coil_positive(scene: Scene, w: np.ndarray, pt: dict, i0: np.ndarray, evaluate) -> tuple:
    """(w, its point) with, for a rod whose energy is even in the field, the sign of every current
    chosen so that the first coil carrying current carries a positive one (±I hold the same state:
    one representative); ``evaluate(w)`` re-evaluates the point where the sign flips."""
    currents = w * i0
    if _even(scene) and currents[np.argmax(np.abs(currents) > 1e-6 * np.max(np.abs(currents)))] < 0:
        return -w, evaluate(-w)
    return w, pt


def record_setting(out: CurrentDesign, scene: Scene, cmap: CurrentMap, prob: CurrentProblem, w: np.ndarray,
                   pt: dict, i0: np.ndarray) -> None:
    """Record the designed weights ``w`` and their point ``pt`` in ``out``: the currents (A), the
    state (one polishing solve), the tip (the rod's, ``tip_point`` where the point's "tip" is a fit's),
    the power, the field at the clamp and on the rod, and the limits at work."""
    out.currents = tuple((w * i0).tolist())
    out.state, out.tip = cmap.result(w, pt["z"]), pt.get("tip_point", pt["tip"])
    out.power = float(np.dot(prob.power, w * w)) if prob.power is not None else math.nan
    out.field_at_clamp, out.max_rod_field = _field_report(scene, w, pt["limit"])
    out.limits_active = _active(prob, w, pt)


def effort_notes(coils: Sequence[CoilSource]) -> List[str]:
    """A note where some coils have a resistance and others not: the effort is then Σ I_k², not the power."""
    resist = np.array([c.resistance for c in coils])
    if np.any(np.isfinite(resist)) and not np.all(np.isfinite(resist)):
        return ["not every coil has a resistance: the effort minimised is the sum of squared currents"]
    return []


def _even(scene: Scene) -> bool:
    """Whether the rod's energy is even in the field (no remanent magnetisation: the soft terms are
    quadratic in H), so currents ±I hold the same state."""
    return lens.remanent_group(scene) == 0.0


def _screen(cmap: CurrentMap, prob: CurrentProblem, even: bool, progress=None,
            miss: Optional[Callable[[np.ndarray, dict], float]] = None) -> List[np.ndarray]:
    """Start weights for the SQP: the configured currents (w = 1) and the best stations of the
    ramps from rest along :func:`_directions` out to the current limits (one walk per direction,
    :meth:`CurrentMap.ray`), at most :data:`STARTS`, nearest the target first, mutually apart.
    ``miss(w, station)`` ranks the stations (default: the largest miss of the tip's coordinates)."""
    m = prob.target.size
    dirs = _directions(prob.bound, even)
    if miss is None:
        miss = lambda w, p: float(np.max(np.abs(p["tip"][:m] - prob.target)))

    def walk(ds):  # the ramps of some directions: (weights, miss) of each station within the limits,
        n0 = cmap.solves  # and the solves they took
        return [(w, miss(w, p))
                for d in ds for w, p in cmap.ray(d, SCREEN_FRACTIONS) if within_limits(prob, w, p)], cmap.solves - n0

    base = cmap.solves
    half = forked.start(lambda: walk(dirs[len(dirs) // 2:]))
    (mine, n1), (theirs, n2) = walk(dirs[:len(dirs) // 2]), half.result()
    cmap.solves = base + n1 + n2  # each half's own count, wherever it ran
    found = [(np.ones(prob.bound.size), None)] + mine + theirs
    ranked = sorted(found[1:], key=lambda c: c[1])
    if progress is not None and ranked:
        progress(f"screen: {len(found) - 1} states from rest, the nearest {ranked[0][1]:.3g} off the target")
    chosen = [found[0][0]]
    p1 = cmap.evaluate(chosen[0])
    if p1 is not None and math.isfinite(prob.max_limit) and float(np.max(p1["limit"])) > prob.max_limit:
        # the configured currents see more field than allowed: scaled into the limit (|h| ∝ the scale,
        # up to the rod's move), they start the search instead
        chosen[0] = chosen[0] * 0.9 * math.sqrt(prob.max_limit / float(np.max(p1["limit"])))
    for w, _ in ranked:
        if len(chosen) >= STARTS:
            break
        if all(float(np.max(np.abs(w - c) / prob.bound)) > 0.1 for c in chosen):
            chosen.append(w)
    return chosen[1:] + chosen[:1]


def _directions(bound: np.ndarray, even: bool) -> List[np.ndarray]:
    """Deterministic directions in weight space, each scaled to reach a current limit: round the
    circle every 15° for two coils; ± each coil and ± each pair of coils (equal or opposite) for
    more (± each coil alone beyond :data:`PAIRED_COILS`). With ``even`` (±I hold the same state)
    only those whose first nonzero component is positive."""
    n = bound.size
    if n == 1:
        dirs = [np.array([1.0]), np.array([-1.0])]
    elif n == 2:
        dirs = [np.array([math.cos(a), math.sin(a)]) for a in np.radians(np.arange(0.0, 360.0, 15.0))]
    else:
        eye = np.eye(n)
        dirs = [sg * eye[k] for k in range(n) for sg in (1.0, -1.0)]
        if n <= PAIRED_COILS:
            dirs += [sg * (eye[i] + sj * eye[j]) for i in range(n) for j in range(i + 1, n)
                     for sg in (1.0, -1.0) for sj in (1.0, -1.0)]
    if even:
        dirs = [d for d in dirs if d[np.argmax(np.abs(d) > 1e-12)] > 0]
    return [d / float(np.max(np.abs(d) / bound)) for d in dirs]


def _better(prob: CurrentProblem, a, b) -> bool:
    """Whether SQP outcome ``a`` beats ``b``: one reaching the target beats one that does not;
    of two that reach it, the lower effort; of two that do not, the smaller miss."""
    m = prob.target.size
    miss = lambda r: float(np.max(np.abs(r.point["tip"][:m] - prob.target)))
    if a.reached != b.reached:
        return a.reached
    if a.reached:  # equal efforts (to 1e-6): the first start's, whatever the round-off
        return float(np.dot(prob.cost, a.w * a.w)) < float(np.dot(prob.cost, b.w * b.w)) * (1 - 1e-6)
    return miss(a) < miss(b) - 1e-9


def _active(prob: CurrentProblem, w: np.ndarray, pt: dict) -> List[str]:
    act = [f"coil {k + 1} current" for k in range(w.size) if abs(w[k]) >= prob.bound[k] * (1 - 1e-6)]
    if prob.power is not None and float(np.dot(prob.power, w * w)) >= prob.max_power * (1 - 1e-6):
        act.append("max_power")
    if math.isfinite(prob.max_limit) and float(np.max(pt["limit"])) >= prob.max_limit * (1 - 1e-6):
        act.append("max_field")
    return act


def _message(out: CurrentDesign) -> str:
    cur = ", ".join(f"{i:.6g} A" for i in out.currents)
    return out.closing_message(f"currents {cur} put the tip on the target (miss {out.tip_error:.2g} rod lengths)")
