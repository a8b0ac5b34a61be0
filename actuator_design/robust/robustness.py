"""Does a design hold over the lab's tolerance box? Branch following, not re-solving from rest.

A design is an equilibrium on one branch. Over the tolerance box (:mod:`actuator_design.robust.tolerances`) the real
actuator stays on that branch as long as the branch exists and is stable; it snaps where the branch
ends (a fold) or loses stability (a branch point). So the box is checked by *following the branch*
with warm-started Newton steps from the nominal design:

* along a ray from the nominal point to every corner, and along every edge of the box (for up to
  three active tolerances; with more, rays only), recording the tip and the smallest eigenvalue of
  the reduced Hessian at every accepted step — the worst tip error is the largest over all of them;
* along each axis (field magnitude up and down, field angle both ways) until the branch ends or
  loses stability: the distance to the nearest snap (``fold_distance``).

A step is accepted only when Newton converges (small residual and small step, the solver's rules),
the state moved by at most ``max_dtheta`` rad at every node (else it jumped to another branch) and
the state is stable; otherwise the step is halved. A segment fails when the step falls below
``min_step`` (a fraction of the segment): the fold or stability loss is then located to that
precision. Each segment is a run of the continuation engine's natural-parameter algorithm
(:class:`~actuator_design.continuation.secant.Secant`, with ``Fold(stop=True)`` and a refusing
``StabilityLoss``). A re-solve from rest at the perturbed scene would answer a different question (where
the rod goes from straight), and can land on another branch.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from dataclasses import replace as _replace
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from actuator_design.contact.clearance import clearance_check
from actuator_design.continuation.engine import continuation
from actuator_design.continuation.events import Fold, StabilityLoss
from actuator_design.continuation.secant import Secant, StatePath
from actuator_design.continuation.settings import ContinuationSettings
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import EquilibriumSolver, get_solver
from actuator_design.model.scene import Scene, UniformField
from actuator_design.robust.snap_location import locate_snap, snap_builds, snap_unit
from actuator_design.robust.tolerances import Tolerances, apply_deltas, axis_label, perturb

__all__ = ["Segment", "follow_segment", "FoldDistance", "Robustness", "evaluate_robustness", "fold_search_builds"]


@dataclass
class Segment:
    """The branch followed from parameters P_a (t = 0) towards P_b (t = 1).

    completed : the whole segment was followed on a stable branch.
    t_end : the last accepted t (1 when completed); a failure lies in (t_end, t_end + min_step].
    z_end : θ at the nodes at t_end.
    samples : list of (t, x(1), y(1), θ(1), λ_min) at every accepted step, t = 0 included.
    reason : why it stopped ("" when completed): "fold or stability loss", "no convergence".
    """

    completed: bool
    t_end: float
    z_end: np.ndarray
    samples: List[Tuple[float, float, float, float, float]]
    reason: str = ""


def _newton(solver: EquilibriumSolver, z_guess: np.ndarray, z_prev: np.ndarray, P: np.ndarray):
    raw = solver.solve_fast(z_guess, P)
    if not raw.converged:
        raw = solver.solve_newton(z_prev, P, max_iter=40)
    return raw


def follow_segment(solver: EquilibriumSolver, z0: np.ndarray, P_a: np.ndarray, P_b: np.ndarray, *,
                   first_step: float = 0.125, max_step: float = 0.25, min_step: float = 1e-7,
                   max_dtheta: float = 0.2, max_steps: int = 2000, admissible=None) -> Segment:
    """Follow the equilibrium branch through ``z0`` along P(t) = (1 − t) P_a + t P_b, t ∈ [0, 1].

    Parameters
    ----------
    solver : EquilibriumSolver
        Built for the scene structure of P_a and P_b.
    z0 : ndarray, shape (n_nodes,)
        An equilibrium at P_a (θ at the nodes, rad).
    P_a, P_b : ndarray, shape (n_params,)
        Parameter vectors of the two ends.
    first_step, max_step, min_step : float
        Step control in t (a fraction of the segment).
    max_dtheta : float
        Largest change of θ at any node in one accepted step, rad (larger: another branch).
    max_steps : int
        Bound on the work (accepted and rejected steps together).
    admissible : callable, optional
        θ at the nodes → bool: whether a state keeps clear of the scene's obstacles
        (:func:`~actuator_design.contact.clearance.clearance_check`); the first state that does not ends
        the segment (reason "touches an obstacle": the free branch followed is no longer the rod's).

    Returns
    -------
    Segment
    """
    path = _SegmentPath(solver, np.asarray(P_a, float), np.asarray(P_b, float), admissible)
    z = np.asarray(z0, float).copy()
    path.record(0.0, z, P_a, float(solver.stability(z, P_a).eigenvalues[0]))
    settings = ContinuationSettings(ds=first_step, ds_min=min_step, ds_max=max_step, max_steps=max_steps,
                                    window=(0.0, 1.0), max_du=max_dtheta)
    run = continuation(path, Secant(growth=1.5), settings, [Fold(stop=True), StabilityLoss()], x0=z)
    return Segment(run.reached, run.lam, run.z, path.samples, run.reason)


class _SegmentPath(StatePath):
    """P(t) = (1 − t) P_a + t P_b on one stable branch (:func:`follow_segment`)."""

    def __init__(self, solver, P_a, P_b, admissible):
        self.solver, self.P_a, self.P_b, self.clear = solver, P_a, P_b, admissible
        self.samples: List[Tuple[float, float, float, float, float]] = []

    def record(self, t, z, P, lam):
        _, th1, x1, y1 = self.solver.summary(z, P)
        self.samples.append((t, x1, y1, th1, lam))

    def at(self, t):
        return (1.0 - t) * self.P_a + t * self.P_b

    def correct(self, guess, z, P):
        return _newton(self.solver, guess, z, P)

    def admissible(self, z):
        return self.clear is None or self.clear(z)

    def stability(self, z, P):
        verdict = self.solver.stability(z, P)
        return not verdict.stable, verdict

    def failure_reason(self, run):
        first, last = self.samples[0][4], self.samples[-1][4]
        return "fold or stability loss" if last < 1e-2 * max(1.0, abs(first)) else "no convergence"

    def accepted(self, run, P, verdict):
        self.record(run.lam, run.z, P, float(verdict.eigenvalues[0]))


#: how :meth:`FoldDistance.sentence` names a search axis
_AXIS_WORDS = {"h_rel_up": "more field", "h_rel_down": "less field", "phi_deg_ccw": "angle counter-clockwise",
               "phi_deg_cw": "angle clockwise"}


@dataclass
class FoldDistance:
    """Distance from the design to the nearest snap along each axis (None: none within ``search``).

    h_rel_up / h_rel_down : relative field change (0.071 = 7.1 % more / less field).
    phi_deg_ccw / phi_deg_cw : field-angle change, degrees (uniform fields only).
    search : the range searched per axis, {"h_rel_up": ..., ...}.
    errors : per axis with a snap, the estimated discretisation error of its distance (same unit),
        or None where the snap could not be located as a fold and refined on finer meshes (then
        the distance is the last stable point of the branch following on the design mesh):
        :mod:`actuator_design.robust.snap_location`.
    touches : the axes whose search stopped where the rod would touch an obstacle (the free
        branch is no longer the rod's beyond; ``search`` then holds the range up to the touch).
    """

    h_rel_up: Optional[float]
    h_rel_down: Optional[float]
    phi_deg_ccw: Optional[float]
    phi_deg_cw: Optional[float]
    search: Dict[str, float]
    errors: Dict[str, Optional[float]] = field(default_factory=dict)
    touches: Tuple[str, ...] = ()

    @property
    def h_rel(self) -> Optional[float]:
        vals = [v for v in (self.h_rel_up, self.h_rel_down) if v is not None]
        return min(vals) if vals else None

    @property
    def phi_deg(self) -> Optional[float]:
        vals = [v for v in (self.phi_deg_ccw, self.phi_deg_cw) if v is not None]
        return min(vals) if vals else None

    def to_dict(self) -> dict:
        return {"h_rel": self.h_rel, "phi_deg": self.phi_deg, "h_rel_up": self.h_rel_up,
                "h_rel_down": self.h_rel_down, "phi_deg_ccw": self.phi_deg_ccw,
                "phi_deg_cw": self.phi_deg_cw, "searched": dict(self.search),
                "errors": dict(self.errors), "touches": list(self.touches)}

    def sentence(self) -> str:
        """E.g. "the nearest snap is 7.1 % more field or 3.4 deg of angle (clockwise) away"."""
        parts, none = [], []
        if self.h_rel is not None:
            more = self.h_rel_up is not None and self.h_rel == self.h_rel_up
            parts.append(f"{100 * self.h_rel:.3g} % {'more' if more else 'less'} field")
        elif "h_rel_up" in self.search:
            none.append(f"{100 * self.search['h_rel_up']:.3g} % more or {100 * self.search['h_rel_down']:.3g} "
                        f"% less field")
        if self.phi_deg is not None:
            ccw = self.phi_deg_ccw is not None and self.phi_deg == self.phi_deg_ccw
            parts.append(f"{self.phi_deg:.3g} deg of angle ({'counter-clockwise' if ccw else 'clockwise'})")
        elif "phi_deg_ccw" in self.search:
            ccw, cw = self.search["phi_deg_ccw"], self.search.get("phi_deg_cw", self.search["phi_deg_ccw"])
            none.append(f"{ccw:.3g} deg of angle either way" if f"{ccw:.3g}" == f"{cw:.3g}" else
                        f"{ccw:.3g} deg of angle counter-clockwise or {cw:.3g} deg clockwise")
        text = ("the nearest snap is " + " or ".join(parts) + " away") if parts else ""
        rough = [k for k, v in (("h_rel_up", self.h_rel_up), ("h_rel_down", self.h_rel_down),
                                ("phi_deg_ccw", self.phi_deg_ccw), ("phi_deg_cw", self.phi_deg_cw))
                 if v is not None and self.errors.get(k) is None and v in (self.h_rel, self.phi_deg)]
        if rough:
            text += " (the last stable point on the design mesh: not located as a fold)"
        if none:
            text += ("; " if text else "") + "no snap within " + " nor ".join(none)
        if self.touches:
            text += (" (the search stops where the rod would touch an obstacle: "
                     + ", ".join(_AXIS_WORDS[k] for k in self.touches) + ")")
        return text or "no snap searched"


@dataclass
class Robustness:
    """How a design holds over a tolerance box (the ``robustness`` object of ``design --json``).

    Attributes
    ----------
    tolerances : Tolerances
    worst_tip_error : float
        Largest |tip − target| (units of ℓ) over every state followed in the box, plus
        ``discretisation_error``; the tip angle's error is ``worst_angle_error`` (rad) when the
        target has an angle.
    discretisation_error : float
        Largest change of the tip when the nominal and corner states are re-solved on a mesh with
        twice the elements (an estimate of the mesh's tip error, units of ℓ).
    stable_over_box : bool
        Every ray and edge was followed to its end on a stable branch.
    min_eigenvalue : float
        Smallest λ_min(H_r, M) met in the box.
    corners : list of dict
        Per corner: offset (signed fractions of the half-widths), tip (x, y, angle), error, λ_min,
        reached.
    fold_distance : FoldDistance
    spread : ndarray, shape (k, 2)
        Every tip position followed in the box (for the figure).
    corner_states : list of ndarray or None
        θ at the nodes at each corner (None where the corner was not reached), for checks.
    failures : list of str
        Where the branch was lost inside the box.
    """

    tolerances: Tolerances
    worst_tip_error: float
    discretisation_error: float
    worst_angle_error: Optional[float]
    stable_over_box: bool
    min_eigenvalue: float
    corners: List[dict]
    fold_distance: FoldDistance
    spread: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 2)))
    failures: List[str] = field(default_factory=list)
    corner_states: List[Optional[np.ndarray]] = field(repr=False, default_factory=list)

    @property
    def holds(self) -> bool:
        """Stable over the whole box and no snap inside it."""
        fd, tol = self.fold_distance, self.tolerances
        inside = ((fd.h_rel is not None and fd.h_rel <= tol.field_rel)
                  or (fd.phi_deg is not None and fd.phi_deg <= math.degrees(tol.angle)))
        return self.stable_over_box and not inside

    def to_dict(self) -> dict:
        return {"worst_tip_error": self.worst_tip_error, "discretisation_error": self.discretisation_error,
                "worst_angle_error": self.worst_angle_error,
                "stable_over_box": self.stable_over_box, "holds": self.holds,
                "min_eigenvalue": self.min_eigenvalue, "fold_distance": self.fold_distance.to_dict(),
                "corners": self.corners, "failures": list(self.failures)}

    def summary(self) -> str:
        box = self.tolerances.describe()
        head = (f"holds over the box ({box}): worst tip error {self.worst_tip_error:.3g}" if self.holds
                else f"does NOT hold over the box ({box})" + (f": {self.failures[0]}" if self.failures else ""))
        return f"{head}; {self.fold_distance.sentence()}"


def _fold_axes(scene: Scene) -> List[str]:
    """The axes the fold search follows: the field magnitude (unless there is no field) and, in a
    uniform field, its angle."""
    return [attr for attr, searched in (("field_rel", scene.h != 0.0), ("angle", isinstance(scene.field, UniformField)))
            if searched]


def fold_search_builds(scene: Scene, options: Optional[SolverOptions] = None) -> List[Callable[[], None]]:
    """The solver builds of :func:`evaluate_robustness`'s fold search of ``scene``, as steps to
    run ahead of need (:func:`~actuator_design.robust.snap_location.snap_builds`)."""
    return snap_builds(scene, options or SolverOptions(), _fold_axes(scene))


def _axis_offsets(tol: Tolerances) -> Dict[str, Tuple[str, float, float]]:
    """Fold searches: name -> (tolerance attribute, sign, search range in that attribute's unit)."""
    out = {"h_rel_up": ("field_rel", 1.0, 1.0), "h_rel_down": ("field_rel", -1.0, 0.9)}
    out["phi_deg_ccw"] = ("angle", 1.0, math.pi / 2)
    out["phi_deg_cw"] = ("angle", -1.0, math.pi / 2)
    return out


def _edges(corners: List[Dict[str, float]]) -> List[Tuple[int, int]]:
    """Pairs of corners that differ in exactly one sign (the box's edges)."""
    out = []
    for i, a in enumerate(corners):
        for j in range(i + 1, len(corners)):
            if sum(a[k] != corners[j][k] for k in a) == 1:
                out.append((i, j))
    return out


def evaluate_robustness(scene: Scene, z: np.ndarray, target: Optional[Sequence[float]],
                        tolerances: Tolerances, options: Optional[SolverOptions] = None, *,
                        fold_search: bool = True) -> Robustness:
    """Follow the design's branch over the tolerance box and to the nearest snap along each axis.

    Parameters
    ----------
    scene : Scene
        The nominal design scene (dimensionless).
    z : ndarray, shape (n_nodes,)
        The design's equilibrium (θ at the nodes of ``options``' transcription, rad).
    target : (x, y) or (x, y, angle), optional
        Tip target, units of ℓ (angle in rad); ``None`` measures the spread around the nominal tip.
    tolerances : Tolerances
    options : SolverOptions, optional
    fold_search : bool
        Also search the distance to the nearest snap (field magnitude both ways, and the angle for
        uniform fields).

    Returns
    -------
    Robustness
    """
    options = options or SolverOptions()
    solver = get_solver(scene, options)
    P0 = solver.parameter_vector(scene)
    z = np.asarray(z, float)
    _, th0, x0, y0 = solver.summary(z, P0)
    ref = np.array([x0, y0, th0] if target is None else
                   [target[0], target[1], target[2] if len(target) > 2 else np.nan], float)

    def errors(samples):
        arr = np.array(samples)
        pos = np.hypot(arr[:, 1] - ref[0], arr[:, 2] - ref[1])
        ang = np.abs(np.angle(np.exp(1j * (arr[:, 3] - ref[2])))) if np.isfinite(ref[2]) else None
        return arr, pos, ang

    all_samples: List[Tuple[float, float, float, float, float]] = list()
    failures: List[str] = []
    corners = tolerances.corners() if tolerances.active else []
    corner_z: List[Optional[np.ndarray]] = []
    corner_out: List[dict] = []
    Pc = [solver.parameter_vector(perturb(scene, tolerances, c)) for c in corners]
    # with obstacles: the free branch is the rod's only while it keeps clear of them
    clear = clearance_check(solver, scene.obstacles, scene.contact_gap)
    for c, P in zip(corners, Pc):
        seg = follow_segment(solver, z, P0, P, admissible=clear)
        all_samples += seg.samples
        corner_z.append(seg.z_end if seg.completed else None)
        last = seg.samples[-1]
        err = float(math.hypot(last[1] - ref[0], last[2] - ref[1]))
        corner_out.append({"offset": {k: float(v) for k, v in c.items()}, "reached": seg.completed,
                           "tip": {"x": last[1], "y": last[2], "angle": last[3]},
                           "error": err, "min_eigenvalue": float(min(s[4] for s in seg.samples))})
        if not seg.completed:
            failures.append(f"the branch is lost ({seg.reason}) on the way to the corner "
                            f"{_describe_offset(c, tolerances)} at {100 * seg.t_end:.3g} % of the way")
    if len(tolerances.active) <= 3:
        for i, j in _edges(corners):
            if corner_z[i] is None:
                continue
            seg = follow_segment(solver, corner_z[i], Pc[i], Pc[j], admissible=clear)
            all_samples += seg.samples
            if not seg.completed:
                failures.append(f"the branch is lost ({seg.reason}) on the edge from "
                                f"{_describe_offset(corners[i], tolerances)} to "
                                f"{_describe_offset(corners[j], tolerances)}")
    disc = _discretisation_error(scene, tolerances, [z] + corner_z, [{}] + corners, solver, options)
    if not all_samples:
        lam = float(solver.stability(z, P0).eigenvalues[0])
        all_samples = [(0.0, x0, y0, th0, lam)]
    arr, pos, ang = errors(all_samples)

    search: Dict[str, float] = {}
    touches: List[str] = []
    found: Dict[str, Optional[float]] = {}
    errors: Dict[str, Optional[float]] = {}
    if fold_search:
        for name, (attr, sign, rng) in _axis_offsets(tolerances).items():
            if attr not in _fold_axes(scene):
                continue
            P_end = solver.parameter_vector(apply_deltas(scene, {attr: sign * rng}))
            seg = follow_segment(solver, z, P0, P_end, first_step=0.01, max_step=0.05, admissible=clear)
            unit = snap_unit(attr)
            search[name] = rng * unit
            if seg.completed or seg.reason == "touches an obstacle":  # searched up to the touch only
                search[name] = (1.0 if seg.completed else seg.t_end) * rng * unit
                if not seg.completed:
                    touches.append(name)
                found[name] = None
                continue
            snap = locate_snap(scene, options, seg.z_end, seg.t_end, attr, sign, rng)
            found[name] = snap.t * rng * unit
            errors[name] = None if snap.error is None else snap.error * rng * unit
    fd = FoldDistance(found.get("h_rel_up"), found.get("h_rel_down"), found.get("phi_deg_ccw"),
                      found.get("phi_deg_cw"), search, errors, tuple(touches))
    return Robustness(tolerances=tolerances, worst_tip_error=float(pos.max()) + disc,
                      discretisation_error=disc,
                      worst_angle_error=None if ang is None else float(ang.max()),
                      stable_over_box=not failures, min_eigenvalue=float(arr[:, 4].min()),
                      corners=corner_out, fold_distance=fd, spread=arr[:, 1:3].copy(), failures=failures,
                      corner_states=corner_z)


def _discretisation_error(scene, tol, states, offsets, solver, options) -> float:
    """Largest tip change when each state is re-solved, warm, on a mesh with twice the elements.

    The refined mesh's error is smaller by ~2^(2d) (LGL) or 4 (midpoint), so the change estimates
    the default mesh's tip error."""
    fine = _replace(options, elements=2 * options.elements, accuracy=None)
    fine_solver = None
    worst = 0.0
    for z, off in zip(states, offsets):
        if z is None:
            continue
        sc = perturb(scene, tol, off) if off else scene
        fine_solver = fine_solver or get_solver(sc, fine)
        theta, _ = solver.transcription.theta_dense(z, fine_solver.transcription.nodes)
        P = solver.parameter_vector(sc)
        _, _, x, y = solver.summary(z, P)
        raw = fine_solver.solve_newton(theta, fine_solver.parameter_vector(sc))
        if not raw.converged:
            return float("inf")
        _, _, xf, yf = fine_solver.summary(raw.z, fine_solver.parameter_vector(sc))
        worst = max(worst, math.hypot(x - xf, y - yf))
    return worst


def _describe_offset(offset: Dict[str, float], tol: Tolerances) -> str:
    parts = []
    for attr, sgn in offset.items():
        label, rel = axis_label(attr)
        v = sgn * getattr(tol, attr)
        parts.append(f"{label} {100 * v:+.3g} %" if rel else f"{label} {math.degrees(v):+.3g} deg")
    return "(" + ", ".join(parts) + ")"
