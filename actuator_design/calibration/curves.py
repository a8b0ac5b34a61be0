"""Model curves of a fitted problem along its primary input (drawn by the fit figures)."""
from __future__ import annotations

from typing import Any, Dict

import numpy as np

__all__ = ["model_curves"]

#: Input column → column of FitProblem.U.
_INPUT_COLUMN = {"field": 0, "field_angle": 1, "load_x": 2, "load": 3, "load_y": 3}


def model_curves(problem, theta: np.ndarray, n_points: int) -> Dict[str, Any]:
    """Model outputs along the primary input, one curve per group of the other inputs.

    The primary input is the input column with the most distinct values; each curve starts
    from the fitted equilibrium of its group's first data point and continues by warm starts,
    keeping the stable branch nearest to the measurement interpolated there (as the fit does).

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
        "x": ndarray (m,), "y": {output: ndarray (m,) SI}, "stable": ndarray (m,) bool}.
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
            ys[m] = out
            stable[m] = not unstable
        label = ", ".join(f"{c} = {d.as_given(c, [v])[0]:.4g} {d.units[c]}".strip()
                          for c, v in zip(others, key))
        groups.append({"label": label, "inputs": dict(zip(others, key)), "x": xs,
                       "y": {o: ys[:, j] for j, o in enumerate(problem.outputs)}, "stable": stable})
    return {"x": primary, "groups": groups}
