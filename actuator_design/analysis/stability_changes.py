"""Stability changes on a continued branch, located and inserted as points of the branch (THEORY §7).

The engine records the points it stepped to; a fold or branch point found on a step is located
there (brentq on the arclength of the step, each evaluation a corrected point) but is not one of
the branch's points, so a branch drawn point to point changes stability at the step's far end
(e.g. the straight rod in a transverse field drawn stable up to h ≈ 1.54 although stability is lost
at π/(2√2) ≈ 1.1107). :func:`insert_stability_changes` puts every located event into the branch in
arclength order, and locates on their own the inertia changes no event explains (two eigenvalues
crossing zero on one step, where neither the tangent nor det [G_x; tᵀW] changes sign), by brentq
on the signed smallest eigenvalue along the step.

An inserted point has Morse index min(before, after): the eigenvalue that crosses there is zero.
"""
from __future__ import annotations

from typing import List

import numpy as np

from actuator_design.continuation import PALC, ContinuationBranch, ContinuationSettings
from actuator_design.continuation.engine import locate_event

__all__ = ["insert_stability_changes"]


def _step_of(X: np.ndarray, W: np.ndarray, x: np.ndarray) -> int:
    """Index i of the step X[i] → X[i + 1] on which the point x lies (smallest detour in the
    W-norm: |X_i − x| + |x − X_{i+1}| − |X_i − X_{i+1}|)."""
    d = np.sqrt(np.einsum("ij,j,ij->i", X - x, W, X - x))
    seg = np.sqrt(np.einsum("ij,j,ij->i", np.diff(X, axis=0), W, np.diff(X, axis=0)))
    return int(np.argmin(d[:-1] + d[1:] - seg))


def insert_stability_changes(problem, settings: ContinuationSettings, res: ContinuationBranch) -> None:
    """Insert the located folds, branch points and stability changes into ``res`` (in place).

    Parameters
    ----------
    problem : BifurcationProblem
        The problem ``res`` was continued on.
    settings : ContinuationSettings
        The run's settings (tolerances for the locator).
    res : ContinuationBranch
        Its arrays ``x`` (N, n + 1), ``tangents``, ``morse_index``, ``min_eig`` gain one row per
        inserted point; unexplained inertia changes are appended to ``events`` as branch points.
    """
    if len(res) < 2:
        return
    X, W = res.x, problem.W
    idx = res.morse_index
    explained = set()
    for e in res.events:
        if e.located and e.kind in ("fold", "branch_point"):
            explained.add(_step_of(X, W, e.x))
    for i in np.flatnonzero(idx[1:] != idx[:-1]):
        if int(i) in explained:
            continue
        t = res.tangents[i]
        s = float((X[i + 1] - X[i]) @ (W * t))
        if not s > 0:
            continue
        ev = locate_event(problem, PALC(), settings, X[i], t, s, "branch_point", "branch_point",
                     idx[i], idx[i + 1])
        if ev.located:
            res.events.append(ev)
    inserts: List = sorted((e for e in res.events if e.located and e.kind in ("fold", "branch_point")),
                           key=lambda e: _step_of(X, W, e.x))
    for e in reversed(inserts):  # from the end, so that earlier step indices stay valid
        X = res.x
        k = _step_of(X, W, e.x) + 1
        _, mu, _ = problem.inertia(e.x)
        res.x = np.insert(X, k, e.x, axis=0)
        tan = e.tangent if e.tangent is not None else res.tangents[k - 1]
        res.tangents = np.insert(res.tangents, k, tan, axis=0)
        res.morse_index = np.insert(res.morse_index, k, min(e.index_before, e.index_after))
        res.min_eig = np.insert(res.min_eig, k, mu)
