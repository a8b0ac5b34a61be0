"""Inverse design: the field (and fibre layout, tip load) that puts the tip where the user wants it,
as a stable state the real actuator reaches from rest.

The pipeline of :func:`design`:

1. **Screen** a grid of starting designs with forward solves (stable states by construction) and
   keep the few whose tip is nearest the target.
2. **Optimise** from each with the design NLP (:mod:`.design_nlp`): stage A finds the nearest
   reachable pose, stage B the least-effort design that reaches the target exactly. Distinct local
   optima are kept.
3. **Choose variables automatically** when the user does not: field magnitude and angle first; when
   they cannot reach the target, the fibre layout α(s) is added (and the report says so).
4. **Verify independently**, never with the design NLP's own state: a fresh forward solve, and a
   quasi-static loading path from zero field to the design (a magnitude ramp at the designed angle,
   or, where that lands on another branch, a ramp at another angle followed by a rotation of the
   field). A design counts only if such a path reaches it without a snap and it is stable.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..equilibrium import solve
from ..options import SolverOptions
from ..result import EquilibriumResult
from ..scene import Scene, default_scene
from .design_nlp import DESIGN_VARIABLES, DesignNLP, DesignPoint, DesignRequest, get_design_nlp, prepare_scene
from .registry import register

__all__ = ["design", "DesignResult", "DesignSettings", "AUTO_VARIABLE_SETS"]

#: Variable sets tried in order when the user does not choose (``--vary`` omitted).
AUTO_VARIABLE_SETS = (("h", "phi"), ("h", "phi", "alpha"))


@dataclass(frozen=True)
class DesignSettings:
    """Bounds and tolerances of a design (dimensionless, THEORY §5).

    h_max : largest field group h allowed.
    p_max : largest |p| allowed when the tip load is designed.
    alpha_max : largest |α(s)| (rad), a fabrication limit on the fibre angle.
    alpha_terms : Legendre coefficients of α(s) (smooth layouts with few parameters).
    margin : required stability margin μ: λ_min(H_r, M) ≥ μ.
    reach_tol : a target is reachable when the nearest pose is within this distance (units of ℓ).
    accept_tol : the verified achieved tip must be within this distance of the target.
    ramp_steps : points of each leg (ramp, rotation) of a verification schedule; the path follower
        refines between them (steps of ≤ 1/4 of a leg segment and ≤ 0.5 rad of shape change).
    """

    h_max: float = 10.0
    p_max: float = 20.0
    alpha_max: float = math.pi / 2
    alpha_terms: int = 4
    margin: float = 1e-2
    reach_tol: float = 1e-6
    accept_tol: float = 1e-3
    ramp_steps: int = 20

    def bounds(self) -> Dict[str, float]:
        return {"h_max": self.h_max, "p_max": self.p_max, "alpha_max": self.alpha_max}


@dataclass
class DesignResult:
    """Outcome of :func:`design`; :meth:`to_dict` is the ``design --json`` contract.

    ``schedule`` is the verified path from zero field, a list of ``{"h", "phi"[, "p"]}``; its angles
    are continuous (a rotating field is not wrapped), so its last φ may differ from ``design["phi"]``
    (reported in (−π/2, π/2]) by a multiple of π — the same field axis, as the energy depends on
    cos²(θ + α − φ) only.
    """

    success: bool
    reachable: bool
    verified: bool
    stable: bool
    snap_free: bool
    target: Tuple[float, ...]
    achieved: Dict[str, float]
    error: float
    design: Dict[str, object]
    vary: Tuple[str, ...]
    schedule: List[Dict[str, float]]
    message: str
    scene: Scene
    design_scene: Optional[Scene] = None
    forward: Optional[EquilibriumResult] = None
    path: object = None
    optima: List[Dict[str, object]] = field(default_factory=list)
    stability_margin: float = float("nan")
    alternatives: Dict[str, bool] = field(default_factory=dict)
    timings: Dict[str, float] = field(default_factory=dict)
    stiffness_target: Optional[float] = None
    achieved_stiffness: Optional[float] = None

    def to_dict(self) -> Dict[str, object]:
        tgt = {} if not self.target else {"x": self.target[0], "y": self.target[1]}
        if len(self.target) > 2:
            tgt["angle"] = self.target[2]
        if self.stiffness_target is not None:
            tgt["stiffness"] = self.stiffness_target
        out = {
            "success": bool(self.success), "reachable": bool(self.reachable),
            "verified": bool(self.verified), "stable": bool(self.stable), "snap_free": bool(self.snap_free),
            "target": tgt, "achieved": {k: float(v) for k, v in self.achieved.items()},
            "error": float(self.error), "design": self.design, "schedule": self.schedule,
            "vary": list(self.vary), "message": self.message,
            "stability_margin": float(self.stability_margin), "optima": self.optima,
            "alternatives": self.alternatives, "timings_s": self.timings,
            "units": {"length": "rod length", "angle": "rad", "h": "dimensionless field group",
                      "p": "B0/l^2", "stiffness": "B0/l^3"},
        }
        if self.stiffness_target is not None:
            out["achieved_stiffness"] = self.achieved_stiffness
        sc = self.scene.scales
        if sc is not None and sc.h_per_field > 0 and math.isfinite(self.design.get("h", float("nan"))):
            # h ∝ H0: the designed field scale in A/m and as μ0H in mT
            H = self.design["h"] / sc.h_per_field
            out["physical"] = {"field_A_per_m": H, "stiffness_scale_N_per_m": sc.stiffness,
                               "field_mT": H * 4e-7 * math.pi * 1e3,
                               "tip_x_m": self.achieved.get("x", float("nan")) * sc.length,
                               "tip_y_m": self.achieved.get("y", float("nan")) * sc.length}
            if self.achieved_stiffness is not None:
                out["physical"]["stiffness_N_per_m"] = self.achieved_stiffness * sc.stiffness
        return out


# -- screening and optimisation -----------------------------------------------------------------------
def _screen(nlp: DesignNLP, base: Scene, options: SolverOptions, target, starts: List[np.ndarray],
            keep: int, stiffness: Optional[float] = None) -> List[Tuple[float, np.ndarray, np.ndarray]]:
    """Forward-solve each start; return the ``keep`` stable ones nearest the target (pose distance
    plus the relative stiffness mismatch when a stiffness is asked for)."""
    scored = []
    prev = None
    for d in starts:
        r = solve(nlp.scene_for(base, d), options, initial=prev)
        if not (r.success and r.stable):
            r = solve(nlp.scene_for(base, d), options)
        if r.success and r.stable:
            prev = r
            dist = 0.0
            if target:
                dist = math.hypot(r.tip["x"] - target[0], r.tip["y"] - target[1])
                if len(target) > 2:
                    dist = math.hypot(dist, r.tip["angle"] - target[2])
            if stiffness is not None:
                pt = DesignPoint(h=0, phi=0, coefficients=np.zeros(0), p=0, z=r.z, tip=np.zeros(3),
                                 converged=True, status="", stage="screen")
                pt.h, pt.phi, pt.p = _unpack(nlp, d, base)
                pt.coefficients = d[nlp.dslices["alpha"]] if "alpha" in nlp.vary else np.zeros(0)
                k = nlp.stiffness(base, pt)
                dist += abs(math.log(k / stiffness)) if (math.isfinite(k) and k > 0) else 1e3
            scored.append((dist, d, r.z))
    scored.sort(key=lambda t: t[0])
    chosen: List[Tuple[float, np.ndarray, np.ndarray]] = []
    for item in scored:  # keep distinct starting shapes
        if all(np.max(np.abs(item[2] - c[2])) > 0.05 for c in chosen):
            chosen.append(item)
        if len(chosen) == keep:
            break
    return chosen


def _start_grid(nlp: DesignNLP, base: Scene, settings: DesignSettings) -> List[np.ndarray]:
    """Starting designs: field magnitudes × angles over one period of φ (× fibre slopes × loads)."""
    with_alpha = "alpha" in nlp.vary
    hs = (1.5, 3.0, 5.0) if with_alpha else (0.8, 1.4, 2.2, 3.5, 5.5)
    hs = [h for h in hs if h <= settings.h_max] or [settings.h_max]
    n_phi = 8 if with_alpha else 12
    phis = np.linspace(-math.pi / 2, math.pi / 2, n_phi + 1)[1:] if "phi" in nlp.vary else [base.phi]
    slopes = [0.0]
    if with_alpha:
        slopes = [s for s in (-1.2, -0.6, 0.6, 1.2) if abs(s) <= settings.alpha_max]
    ps = [base.p] if "p" not in nlp.vary else [-2.0, 0.0, 2.0]
    out = []
    for slope in slopes:
        for p in ps:
            for h in (hs if "h" in nlp.vary else [base.h]):
                for phi in phis:
                    c = [base.fibres.value if base.fibres.kind == "constant" else 0.0, slope]
                    out.append(nlp.design_vector(h=h, phi=phi, coefficients=c, p=p))
    return out


def _unpack(nlp: DesignNLP, d: np.ndarray, base: Scene):
    get = lambda name, default: float(d[nlp.dslices[name]][0]) if name in nlp.vary else default
    return get("h", base.h), get("phi", base.phi), get("p", base.p)


def _optimise(nlp: DesignNLP, base: Scene, options, target, settings: DesignSettings, keep: int = 4,
              stiffness: Optional[float] = None):
    """Multi-start: stage A (nearest pose) then stage B (least effort, pose and stiffness pinned);
    with a stiffness target and no pose, stage B alone."""
    optima: List[DesignPoint] = []
    req_a = DesignRequest(target=target or None, stage="A", margin=settings.margin, bounds=settings.bounds())
    req_b = replace(req_a, stage="B", stiffness=stiffness)
    starts = _screen(nlp, base, options, target, _start_grid(nlp, base, settings), keep, stiffness)
    for _, d0, z0 in starts:
        best = None
        if target:
            a = nlp.solve(base, z0, d0, req_a, certify=False)  # a probe: certified only if it reaches
            if not a.converged:
                continue
            if not getattr(a, "certified", True) and _tip_error(a.tip, target) <= 10 * settings.reach_tol + 1e-7:
                # reached only by an unstable state: ask for the nearest stable one, certified
                a = nlp._solve(base, z0, d0, req_a, certified=True)
            best, z0, d0 = a, a.z, _dvec(nlp, a)
            if _tip_error(a.tip, target) > 10 * settings.reach_tol + 1e-7:
                if stiffness is not None:
                    a.stiffness = nlp.stiffness(base, a)
                optima.append(a)
                continue
        b = nlp.solve(base, z0, d0, req_b)
        if b.converged and (not target or _tip_error(b.tip, target) <= settings.reach_tol):
            best = b
        if best is not None:
            if stiffness is not None:
                best.stiffness = nlp.stiffness(base, best)
            optima.append(best)
    return _distinct(nlp, optima)


def _dvec(nlp: DesignNLP, pt: DesignPoint) -> np.ndarray:
    return nlp.design_vector(h=pt.h, phi=pt.phi, coefficients=pt.coefficients, p=pt.p)


def _effort(pt: DesignPoint) -> float:
    """The stage-B objective: h² + p² + the smoothness of α (Σ k²(k+1)²/4 c_k², cf. ∫α'²)."""
    k = np.arange(len(pt.coefficients), dtype=float)
    return float(pt.h**2 + pt.p**2 + np.sum(k**2 * (k + 1) ** 2 / 4.0 * np.asarray(pt.coefficients) ** 2))


def _rank(pt: DesignPoint, target, settings: "DesignSettings", stiffness: Optional[float] = None):
    """Designs that reach the target first, by least effort; the others by distance."""
    err = _target_error(pt, target, stiffness)
    return (0, _effort(pt)) if err <= settings.reach_tol else (1, err)


def _target_error(pt: DesignPoint, target, stiffness: Optional[float]) -> float:
    """Pose distance (units of ℓ) plus the relative stiffness error."""
    err = _tip_error(pt.tip, target) if target else 0.0
    if stiffness is not None:
        k = getattr(pt, "stiffness", None)
        err += abs(k / stiffness - 1.0) if (k is not None and math.isfinite(k)) else np.inf
    return err


def _tip_error(tip, target) -> float:
    e = [tip[0] - target[0], tip[1] - target[1]]
    if len(target) > 2:
        e.append(tip[2] - target[2])
    return float(np.linalg.norm(e))


def _distinct(nlp: DesignNLP, optima: List[DesignPoint]) -> List[DesignPoint]:
    """Drop repeats: same shape and same design, with φ compared modulo π (the energy's period)."""
    def key(pt):
        return nlp.design_vector(h=pt.h, phi=_normalise_phi(pt.phi), coefficients=pt.coefficients, p=pt.p)

    out: List[DesignPoint] = []
    for pt in optima:
        if all(np.max(np.abs(key(pt) - key(q))) > 1e-4 or np.max(np.abs(pt.z - q.z)) > 1e-4 for q in out):
            out.append(pt)
    return out


def _normalise_phi(phi: float) -> float:
    """The energy is π-periodic in φ: report φ in (−π/2, π/2]."""
    return float(phi - math.pi * math.ceil((phi - math.pi / 2) / math.pi))


# -- verification -----------------------------------------------------------------------------------
def _ramp(h: float, phi: float, p: float, steps: int, design_p: bool) -> List[Dict[str, float]]:
    return [{"h": h * t, "phi": phi, **({"p": p * t} if design_p else {})} for t in np.linspace(0, 1, steps)]


def _ramp_then_rotate(h, phi_a, phi, p, steps, design_p) -> List[Dict[str, float]]:
    turn = [{"h": h, "phi": phi_a + (phi - phi_a) * t, **({"p": p} if design_p else {})}
            for t in np.linspace(0, 1, steps)[1:]]
    return _ramp(h, phi_a, p, steps, design_p) + turn


def _verify(design_scene: Scene, options: SolverOptions, pt: DesignPoint, settings: DesignSettings,
            design_p: bool):
    """Fresh forward solve and a snap-free loading path from zero field; never the NLP's own state.

    Schedules tried: the magnitude ramp at the designed angle; if it lands on another branch, a
    ramp at φ_d ∓ Δ followed by a rotation of the field to φ_d, rotating first in the direction that
    winds the rod from where the plain ramp left it towards the design (a rotating field can wind
    the rod onto branches a ramp never reaches).
    """
    from .loading import follow_path  # the landscape layer's quasi-static path follower

    forward = solve(design_scene, options)  # a fresh forward NLP from the straight rod
    start = replace(design_scene, h=0.0)
    if design_p:
        start = start.with_values(p=0.0)
    steps = settings.ramp_steps

    def attempt(schedule):
        path = follow_path(start, options, schedule, max_step=0.25, max_dtheta=0.5)
        final = path.final
        ok = (final is not None and final.success and path.snap_free and final.stable
              and max(abs(final.tip["x"] - pt.tip[0]), abs(final.tip["y"] - pt.tip[1]),
                      abs(final.tip["angle"] - pt.tip[2])) <= 1e-6)
        return ok, path

    ramp = _ramp(pt.h, pt.phi, pt.p, steps, design_p)
    ok, path = attempt(ramp)
    if ok:
        return forward, path, "magnitude ramp at the designed angle", ramp
    reached = path.final.tip["angle"] if path.final is not None and path.final.success else 0.0
    wind = 1.0 if pt.tip[2] >= reached else -1.0  # rotate the field the way the rod must turn
    for sign in (wind, -wind):
        for delta_deg in (90, 45, 135):
            phi_a = pt.phi - sign * math.radians(delta_deg)
            schedule = _ramp_then_rotate(pt.h, phi_a, pt.phi, pt.p, steps, design_p)
            ok, path = attempt(schedule)
            if ok:
                return (forward, path, f"ramp at {math.degrees(_normalise_phi(phi_a)):.0f} deg, then rotate "
                        f"the field {'counter-' if sign > 0 else ''}clockwise by {delta_deg} deg to the "
                        f"designed angle", schedule)
    return forward, None, "no snap-free path from zero field reaches the design", []


# -- the public entry point ---------------------------------------------------------------------------
def design(target: Optional[Sequence[float]] = None, scene: Optional[Scene] = None,
           vary: Optional[Sequence[str]] = None, options: Optional[SolverOptions] = None,
           settings: Optional[DesignSettings] = None, verify: bool = True,
           stiffness: Optional[float] = None) -> DesignResult:
    """Find a stable, reachable design that puts the tip at ``target`` (and/or gives the tip the
    vertical stiffness ``stiffness``).

    Parameters
    ----------
    target : (x, y) or (x, y, angle), optional
        Tip position in units of ℓ (clamp at the origin, rod initially along +x), optional tip
        angle in rad.
    scene : Scene, optional
        Base scene (default: THEORY §5's cantilever with zero field, p = 0, α = 0).
    vary : sequence of {"h", "phi", "alpha", "p"}, optional
        Design variables; default: (h, φ), adding α(s) if needed (see :data:`AUTO_VARIABLE_SETS`);
        for a stiffness target alone, h.
    options : SolverOptions, optional
        Forward transcription the design satisfies.
    settings : DesignSettings, optional
    verify : bool
        Run the independent verification (forward solve + loading path).
    stiffness : float, optional
        Target tip stiffness dp/dv1 (units of B0/ℓ³; K = s·B0/ℓ³ in N/m, THEORY §6).

    Returns
    -------
    DesignResult
    """
    t0 = time.perf_counter()
    target = () if target is None else tuple(float(v) for v in target)
    if target and (len(target) not in (2, 3) or not all(math.isfinite(v) for v in target)):
        raise ValueError(f"target: expected finite x,y[,angle], got {target}")
    if stiffness is not None and not (math.isfinite(stiffness) and stiffness > 0):
        raise ValueError(f"stiffness target: must be a finite number > 0, got {stiffness}")
    if not target and stiffness is None:
        raise ValueError("design needs a target tip pose, a stiffness target, or both")
    options = options or SolverOptions()
    settings = settings or DesignSettings()
    base0 = scene or default_scene(h=0.0)
    if stiffness is not None and base0.tip_force is None:
        base0 = replace(base0, tip_force=(0.0, 0.0))  # the stiffness is dp/dv1: p must be a term
    user_vary = vary is not None
    if user_vary:
        unknown = [v for v in vary if v not in DESIGN_VARIABLES]
        if unknown or not vary:
            raise ValueError(f"--vary: unknown design variable(s) {unknown} (allowed: {', '.join(DESIGN_VARIABLES)})")
        sets = [tuple(vary)]
    else:
        sets = list(AUTO_VARIABLE_SETS) if target else [("h",)]

    notes: List[str] = []
    best, best_nlp, best_base, all_optima = None, None, None, []
    timings: Dict[str, float] = {}
    rank = lambda pt: _rank(pt, target, settings, stiffness)
    for vset in sets:
        base = prepare_scene(base0, vset)
        tb = time.perf_counter()
        nlp = get_design_nlp(base, vset, options, settings.alpha_terms)
        timings[f"build_{'+'.join(vset)}"] = time.perf_counter() - tb
        to = time.perf_counter()
        optima = sorted(_optimise(nlp, base, options, target, settings, stiffness=stiffness), key=rank)
        timings[f"optimise_{'+'.join(vset)}"] = time.perf_counter() - to
        all_optima += [(vset, nlp, pt) for pt in optima]
        if optima and (best is None or rank(optima[0]) < rank(best)):
            best, best_nlp, best_base = optima[0], nlp, base
        if best is not None and rank(best)[0] == 0:
            if not user_vary and vset != sets[0]:
                notes.append(f"field magnitude and angle alone cannot reach the target; "
                             f"used {', '.join(vset)} (the fibre layout)")
            break

    if best is None:
        timings["total"] = time.perf_counter() - t0
        b = settings.bounds()
        limits = ", ".join([f"h <= {b['h_max']:g}"] + ([f"|p| <= {b['p_max']:g}"] if "p" in sets[-1] else [])
                           + ([f"|alpha| <= {math.degrees(b['alpha_max']):g} deg"] if "alpha" in sets[-1] else []))
        hint = (" (in an axial field the straight rod only stiffens: its stiffness is at least s(0) = 3 "
                "B0/l^3, THEORY §6)" if stiffness is not None and not target else "")
        return DesignResult(success=False, reachable=False, verified=False, stable=False, snap_free=False,
                            target=target, achieved={}, error=float("inf"),
                            design={"h": float("nan"), "phi": float("nan"), "p": float("nan")}, vary=sets[-1],
                            schedule=[], message=f"no stable design of {', '.join(sets[-1])} reaches the target "
                            f"within the bounds ({limits}){hint}",
                            scene=base0, timings=timings, stiffness_target=stiffness)

    reachable = rank(best)[0] == 0
    if not reachable and not getattr(best, "certified", True):
        # the nearest pose reported for an unreachable target must itself be a stable state
        z0, d0 = best.start
        best_stable = best_nlp.solve(best_base, z0, d0, DesignRequest(
            target=target, stage="A", margin=settings.margin, bounds=settings.bounds(), stiffness=None))
        if best_stable.converged:
            if stiffness is not None:
                best_stable.stiffness = best_nlp.stiffness(best_base, best_stable)
            best = best_stable
    err = _tip_error(best.tip, target) if target else 0.0
    alternatives: Dict[str, bool] = {}
    if not reachable:
        what = "target" if stiffness is None else ("stiffness" if not target else "target pose and stiffness")
        notes.append(f"the {what} is not reachable with {', '.join(best_nlp.vary)}: the nearest stable design "
                     f"misses by {_target_error(best, target, stiffness):.3g} (reported as 'achieved')")
        if target and math.hypot(target[0], target[1]) > 1.0:
            notes.append("the target lies beyond the rod's length from the clamp (|r| > 1)")
        elif user_vary and "alpha" not in best_nlp.vary and target and stiffness is None:
            alternatives = _try_alternative(base0, best_nlp.vary, options, target, settings, stiffness)
            if alternatives.get("with_fibre_layout"):
                notes.append(f"adding the fibre layout would reach it: --vary {','.join(best_nlp.vary)},alpha")
    design_scene = best_nlp.scene_for(best_base, _dvec(best_nlp, best))
    phi = _normalise_phi(best.phi) if "phi" in best_nlp.vary else best.phi
    s_dense = np.linspace(0.0, 1.0, 201)
    result = DesignResult(
        success=False, reachable=reachable, verified=False, stable=False, snap_free=False, target=target,
        achieved={"x": best.tip[0], "y": best.tip[1], "angle": best.tip[2]}, error=err,
        design={"h": best.h, "phi": phi, "p": best.p,
                "alpha": {"s": s_dense.tolist(), "value": design_scene.fibres(s_dense).tolist(),
                          "legendre_coefficients": [float(c) for c in best.coefficients]}},
        vary=best_nlp.vary, schedule=[], message="", scene=base0, design_scene=design_scene,
        optima=[_optimum_dict(v, pt, target) for v, _, pt in all_optima], alternatives=alternatives,
        timings=timings, stiffness_target=stiffness, achieved_stiffness=getattr(best, "stiffness", None))

    stiffness_ok = True
    if verify:
        tv = time.perf_counter()
        forward, path, label, schedule = _verify(design_scene, options, best, settings, "p" in best_nlp.vary)
        timings["verify"] = time.perf_counter() - tv
        result.forward = forward
        result.path = path
        if path is not None:
            final = path.final
            result.achieved = {"x": final.tip["x"], "y": final.tip["y"], "angle": final.tip["angle"]}
            result.error = _tip_error((final.tip["x"], final.tip["y"], final.tip["angle"]), target) if target else 0.0
            result.stable = bool(final.stable)
            result.snap_free = bool(path.snap_free)
            result.stability_margin = float(final.eigenvalues[0])
            # one shift by a multiple of π for the whole schedule keeps a rotating field continuous
            # (the energy is π-periodic in φ, so the end angle is equivalent to the design's φ)
            shift = _normalise_phi(float(schedule[0]["phi"])) - float(schedule[0]["phi"])
            result.schedule = [{"h": float(s["h"]), "phi": float(s["phi"]) + shift,
                                **({"p": float(s["p"])} if "p" in s else {})} for s in schedule]
            result.verified = True
            notes.append(f"verified by a loading path from zero field: {label}")
            if forward.success and max(abs(forward.tip["x"] - final.tip["x"]),
                                       abs(forward.tip["y"] - final.tip["y"])) > 1e-6:
                notes.append("note: a forward solve from the straight rod at the designed field lands on "
                             "another equilibrium; the design is reached only along the reported schedule")
            if stiffness is not None:
                result.achieved_stiffness = _stiffness_by_differences(design_scene, options, final)
                result.achieved["stiffness"] = result.achieved_stiffness
                stiffness_ok = abs(result.achieved_stiffness / stiffness - 1.0) <= settings.accept_tol
        else:
            notes.append(label)
    result.success = bool(result.reachable and result.verified and result.stable and result.snap_free
                          and result.error <= settings.accept_tol and stiffness_ok)
    timings["total"] = time.perf_counter() - t0
    result.message = "; ".join(notes) or ("design found" if result.success else "")
    return result


def _stiffness_by_differences(scene: Scene, options: SolverOptions, state: EquilibriumResult,
                              dp: float = 1e-5) -> float:
    """dp/dv1 by central differences of two independent forward solves (warm-started on the
    verified state so they stay on its branch); truncation error O(dp²)."""
    ys = []
    for sgn in (+1.0, -1.0):
        r = solve(scene.with_values(p=scene.p + sgn * dp), replace(options, ensure_stable=False), initial=state)
        ys.append(r.tip["y"])
    return float(2 * dp / (ys[0] - ys[1]))


def _try_alternative(base0, vset, options, target, settings, stiffness) -> Dict[str, bool]:
    """Would adding the fibre layout reach an unreachable target? (No verification: a hint.)"""
    vset2 = tuple(vset) + ("alpha",)
    base = prepare_scene(base0, vset2)
    nlp = get_design_nlp(base, vset2, options, settings.alpha_terms)
    optima = _optimise(nlp, base, options, target, settings, keep=2, stiffness=stiffness)
    return {"with_fibre_layout": any(_rank(pt, target, settings, stiffness)[0] == 0 for pt in optima)}


def _optimum_dict(vset, pt: DesignPoint, target) -> Dict[str, object]:
    out = {"vary": list(vset), "h": pt.h, "phi": _normalise_phi(pt.phi), "p": pt.p,
           "alpha_coefficients": [float(c) for c in pt.coefficients],
           "tip": {"x": float(pt.tip[0]), "y": float(pt.tip[1]), "angle": float(pt.tip[2])},
           "error": _tip_error(pt.tip, target) if target else 0.0, "stage": pt.stage}
    if getattr(pt, "stiffness", None) is not None:
        out["stiffness"] = pt.stiffness
    return out


@register("design")
def run_design(scene, options, target=None, vary=None, stiffness=None, **settings) -> dict:
    """Study entry: ``design`` with ``target: [x, y(, angle)]`` and/or ``stiffness``, optional ``vary``
    and settings."""
    if target is None and stiffness is None:
        raise ValueError("design: give 'target' (e.g. target: [0.3, 0.5]) and/or 'stiffness'")
    res = design(target, scene=scene, vary=vary, options=options, settings=DesignSettings(**settings),
                 stiffness=stiffness)
    out = res.to_dict()
    out["design"] = {k: v for k, v in out["design"].items() if k != "alpha"}
    return out
