"""Multiplicity maps: the number of equilibria (and of stable ones) over a 2-D parameter grid.

The engine is the vectorised shooting scan of :mod:`.equilibria` (THEORY §5, §7): for every grid
point, the free-end residual r(γ) = b(1)θ'(1) − m is evaluated on ``n_gamma`` values of γ = θ'(0)
spread over that point's a-priori window (which contains every equilibrium), for a whole row of
the grid at once, and its sign changes are counted. With ``stability=True`` the Jacobi field
η = ∂θ/∂γ is integrated alongside and each root's Morse index is Sturm's count
Z(η) + [η(1)·r'(γ) < 0] (THEORY §7), so stable equilibria are counted too. Rows are distributed
over processes (``concurrent.futures.ProcessPoolExecutor``) with a ``tqdm`` progress bar on stderr.

Resolution: roots closer together than the γ step (grid points within about that distance of a
fold curve) may be missed; the counts are exact elsewhere up to the RK4 error (``rad_per_step``).
The γ samples are raised to :func:`~.shooting_scan.min_gamma_points` where the IVP amplifies
strongly, and a grid point where the scan cannot be trusted (:func:`~.shooting_scan.scan_validity`)
is counted −1 (unknown), never 0. ``bistable`` marks the points with two or more stable equilibria.
"""
from __future__ import annotations

import io
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..scene import Scene
from .. import parameters as lens
from .continuation import set_param
from .shooting_scan import ShootingProblem, gamma_bound, min_gamma_points, scan_validity, steps_for
from .registry import register

__all__ = ["MultiplicityMap", "multiplicity_map", "count_row"]


@dataclass
class MultiplicityMap:
    """Counts of equilibria on a grid.

    Attributes
    ----------
    x_param, y_param : str
        Parameter names (of the lens, :mod:`actuator_design.parameters`).
    x, y : ndarray, shapes (nx,), (ny,)
    counts, stable : ndarray of int, shape (ny, nx)
        Number of equilibria and of stable equilibria at (x[j], y[i]); −1 where the scan cannot be
        trusted there (unknown).
    """

    x_param: str
    y_param: str
    x: np.ndarray
    y: np.ndarray
    counts: np.ndarray
    stable: np.ndarray
    settings: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)

    @property
    def complete(self) -> np.ndarray:
        """bool (ny, nx): the scan could be trusted at this grid point."""
        return self.counts >= 0

    @property
    def bistable(self) -> np.ndarray:
        """bool (ny, nx): two or more stable equilibria (hysteresis and snapping are possible)."""
        return self.stable >= 2

    def to_dict(self) -> dict:
        """The ``map --json`` contract: ``counts`` and ``stable`` (−1 = unknown), ``bistable``,
        ``complete`` (every point trusted) and ``incomplete_points``."""
        return {"x_param": self.x_param, "y_param": self.y_param, "x": self.x.tolist(),
                "y": self.y.tolist(), "counts": self.counts.tolist(), "stable": self.stable.tolist(),
                "distinct_counts": sorted(int(v) for v in np.unique(self.counts)),
                "distinct_stable_counts": sorted(int(v) for v in np.unique(self.stable)),
                "bistable": self.bistable.tolist(), "complete": bool(np.all(self.complete)),
                "incomplete_points": int(np.sum(~self.complete)),
                "settings": self.settings, "stats": self.stats}

    def csv_text(self) -> str:
        """Long-format CSV: x, y, equilibria, stable (one line per grid point)."""
        buf = io.StringIO()
        buf.write(f"# multiplicity map; {self.x_param}: {lens.parameter(self.x_param).describe()}; "
                  f"{self.y_param}: {lens.parameter(self.y_param).describe()}; equilibria, stable: "
                  f"numbers of equilibria and of stable ones, -1 where the scan cannot be trusted\n")
        buf.write(f"{self.x_param},{self.y_param},equilibria,stable\n")
        for i, yv in enumerate(self.y):
            for j, xv in enumerate(self.x):
                buf.write(f"{float(xv)!r},{float(yv)!r},{int(self.counts[i, j])},{int(self.stable[i, j])}\n")
        return buf.getvalue()


#: Scenes integrated together: B × n_gamma arrays of a few 10⁴ numbers stay in the CPU cache.
BATCH = 40


