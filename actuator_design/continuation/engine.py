"""``continuation(problem, algorithm, settings, events)``: one engine for every branch in the package.

Predictor x_p = x_k + s t_k, corrector Newton on [G(x); rowᵀ(x − x_p)] = 0 (row = W t_k for
PALC, e_λ for natural continuation) started from x_p — at the largest step from x_p + ½ s² κ, κ
the curvature from the last two tangents, kept when Newton converges there well below the
shrinking count —, new tangent from [G_x; t_kᵀW] t = e_{n+1}; step adapted to the number of
Newton iterations (×1.5 for few, ×0.6 for many: settings) and halved when the corrector fails,
the tangent turns too much or an unknown moves more than ``settings.max_du`` (the predictor is
shortened to ``max_du`` and ``max_dlam``).
Along the branch: the Morse index and smallest eigenvalue of M^-1/2 H M^-1/2 at every point, and
the events asked for (:mod:`.events`), located on the step where they are detected; events made
with ``stop=True`` end the run.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import List, Optional, Sequence

import numpy as np

from actuator_design.continuation.events import BranchPoint, BranchState, EventPoint, Fold, UserEvent
from actuator_design.continuation.problem import BifurcationProblem
from actuator_design.continuation.secant import Secant, run_secant
from actuator_design.continuation.settings import ContinuationSettings

__all__ = ["Natural", "PALC", "Secant", "ContinuationBranch", "continuation", "locate_event"]

#: a step on which the Morse index changes by two or more, or whose event is only bracketed, is
#: halved while longer than this many smallest steps (then it is taken: two eigenvalues that cross
#: zero together, an event that is not located)
_DOUBLE_CROSSING_DS = 1e3


@dataclass(frozen=True)
class PALC:
    """Keller's pseudo-arclength continuation: steps of arclength ds in the metric W; passes folds."""

    def predict(self, x, t, ds):
        return x + ds * t, ds

    def row(self, problem: BifurcationProblem, t):
        return t * problem.W


@dataclass(frozen=True)
class Natural:
    """Natural continuation: steps of |Δλ| = ds, the corrector at fixed λ; stops at folds."""

    def predict(self, x, t, ds):
        tl = t[-1]
        s = ds / abs(tl) if abs(tl) > 1e-12 else ds
        return x + s * t, s

    def row(self, problem: BifurcationProblem, t):
        e = np.zeros(problem.n + 1)
        e[-1] = 1.0
        return e


@dataclass
class ContinuationBranch:
    """The points of one continuation run, in arclength order.

    Attributes
    ----------
    x : ndarray, shape (N, n + 1)
        (u, λ) per point.
    tangents : ndarray, shape (N, n + 1)
    morse_index : ndarray of int, shape (N,)
    min_eig : ndarray, shape (N,)
        Smallest eigenvalue of M^-1/2 H M^-1/2.
    events : list of EventPoint
        In the order found.
    status : {"left_window", "max_points", "closed_loop", "step_too_small", "event"}
        ``"event"``: stopped at an event made with ``stop=True`` (the last in ``events``).
    stats : dict
        ``points``, ``newton_evaluations``, ``time_s``.
    """

    x: np.ndarray
    tangents: np.ndarray
    morse_index: np.ndarray
    min_eig: np.ndarray
    events: List[EventPoint]
    status: str
    message: str
    stats: dict = field(default_factory=dict)

    @property
    def lam(self) -> np.ndarray:
        return self.x[:, -1]

    def __len__(self) -> int:
        return self.x.shape[0]


