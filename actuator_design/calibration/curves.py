"""Model curves of a fitted problem along its primary input (drawn by the fit figures)."""
from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence

import numpy as np

__all__ = ["model_curves", "branch_switches"]

#: Input column → column of FitProblem.U.
_INPUT_COLUMN = {"field": 0, "field_angle": 1, "load_x": 2, "load": 3, "load_y": 3}


def model_curves(problem, theta: np.ndarray, n_points: int) -> Dict[str, Any]:
    """Model outputs along the primary input, one curve per group of the other inputs.

    The primary input is the input column with the most distinct values; each curve starts
    from the fitted equilibrium of its group's first data point and continues by warm starts,
    keeping the stable branch nearest to the measurement interpolated there (as the fit does).
    Where the curve leaves one branch for another (:func:`branch_switches`; an imperfect rod's
    other branch appears beyond its fold, or the branch followed ends) the point is marked in
    ``branch_switch`` and the figure does not join the two branches by a solid line.

    Parameters
    ----------
    problem : FitProblem
        After a fit (its tracked equilibria start the curves).
    theta : ndarray, shape (k,)
        Fitted parameters, natural units.
    n_points : int
        Points per curve.

    Returns
    -------
    dict
        ``x`` (input name or None), ``groups``: list of {"label", "inputs": {name: value SI},
        "x": ndarray (m,), "y": {output: ndarray (m,) SI}, "stable": ndarray (m,) bool,
        "branch_switch": ndarray (m,) bool (point m is on another branch than point m − 1)}.
    """
    d, sel = problem.data, problem.selector
    names = [c for c in ("field", "load", "load_y", "load_x", "field_angle") if c in d.columns]
    if not names:
        return {"x": None, "groups": []}
    primary = max(names, key=lambda c: len(np.unique(d.columns[c])))
    jp = _INPUT_COLUMN[primary]
    others = [c for c in names if c != primary]
    keys = [tuple(d.columns[c][i] for c in others) for i in range(d.n)]
    rows_of: Dict[tuple, list] = {}
    for i, key in enumerate(keys):
        rows_of.setdefault(key, []).append(i)
    groups = []
    for key, rows in rows_of.items():
        idx = np.array(rows)
        idx = idx[np.argsort(problem.U[idx, jp], kind="stable")]
        xs = np.linspace(problem.U[idx[0], jp], problem.U[idx[-1], jp], n_points)
        u = problem.U[idx[0]].copy()
        z = problem.state_of_row(idx[0]).z
        ys, stable = np.zeros((n_points, len(problem.outputs))), np.zeros(n_points, bool)
        states: List[Optional[np.ndarray]] = [None] * n_points
        xd = problem.U[idx, jp]
        for m, x in enumerate(xs):
            u[jp] = x
            P, _ = problem.nlp_params(theta, u)
            # the measurement interpolated at x picks the branch, as for the data points
            target = np.array([np.interp(x, xd, problem.Y[idx, j])
                               for j in range(problem.Y.shape[1])])
            straight = sel.straight(P)
            starts = [straight] if z is None else [z, 2.0 * straight - z]
            best = sel.best(starts, P, problem.target_misfit(target))
            if best is None:
                ys[m] = np.nan
                continue
            (unstable, _), z, _, out = best
            states[m] = np.asarray(z, float)
            ys[m] = out
            stable[m] = not unstable
        label = ", ".join(f"{c} = {d.as_given(c, [v])[0]:.4g} {d.units[c]}".strip()
                          for c, v in zip(others, key))
        groups.append({"label": label, "inputs": dict(zip(others, key)), "x": xs,
                       "y": {o: ys[:, j] for j, o in enumerate(problem.outputs)}, "stable": stable,
                       "branch_switch": branch_switches(states)})
    return {"x": primary, "groups": groups}


def branch_switches(states: Sequence[Optional[np.ndarray]], ratio: float = 3.0,
                    floor: float = 1e-3) -> np.ndarray:
    """Where consecutive states of a curve sampled along its input lie on different branches.

    On one smooth branch, finely sampled, a step of the state neither reverses the previous
    step's direction nor grows several times over it; a jump to another branch does both (an
    imperfect rod leaving its natural branch for the data's: the angle climbs, then drops by
    several times the climb). Point m is marked when the step z_m − z_{m−1} points against
    z_{m−1} − z_{m−2}, is more than ``ratio`` times longer, and longer than ``floor`` (1 + |z_m|)
    (round-off on a flat branch is not a switch).

    Parameters
    ----------
    states : sequence of ndarray or None, length m
        The state (free node angles, rad) at each sample; None where no equilibrium was found.
    ratio, floor : float

    Returns
    -------
    ndarray of bool, shape (m,)
    """
    out = np.zeros(len(states), bool)
    for m in range(2, len(states)):
        a, b, c = states[m - 2], states[m - 1], states[m]
        if a is None or b is None or c is None:
            continue
        d0, d1 = b - a, c - b
        n0, n1 = float(np.linalg.norm(d0)), float(np.linalg.norm(d1))
        out[m] = bool(d0 @ d1 < 0 and n1 > ratio * n0 and n1 > floor * (1.0 + np.linalg.norm(c)))
    return out
