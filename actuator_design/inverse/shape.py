"""Design for a target shape: points (s_i, x_i, y_i) along the centreline, fitted in least squares.

    min_{d, θ}  Σ_i |r(s_i) − (x_i, y_i)|² + w · effort(d)     s.t.  ∇Ê(θ; P(d)) = 0,

with r(s) = ∫₀^s (cos θ, sin θ) dσ evaluated exactly for the transcription's θ(s) (16-point
Gauss–Legendre on every element piece of [0, s_i]; θ at those points is a linear map of the nodal
values). The start is the single-pose design of the last point taken as a tip target; the fitted
design must be stable with the design margin (checked at the solution; the LDLᵀ certificate is
added when it is not), and it is then verified from rest like any design and evaluated over the
tolerance box (the tip's spread around its nominal position).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Sequence

import casadi as ca
import numpy as np

from actuator_design.contact.guard import refuse_contact
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.inverse.choose import choose
from actuator_design.inverse.design import design_problem, search
from actuator_design.inverse.design_map import certificate_matrix, driven_values, profile_report
from actuator_design.inverse.layout import Blocks, DesignStates, Variant, ipopt_options, outcome, profile_rows
from actuator_design.inverse.ldl import (Certificate, CertificateTooLarge, certified_hessian,
                                         check_certificate_size)
from actuator_design.inverse.nlp import DesignNLP
from actuator_design.inverse.optimise import design_vector
from actuator_design.inverse.settings import Choice, DesignSettings, normalise_phi, phi_period
from actuator_design.inverse.verify import schedule_rows
from actuator_design.inverse.verify import verify as verify_stage
from actuator_design.model.scene import Scene
from actuator_design.robust.robustness import Robustness, evaluate_robustness
from actuator_design.transcription.arc_points import arc_point_maps

__all__ = ["ShapeResult", "design_shape", "read_shape_points", "MAX_SHAPE_POINTS"]

MAX_SHAPE_POINTS = 200


def read_shape_points(text: str, scale: float = 1.0) -> np.ndarray:
    """Points of a ``s,x,y`` CSV (a header line naming s, x, y; s in [0, 1], x and y in rod lengths
    times ``1/scale``). Returns an array of shape (k, 3) sorted by s. Raises ``ValueError`` naming the
    row and the allowed range."""
    rows = [r.strip() for r in text.splitlines() if r.strip() and not r.strip().startswith("#")]
    if not rows:
        raise ValueError("--target-shape: the file is empty (expected a header s,x,y and rows)")
    head = [h.strip().lower() for h in rows[0].split(",")]
    if head[:3] != ["s", "x", "y"]:
        raise ValueError(f"--target-shape: the header must be s,x,y, got {rows[0]!r}")
    pts = []
    for i, r in enumerate(rows[1:], start=2):
        try:
            s, x, y = (float(v) for v in r.split(",")[:3])
        except ValueError:
            raise ValueError(f"--target-shape: row {i}: expected three numbers s,x,y, got {r!r}") from None
        if not (0.0 < s <= 1.0 and math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"--target-shape: row {i}: s must lie in (0, 1] and x, y be finite, got {r!r}")
        pts.append((s, x * scale, y * scale))
    if not 1 <= len(pts) <= MAX_SHAPE_POINTS:
        raise ValueError(f"--target-shape: 1 to {MAX_SHAPE_POINTS} points, got {len(pts)}")
    arr = np.array(sorted(pts))
    if np.any(np.diff(arr[:, 0]) <= 0):
        raise ValueError("--target-shape: the arc lengths s must be distinct")
    for s, x, y in arr:
        if math.hypot(x, y) > s + 1e-12:
            raise ValueError(f"--target-shape: the point at s = {s:g} lies {math.hypot(x, y):.3g} from the clamp, "
                             f"farther than the arc length s: no inextensible rod reaches it")
    return arr


class ShapeDesignNLP:
    """The least-squares shape NLP for a design NLP's variables and fixed arc lengths s_i."""

    def __init__(self, base: DesignNLP, s_points: Sequence[float]):
        sv, lay = base.solver, base.solver.layout
        n, sl = base.n, lay.slices
        L, W = arc_point_maps(sv.transcription, s_points)  # θ(σ) = L z, x_i = W cos θ(σ)
        d, P0 = ca.SX.sym("d", base.nd), ca.SX.sym("P0", lay.size)
        # the design NLP's map: a designed h moves the groups the field drives (h_r, h_pos) with it
        states = DesignStates(sv, base.dmap, d, P0, base.vandermonde)
        zr, state = states.z[0], states.rows[0]
        th = ca.mtimes(ca.DM(L), ca.vertcat(P0[sl["theta0"]], zr))
        xs, ys = ca.mtimes(ca.DM(W), ca.cos(th)), ca.mtimes(ca.DM(W), ca.sin(th))
        tx, ty = ca.SX.sym("tx", len(s_points)), ca.SX.sym("ty", len(s_points))
        m = state.mass
        effort = base.dmap.effort(d)
        w_eff, margin = ca.SX.sym("w_eff"), ca.SX.sym("margin")
        f = ca.sumsqr(xs - tx) + ca.sumsqr(ys - ty) + w_eff * effort
        self.base, self.n, self.k = base, n, len(s_points)
        self._theta, self._d = zr, d
        self._p = ca.vertcat(P0, tx, ty, w_eff, margin)
        self._f = f
        self._eq, self._profiles = state.eq, profile_rows(base.vandermonde, base.values(d), base.profiles)
        self._certificate = (m, state.hessian, margin)  # (built with the certified NLP)
        self._variants: Dict[bool, Variant] = {}
        self.f_points = ca.Function("shape_points", [zr, P0], [xs, ys])

    def nlpsol(self, certified: bool):
        """The shape NLP without or with the stability certificate (built on first use)."""
        return self._variant(certified).solver

    def _variant(self, certified: bool) -> Variant:
        if certified:
            check_certificate_size(self.base.solver, self.n, exact_hessian=False)
        if certified not in self._variants:
            xs, rows, cert, schur = Blocks(), Blocks(), None, None
            xs.add("theta", self._theta)
            xs.add("d", self._d)
            rows.add("eq", self._eq, 0.0, 0.0)
            if certified:  # the pivots, and the Schur entries lifted at the element joints
                m, H, margin = self._certificate
                cert = Certificate([certificate_matrix(H, m, margin)])
                schur = ca.Function("schur", [xs.vector(), self._p, cert.v], [cert.schur])
                xs.add("lifted", cert.v)
                rows.add("pivots", cert.pivots, 0.0, np.inf)
                rows.add("lifted", cert.rows, 0.0, 0.0)
            rows.add("profiles", self._profiles)  # bounded by the request (DesignNLP.profile_bounds)
            # a least-squares objective is tiny near a good fit (1e-14 at 1e-7 rms): scale it so that
            # IPOPT's stopping test resolves the fit, not just the equilibrium
            opts = ipopt_options(tol=1e-12, acceptable_tol=1e-9, max_iter=400, obj_scaling_factor=1e4,
                                 **(certified_hessian(self.base.solver, self.n) if certified else {}))
            nlp = ca.nlpsol("shape_design", "ipopt", {"x": xs.vector(), "p": self._p, "f": self._f,
                                                      "g": rows.vector()}, opts)
            self._variants[certified] = Variant(nlp, xs, rows, cert, schur)
        return self._variants[certified]

    def solve(self, base_scene: Scene, points: np.ndarray, d0, z0, *, margin, bounds, certified=False):
        b, n = self.base, self.n
        sv = b.solver
        P0 = sv.parameter_vector(base_scene)
        p = np.concatenate([P0, points[:, 1], points[:, 2], [1e-12, margin]])  # w: a tie-break only
        if certified:
            try:
                check_certificate_size(sv, n, exact_hessian=False)
            except CertificateTooLarge as err:
                return np.asarray(d0, float), np.asarray(z0, float), False, str(err)
        nlp, xs, rows, cert, schur = self._variant(certified)
        lbx, ubx = xs.bounds(d=b.variable_bounds(bounds))
        lbg, ubg = rows.bounds(profiles=b.profile_bounds(bounds))
        x0 = np.concatenate([np.asarray(z0, float)[1:], d0])
        if cert is not None and cert.m:
            x0 = np.concatenate([x0, cert.start(schur, x0, p)])
        sol = nlp(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        ok, status = outcome(nlp)
        x = np.asarray(sol["x"], float).ravel()
        theta0 = float(P0[sv.layout.slices["theta0"]][0])
        return x[xs["d"]], np.concatenate([[theta0], x[:n]]), ok, status


@dataclass
class ShapeResult:
    """Outcome of :func:`design_shape` (dimensionless; angles in rad).

    points : the target points, shape (k, 3): s, x, y.
    fitted : the design's centreline at the same s, shape (k, 2) (the verified state when verified).
    rms_error, max_error : of |r(s_i) − target_i|, units of ℓ.
    """

    success: bool
    points: np.ndarray
    fitted: np.ndarray
    rms_error: float
    max_error: float
    design: Dict[str, object]
    vary: tuple
    verified: bool
    stable: bool
    snap_free: bool
    schedule: List[Dict[str, float]]
    robustness: Optional[Robustness]
    message: str
    scene: Scene
    design_scene: Optional[Scene] = None
    state: object = field(default=None, repr=False)
    timings: Dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"success": bool(self.success),
                "shape": {"points": [{"s": float(s), "x": float(x), "y": float(y)} for s, x, y in self.points],
                          "fitted": [{"x": float(x), "y": float(y)} for x, y in self.fitted],
                          "rms_error": float(self.rms_error), "max_error": float(self.max_error)},
                "design": self.design, "vary": list(self.vary), "verified": bool(self.verified),
                "stable": bool(self.stable), "snap_free": bool(self.snap_free), "schedule": self.schedule,
                "robustness": None if self.robustness is None else self.robustness.to_dict(),
                "message": self.message, "timings_s": self.timings,
                "units": {"length": "rod length", "angle": "rad", "h": "dimensionless field group"}}


