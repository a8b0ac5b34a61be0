"""Critical values directly: folds by the augmented system, fold curves, and every critical point
of a parameter window over all branches (THEORY §7–8).

* :func:`locate_fold` — Newton on the Moore–Spence system
  G(u, λ) = 0,  H(u, λ) v = 0,  cᵀ M v = 1  (2n + 1 equations in u, λ, v; M the lumped mass, c a
  fixed guess of v): an equilibrium whose reduced Hessian is singular. Its Jacobian is regular at a
  quadratic fold with ψᵀG_λ ≠ 0 (Moore & Spence 1980), so Newton converges quadratically. The
  locator is the reduced toolkit's (:func:`actuator_design.reduced.locate_fold`).
* :func:`fold_curve` — pseudo-arclength continuation of that system in a second parameter μ on the
  continuation engine (:class:`actuator_design.continuation.FoldCurveProblem` under PALC):
  the critical curve λ_crit(μ), e.g. p_crit^(k)(h²) for φ = 0.
* :func:`critical_points` — every fold and branch point in a window [a, b] of λ over all branches:
  the equilibria are found (:func:`~.equilibria.find_equilibria`, complete up to resolution) at
  ``n_samples`` values of λ spread over the window, every equilibrium not already on a traced
  branch is continued both ways until the branch leaves the window, branches bifurcating at the
  branch points found are followed too, and the critical points are deduplicated. The number of
  equilibria on either side of each critical value is counted by the shooting scan at the middle
  of each interval between consecutive critical values (where the count is constant).
  A branch that exists only strictly between two sample values and is connected to no traced
  branch (an isola) is missed; raise ``n_samples`` to rule that out. Where a scan cannot be
  trusted (:func:`~.shooting_scan.scan_validity`, e.g. h ≳ 12) the result says ``complete: false``
  with the reasons, never an empty window called complete. Each critical point is reported once
  over all branches (:func:`_dedupe`: values to 1e-7 relative, shapes to its square root).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.analysis.registration import register
from actuator_design.contact.guard import no_contact
from actuator_design.continuation import PALC, ContinuationSettings, FoldCurveProblem, continuation
from actuator_design.continuation.branch_accuracy import branch_options, critical_accuracy, unlocated_note
from actuator_design.continuation.follow import Branch, Continuation, CriticalPoint, get_param, set_param
from actuator_design.equilibrium.acceptance import warm_values
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.reduced import locate_fold as _locate_fold
from actuator_design.reduced import null_vector, reduced_system

__all__ = ["fold_function", "locate_fold", "FoldCurve", "fold_curve", "CriticalResult",
           "critical_points", "critical_curves", "count_equilibria"]

def fold_function(cont: Continuation, second: Optional[str] = None) -> ca.Function:
    """CasADi ``(u, λ (k,), v, c, P) -> (F, J, F_μ)`` of the Moore–Spence system
    F = [g; H v; cᵀ M v − 1] in X = (u, λ, v), with J = ∂F/∂X dense and F_μ = ∂F/∂μ for a second
    parameter ``second`` (λ = (λ, μ) then): :attr:`actuator_design.reduced.ReducedSystem.f_fold`."""
    names = [cont.name] + ([second] if second else [])
    return reduced_system(cont.solver, names).f_fold


def locate_fold(cont: Continuation, z, lam: float, v=None, *, mu: Optional[float] = None,
                second: Optional[str] = None, max_iter: int = 30):
    """Newton on the Moore–Spence system from an approximate fold (z, λ)
    (:func:`actuator_design.reduced.locate_fold`).

    Parameters
    ----------
    cont : Continuation
        Built for the fold's parameter λ (and the scene's other values).
    z : ndarray, shape (n_nodes,)
        Node vector near the fold.
    lam : float
    v : ndarray (n,), optional
        Null-vector guess (default: the eigenvector of the eigenvalue of H closest to zero).
    mu, second : float, str
        Value of a second parameter (for fold curves).

    Returns
    -------
    (z, λ, v, converged)
        The fold's node vector, parameter value and null vector (cᵀMv = 1).
    """
    names = [cont.name] + ([second] if second else [])
    others = [0.0 if mu is None else float(mu)] if second else []
    u = np.asarray(z, float)[1:]
    if v is None:
        _, H, _ = cont.ev(u, lam)
        v = null_vector(H, cont.mass)
    fp = _locate_fold(reduced_system(cont.solver, names), cont.P, u, lam, v, others=others,
                      tol=cont.tol, max_iter=max_iter)
    return cont.full(fp.u, fp.lam), fp.lam, fp.v, fp.converged


# -- fold curves --------------------------------------------------------------------------------
@dataclass
class FoldCurve:
    """A fold continued in a second parameter: λ_crit(μ).

    Attributes
    ----------
    param, second : str
        λ (the folding parameter) and μ.
    mu, lam : ndarray, shape (N,)
    tip_angle : ndarray, shape (N,)
        θ(1) at the fold (rad).
    status : str
    gamma : ndarray, shape (N,)
        θ'(0) at the fold (1/ℓ).
    """

    param: str
    second: str
    mu: np.ndarray
    lam: np.ndarray
    tip_angle: np.ndarray
    status: str
    gamma: Optional[np.ndarray] = None

    def to_dict(self) -> dict:
        return {"param": self.param, "second": self.second, "points": [
            {self.second: float(m), self.param: float(l), "tip_angle": float(a)}
            for m, l, a in zip(self.mu, self.lam, self.tip_angle)], "status": self.status}


def fold_curve(scene: Scene, param: str, second: str, z, lam: float, window: Sequence[float], *,
               options: Optional[SolverOptions] = None, ds: float = 0.1, ds_max: float = 1.0,
               max_points: int = 500, lam_window: Optional[Sequence[float]] = None) -> FoldCurve:
    """Continue a fold of ``param`` (at (z, λ) for the value of ``second`` in ``scene``) in the
    second parameter over ``window`` (both directions from the start), by pseudo-arclength on the
    Moore–Spence system in Y = (u, λ, v, μ) with metric weights (M, 1, 0, 1).

    Returns
    -------
    FoldCurve
        Sorted by arclength; it stops where μ leaves ``window``, λ leaves ``lam_window``, at a
        cusp where Newton fails (``status``), or after ``max_points``.
    """
    mu0 = get_param(scene, second)
    cont = Continuation(scene, param, options)
    n = cont.n
    zf, lf, v, ok = locate_fold(cont, z, lam, mu=mu0, second=second)
    if not ok:
        raise RuntimeError(f"fold_curve: no fold of {param} near {param} = {lam:g}")
    lam_win = (-np.inf, np.inf) if lam_window is None else tuple(lam_window)
    problem = FoldCurveProblem(reduced_system(cont.solver, [param, second]), cont.P, v, lam_win)
    Y0 = np.concatenate([zf[1:], [lf], v, [mu0]])
    halves, status = [], "left_window"
    for direction in (1.0, -1.0):
        problem.accept(Y0)
        st = ContinuationSettings(ds=ds, ds_min=min(1e-6, ds), ds_max=ds_max, max_steps=max_points,
                                  window=(min(window), max(window)), direction=direction,
                                  tol=cont.tol, arc_tol=1e-10, max_corrector_iter=9,
                                  min_cos_turn=-1.0, grow_iterations=9, shrink_iterations=10)
        half = continuation(problem, PALC(), st, x0=Y0)
        if half.status == "step_too_small":
            status = "newton_failed (a cusp or the end of the fold curve?)"
        X = half.x
        if len(X) > 1 and np.array_equal(X[-1], X[-2]):
            X = X[:-1]  # started on the window's edge: the edge point is the start itself
        halves.append(X)
    Ys = np.vstack([halves[1][::-1], halves[0][1:]])
    zs = np.column_stack([np.full(len(Ys), cont._theta0), Ys[:, :n]])
    tips = np.asarray(cont.solver.f_tip.map(len(Ys))(zs.T, cont.P)[0], float).ravel()
    dmu = np.diff(Ys[:, -1])
    order = np.arange(len(Ys)) if np.all(dmu > 0) or not np.all(dmu < 0) else np.arange(len(Ys))[::-1]
    gam = zs @ cont._gamma_row()
    return FoldCurve(param, second, Ys[order, -1], Ys[order, n], tips[order], status, gam[order])


# -- all critical points of a window ------------------------------------------------------------
@dataclass
class CriticalResult:
    """Every fold and branch point of λ in a window over all traced branches.

    Attributes
    ----------
    folds, branch_points : list of dict
        Each with ``value`` (λ*), ``tip_angle``, ``equilibria_below`` and ``equilibria_above``
        (number of equilibria just below / above λ*), ``located``, Morse indices.
    branches : list of Branch
    counts : list of dict
        ``{"from", "to", "equilibria", "stable", "complete"}`` per interval between consecutive
        critical values.
    complete : bool
        Every equilibrium scan (samples and counts) was certified complete; else
        ``incomplete_reasons`` says where and why (the branches and counts may then miss some).
    """

    param: str
    window: tuple
    folds: List[dict]
    branch_points: List[dict]
    branches: List[Branch]
    counts: List[dict]
    samples: List[float]
    stats: dict
    fold_points: List[CriticalPoint] = field(default_factory=list, repr=False)
    branch_point_objects: List[CriticalPoint] = field(default_factory=list, repr=False)
    complete: bool = True
    incomplete_reasons: List[str] = field(default_factory=list)
    #: why a critical value misses its accuracy (its estimated error, ``value_error`` of each row,
    #: above :data:`~actuator_design.continuation.branch_accuracy.CRITICAL_RTOL` × max(1, |λ*|)), or None
    accuracy: Optional[str] = None
    #: whether the critical values were checked (``accurate`` is null in the JSON when not)
    accuracy_checked: bool = True

    def to_dict(self, branches: bool = False) -> dict:
        """The ``critical --json`` contract: ``folds`` and ``branch_points`` with the parameter
        value, the tip angle and the number of equilibria on either side (and ``value_error``);
        ``accurate`` and ``accuracy``."""
        out = {"param": self.param, "window": list(self.window), "folds": self.folds,
               "branch_points": self.branch_points, "counts": self.counts, "samples": self.samples,
               "stats": self.stats, "complete": bool(self.complete),
               "incomplete_reasons": list(self.incomplete_reasons),
               "accurate": (self.accuracy is None) if self.accuracy_checked else None, "accuracy": self.accuracy,
               "success": bool(self.complete and self.accuracy is None)}
        if branches:
            out["branches"] = [b.to_dict() for b in self.branches]
        return out


def count_equilibria(scene: Scene, options: Optional[SolverOptions] = None, **kw) -> Tuple[int, int]:
    """(number of equilibria, number of stable ones) by :func:`~.equilibria.find_equilibria`."""
    r = find_equilibria(scene, options, **kw)
    return r.count, r.stable_count


def _incomplete(where: str, result) -> Optional[str]:
    """One line saying why the equilibria at ``where`` are not certified complete, else None."""
    if result.complete:
        return None
    return f"{where}: {result.incomplete_reason or 'the equilibria are not certified complete'}"


def _join(back: Branch, fwd: Branch) -> Branch:
    """One branch from a backward half (reversed) and a forward half sharing their first point."""
    cat = lambda a, b: np.concatenate([a[::-1][:-1], b]) if a.ndim == 1 else np.vstack([a[::-1][:-1], b])
    br = Branch(fwd.param, cat(back.lam, fwd.lam), cat(back.z, fwd.z), cat(back.morse_index, fwd.morse_index),
                cat(back.min_eig, fwd.min_eig), back.folds + fwd.folds, back.branch_points + fwd.branch_points,
                f"{back.status} / {fwd.status}", f"{back.message} / {fwd.message}",
                {k: back.stats.get(k, 0) + fwd.stats.get(k, 0) for k in fwd.stats}, cat(back.tips, fwd.tips),
                cat(back.energy, fwd.energy), cat(back.gamma, fwd.gamma), fwd.origin)
    return br


def _on_branch(cont: Continuation, br: Branch, z, lam, tol=1e-6) -> bool:
    """Whether the equilibrium (z, λ) lies on ``br``: every crossing of λ by the branch is
    corrected by Newton at fixed λ and compared node-wise."""
    L = br.lam
    idx = np.flatnonzero((L[:-1] - lam) * (L[1:] - lam) <= 0)
    for i in idx:
        w = 0.0 if L[i + 1] == L[i] else (lam - L[i]) / (L[i + 1] - L[i])
        guess = (1 - w) * br.z[i, 1:] + w * br.z[i + 1, 1:]
        if np.max(np.abs(guess - z[1:])) > 0.5:
            continue
        u, ok, _ = cont.correct_fixed(guess, lam, max_iter=15)
        if ok and np.max(np.abs(u - z[1:])) <= tol * max(1.0, np.max(np.abs(z))):
            return True
    return False


#: Relative accuracy of a located critical value: the engine's brentq runs on the arclength to
#: 1e-15 and the corrector to ``tol``; two branches through one critical point locate it on
#: different steps and agree to about 1e-8 (1.11072073 and 1.11072074 for the first pitchfork).
VALUE_RTOL = 1e-7


def _dedupe(points: List[CriticalPoint], rtol: float = VALUE_RTOL) -> List[CriticalPoint]:
    """Report each critical point once, whichever branches it was found on.

    Two points of one kind are the same when their values agree to τ = ``rtol`` (1 + |λ|) and their
    shapes (node values, rad) to √τ: near a fold or a branch point the state depends on λ like a
    square root (λ − λ* ∝ a² along a pitchfork's bifurcating branch, whose vertex is located by
    t_λ = 0), so a value located to τ fixes the state only to about √τ — e.g. the first pitchfork
    located on the straight rod (tip angle 0) and on the bifurcating branch (tip angle 9e-5).
    An unlocated point whose step interval contains a located one of the same kind is dropped.
    """
    located = [c for c in points if c.located]
    points = located + [c for c in points if not c.located and not any(
        o.kind == c.kind and c.interval is not None and c.interval[0] <= o.value <= c.interval[1]
        for o in located)]
    out: List[CriticalPoint] = []
    for cp in sorted(points, key=lambda c: (not c.located, c.value, c.tip["angle"])):
        tau = rtol * (1 + abs(cp.value))
        if any(o.kind == cp.kind and abs(o.value - cp.value) <= tau
               and np.max(np.abs(np.asarray(o.z) - np.asarray(cp.z))) <= np.sqrt(tau) for o in out):
            continue
        out.append(cp)
    out.sort(key=lambda c: (c.value, c.tip["angle"]))
    return out


@no_contact("critical")
def critical_points(scene: Scene, param: str, window: Sequence[float], *,
                    options: Optional[SolverOptions] = None, n_samples: int = 5,
                    ds: float = 0.05, ds_max: float = 0.3, max_points: int = 3000,
                    switch: bool = True, check_accuracy: bool = True) -> CriticalResult:
    """Every fold and branch point of ``param`` in ``window`` over all branches (module docstring).

    Parameters
    ----------
    scene : Scene
        Uniform field (or none); the other parameters are fixed at their values here.
    param : str
        A name of the parameter lens (:mod:`actuator_design.physics.parameters`).
    window : (a, b)
        Parameter interval, a < b.
    n_samples : int
        Values of λ (ends included) at which all equilibria are computed and continued.
    check_accuracy : bool
        Estimate each critical value's discretisation error (``value_error``, ``accuracy``:
        :func:`~actuator_design.continuation.branch_accuracy.critical_accuracy`).

    Returns
    -------
    CriticalResult
    """
    t0 = time.perf_counter()
    a, b = (float(v) for v in window)
    if not b > a:
        raise ValueError(f"window must be increasing, got ({a}, {b})")
    par = lens.parameter(param, "continuation parameter")
    if a < par.lower:
        raise ValueError(f"window: {param} must be >= {par.lower:g}, got {a}")
    if b > par.upper:
        raise ValueError(f"window: {param} must be <= {par.upper:g}, got {b}")
    cont = Continuation(scene, param, branch_options(scene, param, (a, b), options))
    nodes = cont.solver.transcription.nodes
    samples = list(np.linspace(a, b, max(2, int(n_samples))))
    branches: List[Branch] = []
    kw = dict(ds=ds, ds_max=ds_max, max_points=max_points)

    def trace(x0, t0=None):
        fwd = cont.run(x0, (a, b), direction=1.0, t0=t0, **kw)
        back = cont.run(x0, (a, b), direction=-1.0, t0=None if t0 is None else -t0, **kw)
        return _join(back, fwd)

    def known(z, lam):
        return any(_on_branch(cont, br, z, lam) for br in branches)

    reasons: List[str] = []
    for lam in samples:
        eqs = find_equilibria(cont.scene_at(lam), options)
        reasons.append(_incomplete(f"at {param} = {lam:.6g}", eqs))
        for e in eqs.equilibria:
            z = warm_values(e.result, nodes)  # (solved on the mesh chosen for that scene)
            if known(z, lam):
                continue
            u, ok, _ = cont.correct_fixed(z[1:], lam)
            if ok:
                branches.append(trace(np.append(u, lam)))
    if switch:
        done = 0
        while done < len(branches):
            br = branches[done]
            done += 1
            for bp in _dedupe(br.branch_points):
                for half in cont.switch(bp, (a, b), **kw):
                    if len(half) and not known(half.z[0], half.lam[0]):
                        branches.append(half)
    for br in branches:  # a branch that stopped inside the window may have folds beyond where it stopped
        if any(part in ("step_too_small", "max_points") for part in br.status.split(" / ")):
            reasons.append(f"a branch through {param} = {br.lam[0]:.6g} .. {br.lam[-1]:.6g} stopped inside the "
                           f"window ({br.message}): its folds and branch points beyond are not known")
    folds = _dedupe([cp for br in branches for cp in br.folds])
    bps = _dedupe([cp for br in branches for cp in br.branch_points])
    # (each located one gets its value_error)
    accuracy = critical_accuracy(cont, folds + bps) if check_accuracy else None
    loose = unlocated_note(param, folds + bps)
    if loose:  # a value only bracketed, perhaps no critical point at all: the list is not certain
        reasons.append(loose)
    # counts between consecutive critical values
    vals = sorted({round(c.value, 9) for c in folds + bps})
    edges = [a] + [v for v in vals if a < v < b] + [b]
    counts = []
    for lo_, hi_ in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (lo_ + hi_)
        eqs = find_equilibria(cont.scene_at(mid), options)
        why = _incomplete(f"at {param} = {mid:.6g}", eqs)
        reasons.append(why)
        counts.append({"from": lo_, "to": hi_, "at": mid, "equilibria": eqs.count,
                       "stable": eqs.stable_count, "complete": why is None})

    def side_counts(v):
        below = [c for c in counts if c["to"] <= v + 1e-9 * (1 + abs(v))]
        above = [c for c in counts if c["from"] >= v - 1e-9 * (1 + abs(v))]
        return (below[-1]["equilibria"] if below else None, above[0]["equilibria"] if above else None)

    def rows(cps):
        out = []
        for cp in cps:
            d = cp.to_dict()
            d["equilibria_below"], d["equilibria_above"] = side_counts(cp.value)
            out.append(d)
        return out

    stats = {"branches": len(branches), "points": int(sum(len(br) for br in branches)),
             "time_s": time.perf_counter() - t0}
    reasons = [r for r in reasons if r is not None]
    return CriticalResult(param, (a, b), rows(folds), rows(bps), branches, counts,
                          [float(s) for s in samples], stats, folds, bps, not reasons, reasons, accuracy,
                          check_accuracy)


def critical_curves(scene: Scene, param: str, second: str, window: Sequence[float],
                    second_window: Sequence[float], *, options: Optional[SolverOptions] = None,
                    n_starts: int = 3, n_samples: int = 5, seeds: Sequence[float] = ()) -> List[FoldCurve]:
    """Every fold curve λ_crit(μ) of ``param`` in ``window`` over μ = ``second`` in
    ``second_window``: :func:`critical_points` at ``n_starts`` values of μ (ends included) and at
    ``seeds``, each fold not already on a curve continued by :func:`fold_curve` (e.g. p_crit^(k)(h²)
    for φ = 0).

    ``seeds``: further values of μ to look for folds at, e.g. where a multiplicity map's count
    changes along λ (a fold curve that enters and leaves the window between the evenly spaced
    starts is otherwise missed: a transverse field's p-fold exists only above h_crit).

    Returns
    -------
    list of FoldCurve
        Sorted by their λ at the first μ.
    """
    curves: List[FoldCurve] = []
    a, b = (float(v) for v in window)
    lo, hi = min(second_window), max(second_window)
    starts = list(np.linspace(lo, hi, max(1, int(n_starts))))
    starts += [float(v) for v in seeds if lo <= float(v) <= hi]
    for mu in starts:
        sc = set_param(scene, second, mu)
        cr = critical_points(sc, param, (a, b), options=options, n_samples=n_samples,
                             check_accuracy=False)  # (the fold curves' own points are what count)
        for cp in cr.fold_points:
            on = False
            for c in curves:
                if c.mu.min() - 1e-9 <= mu <= c.mu.max() + 1e-9 and len(c.mu) > 1:
                    o = np.argsort(c.mu)
                    lam_c = np.interp(mu, c.mu[o], c.lam[o])
                    ang_c = np.interp(mu, c.mu[o], c.tip_angle[o])
                    # the polyline's interpolation error is below its step around mu
                    k = int(np.clip(np.searchsorted(c.mu[o], mu), 1, len(o) - 1))
                    dlam = abs(c.lam[o][k] - c.lam[o][k - 1])
                    dang = abs(c.tip_angle[o][k] - c.tip_angle[o][k - 1])
                    if (abs(lam_c - cp.value) <= 1e-3 * (1 + abs(cp.value)) + dlam
                            and abs(ang_c - cp.tip["angle"]) < 1e-2 + dang):
                        on = True
                        break
            if not on:
                try:
                    curves.append(fold_curve(sc, param, second, cp.z, cp.value, second_window,  # (cp.z's mesh)
                                             options=branch_options(sc, param, (a, b), options),
                                             lam_window=(a, b)))
                except RuntimeError:
                    continue
    curves.sort(key=lambda c: c.lam[0])
    return curves


@register("critical")
def run_critical(scene, options, **settings) -> dict:
    """Settings: ``param``, ``window`` (a, b), optional ``n_samples``."""
    try:
        param, window = settings.pop("param"), settings.pop("window")
    except KeyError as err:
        raise ValueError(f"critical needs the setting {err.args[0]!r}") from None
    return critical_points(scene, param, window, options=options, **settings).to_dict()