def locate_event(problem, algorithm, settings, x, t, s, kind, name, idx_before, idx_after,
            function=None, by_tangent=False) -> EventPoint:
    """Locate an event inside the step x + σ t, σ ∈ [0, s]: brentq on σ of the event's test
    function at the corrected point (signed min |μ| of H for folds and branch points, t_λ for a
    fold where H does not change sign, the user function for user events); a fold is then finished
    by the Moore–Spence locator of :mod:`actuator_design.reduced.fold` (the project's one fold
    locator) where the problem offers it."""
    from scipy.optimize import brentq  # here: importing scipy.optimize costs 0.1 s at start-up
    n = problem.n
    row = algorithm.row(problem, t)
    cache = {}
    tol = settings.tol

    def point(sig):
        if sig not in cache:
            xs, ok, _ = problem.correct(x + sig * t, row, tol, settings.arc_tol, max_iter=20)
            cache[sig] = (xs, ok)
        return cache[sig]

    def corrected(sig):
        xs, ok = point(sig)
        if not ok:
            raise RuntimeError("corrector failed")
        return xs

    def singular(sig):
        return problem.inertia(corrected(sig))[2]

    def turn(sig):
        return problem.tangent(corrected(sig), t)[0][n]

    def user(sig):
        return float(function(BranchState(problem, corrected(sig))))

    located = True
    eps = np.finfo(float).eps
    try:
        if kind == "user":
            sig = brentq(user, 0.0, s, xtol=1e-15, rtol=4 * eps, maxiter=100)
        else:
            fa, fb = (1.0, 1.0) if by_tangent else (singular(0.0), singular(s))
            if fa * fb < 0:
                sig = brentq(singular, 0.0, s, xtol=1e-15, rtol=4 * eps, maxiter=100)
            elif (kind == "fold" or by_tangent) and turn(0.0) * turn(s) < 0:
                sig = brentq(turn, 0.0, s, xtol=1e-15, rtol=4 * eps, maxiter=100)
            else:
                sig, located = 0.5 * s, False
        xs, ok = point(sig)
        if kind == "fold" and located and hasattr(problem, "polish_fold"):
            # the bracketed root of the test function, finished by the one fold locator
            polished = problem.polish_fold(xs)
            if polished is not None:
                xs = polished
    except (RuntimeError, ValueError):
        xs, located = x + 0.5 * s * t, False
    tc, _ = problem.tangent(xs, t)
    xe = point(s)[0] if s in cache else x + s * t
    return EventPoint(kind, name, xs, tc, int(idx_before), int(idx_after), located,
                      (float(min(x[n], xe[n]) - s), float(max(x[n], xe[n]) + s)))


def _w_norm2(d: np.ndarray, W: np.ndarray) -> float:
    """dᵀ W d (W the metric's diagonal)."""
    return float(d @ (W * d))


def _to_edge(problem, settings, x, xn, edge):
    """The branch point at λ = edge between x and xn (Newton at fixed λ from interpolation)."""
    n = problem.n
    w = (edge - x[n]) / (xn[n] - x[n])
    u, ok, _ = problem.correct_fixed((1 - w) * x[:n] + w * xn[:n], edge, settings.tol, max_iter=20)
    return np.append(u, edge) if ok else None