def design_shape(points: np.ndarray, scene: Optional[Scene] = None, vary: Optional[Sequence[str]] = None,
                 options: Optional[SolverOptions] = None, settings: Optional[DesignSettings] = None,
                 verify: bool = True) -> ShapeResult:
    """The design whose centreline passes nearest the points (s_i, x_i, y_i), least squares.

    ``success`` needs the fit within ``settings.accept_tol`` (rms, units of ℓ), a verified stable
    snap-free path from rest and, with a tolerance box, the design holding over it (tip spread).
    """
    t0 = time.perf_counter()
    timings: Dict[str, float] = {}
    pts = np.asarray(points, float)
    settings = settings or DesignSettings()
    last = pts[-1]
    # the start: the single-pose design of the last point taken as a tip target
    refuse_contact(scene, "design --target-shape")
    problem = design_problem((last[1], last[2]), scene, vary, options, settings, None, t0)
    vset = problem.variable_sets[-1]
    problem = replace(problem, variable_sets=(vset,))
    ch = choose(problem, search(problem, timings))
    if ch is None:
        return _failed(pts, problem, vset, "no stable start for the shape fit", timings)
    nlp, base = ch.candidate.nlp, ch.candidate.base
    shape_nlp = ShapeDesignNLP(nlp, pts[:, 0])
    d, z, ok, status = shape_nlp.solve(base, pts, design_vector(nlp, ch.point), ch.point.z,
                                       margin=settings.margin, bounds=settings.bounds())
    sv = nlp.solver
    sc = nlp.scene_for(base, d)
    if ok and sv.stability(z, sv.parameter_vector(sc)).eigenvalues[0] < settings.margin:
        d, z, ok, status = shape_nlp.solve(base, pts, design_vector(nlp, ch.point), ch.point.z,
                                           margin=settings.margin, bounds=settings.bounds(), certified=True)
        sc = nlp.scene_for(base, d)
    timings["fit"] = time.perf_counter() - t0
    if not ok:
        return _failed(pts, problem, vset, f"the shape fit did not converge ({status})", timings)
    P = sv.parameter_vector(sc)
    _, th, x, y = sv.summary(z, P)
    pt = nlp.point(d, sc, z, np.array([x, y, th]), converged=True, status=status, stage="shape")
    xs, ys = (np.asarray(v, float).ravel() for v in shape_nlp.f_points(z[1:], sv.parameter_vector(sc)))
    tol = settings.tolerances
    rob = evaluate_robustness(sc, z, None, tol, problem.options) if tol.active else None
    verified = stable = snap_free = False
    schedule, label, state = [], "not verified (skipped)", None
    if verify:
        v = verify_stage(problem, Choice(point=pt, candidate=ch.candidate, scene=sc, reachable=True, notes=[],
                                         alternatives={}, optima=[]))
        label = v.label
        if v.path is not None:
            state = v.path.final
            verified, stable, snap_free = True, bool(state.stable), bool(v.path.snap_free)
            schedule = schedule_rows(v.schedule)
            ev = state.evaluate(pts[:, 0])
            xs, ys = np.asarray(ev["x"], float), np.asarray(ev["y"], float)
    err = np.hypot(xs - pts[:, 1], ys - pts[:, 2])
    rms, mx = float(np.sqrt(np.mean(err ** 2))), float(err.max())
    ok = verified and stable and snap_free and rms <= settings.accept_tol and (rob is None or rob.holds)
    notes = [f"least-squares fit of {len(pts)} points: rms error {rms:.3g}, largest {mx:.3g} rod lengths",
             label if verify else "not verified (skipped)"]
    if rms > settings.accept_tol:
        notes.append(f"not a success: the fit misses the shape by {rms:.3g} rms (> {settings.accept_tol:g}); "
                     f"this is the nearest shape of {', '.join(vset)}")
    if rob is not None:
        notes.append(("holds" if rob.holds else "does NOT hold") + f" over the box: the tip moves by at most "
                     f"{rob.worst_tip_error:.3g}; {rob.fold_distance.sentence()}")
    design = {"h": pt.h, "phi": normalise_phi(pt.phi, phi_period(sc)), "p": pt.p,
              **profile_report(sc, pt.profiles, vset),  # α(s), and β(s) when designed (THEORY §9)
              **driven_values(sc)}  # the other groups at the design field (THEORY §5, §9)
    timings["total"] = time.perf_counter() - t0
    return ShapeResult(ok, pts, np.column_stack([xs, ys]), rms, mx, design, vset, verified, stable, snap_free,
                       schedule, rob, "; ".join(notes), problem.base, sc, state, timings)


def _failed(pts, problem, vset, message, timings) -> ShapeResult:
    return ShapeResult(False, pts, np.full((len(pts), 2), np.nan), float("inf"), float("inf"), {}, vset, False,
                       False, False, [], None, message, problem.base, timings=timings)