def count_row(scenes: Sequence[Scene], n_gamma: int = 161, rad_per_step: float = 0.3,
              stability: bool = True):
    """Counts for a batch of uniform-field scenes (e.g. one grid row).

    Parameters
    ----------
    scenes : sequence of Scene, length B
    n_gamma : int
        γ samples per scene over its a-priori window (made odd so that γ = 0 is one).
    rad_per_step : float
        RK4 step: the tangent turns by at most this much per step (rad).
    stability : bool
        Also count the stable equilibria (Jacobi field, Sturm's Morse index).

    Returns
    -------
    counts, stable : ndarray of int, shape (B,)
        ``stable`` is −1 when ``stability`` is False; both are −1 for a scene whose scan cannot be
        trusted (:func:`~.shooting_scan.scan_validity`).
    """
    scenes = list(scenes)
    if len(scenes) > BATCH:
        parts = [count_row(scenes[i:i + BATCH], n_gamma, rad_per_step, stability)
                 for i in range(0, len(scenes), BATCH)]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    W = np.array([gamma_bound(sc)["window"] for sc in scenes])
    valid = np.array([scan_validity(sc, w, rad_per_step)["valid"] for sc, w in zip(scenes, W)])
    if not np.all(valid):  # count the trusted scenes only; the others are unknown (-1)
        counts, stable = np.full(len(scenes), -1), np.full(len(scenes), -1)
        if np.any(valid):
            ok = np.flatnonzero(valid)
            counts[ok], stable[ok] = count_row([scenes[i] for i in ok], n_gamma, rad_per_step, stability)
        return counts, stable
    N = max(steps_for(sc, w, min_steps=16, rad_per_step=rad_per_step) for sc, w in zip(scenes, W))
    G = max(int(n_gamma), max(min_gamma_points(sc, w) for sc, w in zip(scenes, W))) | 1
    g = W[:, None] * np.linspace(-1.0, 1.0, G)[None, :]
    prob = ShootingProblem(scenes, N)
    if stability:
        r, Z, eta1 = prob.residual(g, jacobi=True)
    else:
        r = prob.residual(g)
    sc_mask = r[:, :-1] * r[:, 1:] < 0.0
    zero = r == 0.0
    counts = sc_mask.sum(1) + zero.sum(1)
    if not stability:
        return counts, np.full_like(counts, -1)
    # Morse index at each root from the end of its bracket with the smaller |r|
    left = np.abs(r[:, :-1]) <= np.abs(r[:, 1:])
    Zb = np.where(left, Z[:, :-1], Z[:, 1:])
    eb = np.where(left, eta1[:, :-1], eta1[:, 1:])
    dr = r[:, 1:] - r[:, :-1]
    stable_b = sc_mask & (Zb == 0) & (eb * dr > 0)
    # exact zeros: slope from the neighbours
    dz = np.zeros_like(r)
    dz[:, 1:-1] = r[:, 2:] - r[:, :-2]
    stable_z = zero & (Z == 0) & (eta1 * dz > 0)
    return counts, stable_b.sum(1) + stable_z.sum(1)


def _rows(scene, x_param, xs, y_param, ys, n_gamma, rad_per_step, stability):
    out_c, out_s = [], []
    for yv in ys:
        base = set_param(scene, y_param, yv)
        c, s = count_row([set_param(base, x_param, xv) for xv in xs], n_gamma, rad_per_step, stability)
        out_c.append(c)
        out_s.append(s)
    return np.array(out_c), np.array(out_s)


def multiplicity_map(scene: Scene, x_param: str, x_values, y_param: str, y_values, *,
                     n_gamma: int = 161, rad_per_step: float = 0.3, stability: bool = True,
                     workers: Optional[int] = None, rows_per_task: int = 2,
                     progress: Optional[bool] = None) -> MultiplicityMap:
    """Number of equilibria (and stable ones) at every (x, y) of a grid.

    Parameters
    ----------
    scene : Scene
        Uniform field (or none); other parameters fixed at their values here.
    x_param, y_param : str
        Names of the parameter lens (e.g. ``"h2"``, ``"p"``).
    x_values, y_values : array_like, shapes (nx,), (ny,)
    n_gamma : int
        γ samples per grid point (made odd).
    rad_per_step : float
        RK4 resolution: the tangent turns by at most this per step (rad).
    workers : int, optional
        Processes (default: all cores; 1 runs in this process).
    progress : bool, optional
        tqdm bar on stderr (default: only when stderr is a terminal).

    Returns
    -------
    MultiplicityMap
    """
    from tqdm import tqdm

    for name in (x_param, y_param):
        lens.parameter(name, "map parameter")
    if x_param == y_param:
        raise ValueError("x_param and y_param must differ")
    xs = np.asarray(x_values, float).ravel()
    ys = np.asarray(y_values, float).ravel()
    set_param(set_param(scene, x_param, xs[0]), y_param, ys[0])  # validates names and values
    t0 = time.perf_counter()
    workers = (os.cpu_count() or 1) if workers is None else max(1, int(workers))
    if progress is None:
        progress = sys.stderr.isatty()
    counts = np.zeros((ys.size, xs.size), int)
    stable = np.zeros((ys.size, xs.size), int)
    chunks = [list(range(i, min(i + rows_per_task, ys.size))) for i in range(0, ys.size, rows_per_task)]
    bar = tqdm(total=ys.size, disable=not progress, file=sys.stderr, desc="multiplicity map", unit="row")
    args = (n_gamma, rad_per_step, stability)
    if workers == 1:
        for rows in chunks:
            c, s = _rows(scene, x_param, xs, y_param, ys[rows], *args)
            counts[rows], stable[rows] = c, s
            bar.update(len(rows))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futs = {pool.submit(_rows, scene, x_param, xs, y_param, ys[rows], *args): rows for rows in chunks}
            for fut in as_completed(futs):
                rows = futs[fut]
                c, s = fut.result()
                counts[rows], stable[rows] = c, s
                bar.update(len(rows))
    bar.close()
    return MultiplicityMap(x_param, y_param, xs, ys, counts, stable,
                           {"n_gamma": int(n_gamma) | 1, "rad_per_step": rad_per_step,
                            "stability": stability, "workers": workers},
                           {"time_s": time.perf_counter() - t0, "grid": [int(ys.size), int(xs.size)]})


@register("map")
def run_map(scene, options, **settings) -> dict:
    """Settings: ``x_param``, ``x_range`` (a, b), ``y_param``, ``y_range``, ``n`` (nx, ny)."""
    try:
        xp, xr, yp, yr = (settings.pop(k) for k in ("x_param", "x_range", "y_param", "y_range"))
    except KeyError as err:
        raise ValueError(f"map needs the setting {err.args[0]!r}") from None
    nx, ny = settings.pop("n", (50, 50))
    m = multiplicity_map(scene, xp, np.linspace(*xr, int(nx)), yp, np.linspace(*yr, int(ny)),
                         **settings)
    return m.to_dict()