def continuation(problem: BifurcationProblem, algorithm=PALC(),
                 settings: ContinuationSettings = ContinuationSettings(),
                 events: Sequence = (), *, x0: Optional[np.ndarray] = None,
                 tangent: Optional[np.ndarray] = None, start=None, solves: int = 0):
    """Continue the branch of ``problem`` from its start until λ leaves ``settings.window`` (the
    end point is placed on the window's edge), the branch closes, ``settings.max_steps`` points are
    reached or the step underflows.

    Parameters
    ----------
    problem : BifurcationProblem or FoldCurveProblem, or a StatePath for Secant
        Anything with their interface (corrector, tangent, stability, ``accept`` and ``inside``
        hooks, ``evaluations``).
    algorithm : PALC, Natural or Secant
        :class:`~.secant.Secant` continues the full state of a :class:`~.secant.StatePath` with its
        own loop (:func:`~.secant.run_secant`), as BifurcationKit's deflated continuation does.
    settings : ContinuationSettings
    events : sequence of Fold, BranchPoint, UserEvent (Secant: Fold(stop=True) or Snap, StabilityLoss)
    x0 : ndarray (n + 1,), optional
        Converged start (u, λ); default ``problem.u0, problem.lam0`` corrected at fixed λ. Secant:
        the converged start state (n_nodes,) at λ = ``settings.window[0]``, required.
    tangent : ndarray (n + 1,), optional
        Start tangent (branch switching); default the tangent along ``settings.direction``.
    start, solves
        Secant only: the start's solve and the solves already spent (:func:`~.secant.run_secant`).

    Returns
    -------
    ContinuationBranch, or SecantRun for Secant
    """
    if isinstance(algorithm, Secant):
        if x0 is None:
            raise ValueError("continuation: Secant needs the converged start state x0")
        return run_secant(problem, algorithm, settings, events, z0=x0, start=start, solves=solves)
    if any(getattr(e, "kind", None) in ("snap", "stability_loss") for e in events):
        raise ValueError("continuation: Snap and StabilityLoss events are for the Secant algorithm")
    tstart = time.perf_counter()
    st = settings
    lo, hi = st.window
    n = problem.n
    W = problem.W
    calls0 = problem.evaluations
    if x0 is None:
        if problem.u0 is None or problem.lam0 is None:
            raise ValueError("continuation: the problem has no start (u0, lam0) and no x0 was given")
        u, ok, _ = problem.correct_fixed(problem.u0, problem.lam0, st.tol, max_iter=50)
        if not ok:
            raise RuntimeError(f"continuation: Newton did not converge at the start "
                               f"{problem.lens} = {problem.lam0}")
        x0 = np.append(u, problem.lam0)
    x = np.array(x0, float)
    want_fold = any(isinstance(e, Fold) for e in events)
    want_bp = any(isinstance(e, BranchPoint) for e in events)
    users = [e for e in events if isinstance(e, UserEvent)]
    stops = {"fold": any(isinstance(e, Fold) and e.stop for e in events),
             "branch_point": any(isinstance(e, BranchPoint) and e.stop for e in events)}
    if tangent is None:
        t, dsign = problem.tangent(x)
        if t[n] * st.direction < 0 or (abs(t[n]) < 1e-12 and st.direction < 0):
            t = -t
            t, dsign = problem.tangent(x, t)
    else:
        t0 = np.asarray(tangent, float)
        t, dsign = problem.tangent(x, t0 / math.sqrt(float(t0 @ (W * t0))))
    idx, mu0 = problem.stability(x)
    X, T, IDX, MU, D = [x], [t], [idx], [mu0], [dsign]
    U = [float(e.function(BranchState(problem, x))) for e in users]
    found: List[EventPoint] = []
    status, msg = "max_points", f"stopped after {st.max_steps} points"
    ds = st.ds
    # (t_k − t_{k−1}) / |x_k − x_{k−1}|_W ≈ the branch's curvature vector κ: the corrector starts
    # from x_p + ½ s² κ, O(s³) instead of O(s²) from the branch, and converges in one Newton step
    # where the predictor needs two (the corrected point is the same: the constraint stays
    # rowᵀ(x − x_p) = 0)
    curvature = None
    bounded = math.isfinite(st.max_du) or math.isfinite(st.max_dlam)
    while len(X) < st.max_steps:
        xp, s = algorithm.predict(x, t, ds)
        if bounded:
            shrink = min(1.0, st.max_dlam / max(abs(xp[n] - x[n]), 1e-300),
                         st.max_du / max(float(np.max(np.abs(xp[:n] - x[:n]), initial=0.0)), 1e-300))
            if shrink < 1.0:  # a shorter predictor respects the step bounds
                ds *= shrink
                xp, s = algorithm.predict(x, t, ds)
        row = algorithm.row(problem, t)
        ok = False
        if curvature is not None and ds >= st.ds_max:
            # at the largest step the iteration count only decides a shrink (≥ shrink_iterations);
            # from the closer start Newton needs no more steps than from x_p, so a count well
            # below the threshold leaves the step sizes as they were (else x_p decides)
            xn, ok, it = problem.correct(xp, row, st.tol, st.arc_tol, st.max_corrector_iter,
                                         start=xp + (0.5 * s * s) * curvature)
            ok = ok and it < st.shrink_iterations - 1
        if not ok:
            xn, ok, it = problem.correct(xp, row, st.tol, st.arc_tol, st.max_corrector_iter)
        if ok:
            idx, mu = problem.fast_inertia()
            tn, dn = problem.tangent(xn, t, evaluate=False)
            if st.min_cos_turn > -1.0 and float(tn @ (W * t)) < st.min_cos_turn and ds > 10 * st.ds_min:
                ok = False
            elif bounded and float(np.max(np.abs(xn[:n] - x[:n]), initial=0.0)) > st.max_du:
                ok = False
        if ok and want_bp and abs(idx - IDX[-1]) >= 2 and ds > _DOUBLE_CROSSING_DS * st.ds_min:
            # two eigenvalues crossed zero on one step: two branch points whose determinant signs
            # cancel (a wide window's largest step over pitchforks 2.2 apart in h skipped some);
            # shorter steps take them one at a time (a true double crossing stays at small steps)
            ok, it = False, st.max_corrector_iter
        if not ok:
            ds *= 0.5
            if ds < st.ds_min:
                status, msg = "step_too_small", f"the corrector failed with steps below {st.ds_min:g}"
                break
            continue
        # detections on the step x -> xn
        turned, crossed = tn[n] * t[n] < 0, dn * D[-1] < 0
        step_events = []
        if (want_fold and turned) or (want_bp and crossed):
            # both at once: the branch passes through a branch point where it turns in λ
            # (the vertex of a pitchfork's bifurcating branch): a branch point, located by t_λ = 0
            kind = "branch_point" if crossed else "fold"
            if kind == "fold" or want_bp:
                ev = locate_event(problem, algorithm, st, x, t, s, kind, kind, IDX[-1], idx,
                             by_tangent=turned and crossed)
                step_events.append((ev, stops[kind]))
        u_new = []
        for e, fa in zip(users, U):
            fb = float(e.function(BranchState(problem, xn)))
            u_new.append(fb)
            if fa * fb < 0:
                ev = locate_event(problem, algorithm, st, x, t, s, "user", e.name, IDX[-1], idx,
                             function=e.function)
                step_events.append((ev, e.stop))
        if ds > _DOUBLE_CROSSING_DS * st.ds_min and any(not ev.located and (stop or lo <= ev.lam <= hi)
                                                         for ev, stop in step_events):
            # an event the step only brackets (its corrected points jump between branches, e.g.
            # across a pitchfork's vertex): shorter steps locate it (or, at the smallest, bracket it)
            ds *= 0.5
            continue
        stop_here = [ev for ev, stop in step_events if stop] if step_events else step_events
        if stop_here and any(not lo <= ev.lam <= hi for ev in stop_here):
            # a stopping event beyond the window: shorter steps reach the window's edge before it
            ds *= 0.5
            if ds < st.ds_min:
                status, msg = "step_too_small", f"a stopping event lies just beyond the window ({ds:g})"
                break
            continue
        if step_events:
            found.extend(ev for ev, _ in step_events if lo <= ev.lam <= hi)
        if stop_here:
            status, msg = "event", f"stopped at the {stop_here[0].kind} at {problem.lens} = {stop_here[0].lam:.10g}"
            break
        U = u_new
        if not problem.inside(xn):
            status, msg = "left_window", "left the problem's domain"
            break
        if not (lo <= xn[n] <= hi):
            edge = hi if xn[n] > hi else lo
            xe = _to_edge(problem, st, x, xn, edge)
            if xe is not None:
                ie, me = problem.stability(xe)
                X.append(xe), T.append(tn), IDX.append(ie), MU.append(me), D.append(dn)
            status, msg = "left_window", f"reached {problem.lens} = {edge:g}"
            break
        X.append(xn), T.append(tn), IDX.append(idx), MU.append(mu), D.append(dn)
        h = math.sqrt(_w_norm2(xn - x, W))
        curvature = (tn - t) / h if h > 0 else None
        x, t = xn, tn
        problem.accept(x)
        if len(X) > 10 and _w_norm2(x - X[0], W) < 0.25 * ds * ds and float(t @ (W * T[0])) > 0.9:
            status, msg = "closed_loop", "the branch closed on itself (an isola or a loop)"
            break
        ds = (min(ds * 1.5, st.ds_max) if it <= st.grow_iterations
              else (ds * 0.6 if it >= st.shrink_iterations else ds))
    return ContinuationBranch(np.array(X), np.array(T), np.array(IDX), np.array(MU), found, status, msg,
                              {"points": len(X), "newton_evaluations": problem.evaluations - calls0,
                               "time_s": time.perf_counter() - tstart})
