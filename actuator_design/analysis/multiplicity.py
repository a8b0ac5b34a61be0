"""Multiplicity maps: the number of equilibria (and of stable ones) over a 2-D parameter grid.

The engine is the vectorised shooting scan of :mod:`.equilibria` (THEORY §5, §7): for every grid
point, the sign changes of the free-end residual r(γ) = b(1)θ'(1) − m are counted on a fine grid of
at least ``n_gamma`` values of γ = θ'(0) spread over that point's a-priori window (which contains
every equilibrium). With ``stability=True`` each root's Morse index is Sturm's count
Z(η) + [η(1)·r'(γ) < 0] of the Jacobi field η = ∂θ/∂γ (THEORY §7), so stable equilibria are
counted too. The fine grid is visited coarse to fine (:mod:`.multiplicity_scan`): r and its slope
r'(γ) (from the Jacobi field) on every 16th fine sample, then bisection only where r may vanish,
for all the points of a task at once (each with its own RK4 step count). Tasks of whole grid rows
are distributed over processes (``concurrent.futures.ProcessPoolExecutor``) with a ``tqdm``
progress bar on stderr; the counts depend neither on the tasks nor on the workers.

Resolution: roots closer together than the fine γ step (grid points within about that distance of
a fold curve) may be missed; the counts are exact elsewhere up to the RK4 error (``rad_per_step``).
The fine γ samples are raised to :func:`~.shooting_scan.min_gamma_points` where the IVP amplifies
strongly (each point takes the finest step and γ grid any of the :data:`BATCH` neighbours of its row
needs), and a grid point where the scan cannot be trusted (:func:`~.shooting_scan.scan_validity`)
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

from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.analysis.multiplicity_scan import count_roots
from actuator_design.analysis.shooting_scan import (ShootingProblem, curvature_bound, gamma_bound,
                                                    growth_exponent, is_autonomous, min_gamma_points,
                                                    scan_validity, steps_for)
from actuator_design.analysis.registration import register
from actuator_design.contact.guard import no_contact

__all__ = ["MultiplicityMap", "multiplicity_map", "count_row", "count_rows"]


@dataclass
class MultiplicityMap:
    """Counts of equilibria on a grid.

    Attributes
    ----------
    x_param, y_param : str
        Parameter names (of the lens, :mod:`actuator_design.physics.parameters`).
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


def set_param(scene: Scene, name: str, value: float) -> Scene:
    """A copy of ``scene`` with the lens parameter ``name`` set to ``value``
    (:func:`actuator_design.physics.parameters.set_value`; without importing the continuation engine)."""
    return lens.set_value(scene, name, value, "map parameter")


#: Points of a grid row that share one resolution: each takes the finest RK4 step and γ grid any of
#: the :data:`BATCH` consecutive trusted points of its row needs (the rule of the row-batched scan
#: the maps were first computed with, so that the counts are those of that scan, sample for sample).
BATCH = 40
#: Grid points per task of :func:`multiplicity_map` by default (rows are not split).
POINTS_PER_TASK = 5000


def _plan(scenes: Sequence[Scene], n_gamma: int, rad_per_step: float):
    """Window W, trust, RK4 steps N and fine γ samples G of each scene of one grid row (:data:`BATCH`).

    Returns
    -------
    window : ndarray, shape (B,)
    valid : ndarray of bool, shape (B,)
        :func:`~.shooting_scan.scan_validity`; N and G are 0 where False.
    steps, n_fine : ndarray of int, shape (B,)
    """
    B = len(scenes)
    window, steps, n_fine = np.zeros(B), np.zeros(B, int), np.zeros(B, int)
    valid = np.zeros(B, bool)
    for i, sc in enumerate(scenes):
        gb = gamma_bound(sc)
        w = window[i] = gb["window"]
        L = growth_exponent(sc)
        kappa = curvature_bound(sc, w, bound=gb)
        valid[i] = scan_validity(sc, w, rad_per_step, exponent=L, kappa=kappa)["valid"]
        steps[i] = steps_for(sc, w, min_steps=16, rad_per_step=rad_per_step, kappa=kappa)
        n_fine[i] = min_gamma_points(sc, w, exponent=L)
    for b in range(0, B, BATCH):
        ok = np.flatnonzero(valid[b:b + BATCH]) + b
        if ok.size:
            steps[ok] = steps[ok].max()
            n_fine[ok] = max(int(n_gamma), int(n_fine[ok].max())) | 1
    steps[~valid], n_fine[~valid] = 0, 0
    return window, valid, steps, n_fine


def count_rows(rows: Sequence[Sequence[Scene]], n_gamma: int = 161, rad_per_step: float = 0.3,
               stability: bool = True):
    """Counts for several grid rows of uniform-field scenes, integrated together.

    All the trusted points whose equation does not depend on s (constant b, α, β and no distributed
    load) form one block, scanned coarse to fine at once (:func:`~.multiplicity_scan.count_roots`),
    each with its own number of RK4 steps; the others form one block per number of steps.

    Parameters
    ----------
    rows : sequence of sequences of Scene
        R rows of B scenes each (the rows may differ in length).
    n_gamma, rad_per_step, stability
        As in :func:`count_row`.

    Returns
    -------
    counts, stable : list of ndarray of int, shapes (B,) per row
        −1 where the scan cannot be trusted (and ``stable`` −1 everywhere without ``stability``).
    stats : dict
        γ samples evaluated and those of a full fine scan.
    """
    rows = [list(r) for r in rows]
    plans = [_plan(r, n_gamma, rad_per_step) for r in rows]
    flat = [sc for r in rows for sc in r]
    window, valid, steps, n_fine = (np.concatenate([p[v] for p in plans]) for v in range(4))
    counts, stable = np.full(len(flat), -1), np.full(len(flat), -1)
    stats = {"samples": 0, "fine_samples": 0}
    autonomous = np.array([is_autonomous(sc) for sc in flat], bool)
    blocks = [(np.flatnonzero(valid & autonomous), True)]
    blocks += [(np.flatnonzero(valid & ~autonomous & (steps == N)), False)
               for N in np.unique(steps[valid & ~autonomous])]
    for members, own_steps in blocks:
        if not members.size:
            continue
        prob = ShootingProblem([flat[i] for i in members], int(steps[members].max()))
        c, s, st = count_roots(prob, window[members], n_fine[members], stability,
                               steps[members] if own_steps else None)
        counts[members], stable[members] = c, s
        for k in stats:
            stats[k] += st[k]
    ends = np.cumsum([0] + [len(r) for r in rows])
    return ([counts[a:b] for a, b in zip(ends[:-1], ends[1:])],
            [stable[a:b] for a, b in zip(ends[:-1], ends[1:])], stats)


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
    counts, stable, _ = count_rows([scenes], n_gamma, rad_per_step, stability)
    return counts[0], stable[0]


def _rows(scene, x_param, xs, y_param, ys, n_gamma, rad_per_step, stability):
    grid = []
    for yv in ys:
        base = set_param(scene, y_param, yv)
        grid.append([set_param(base, x_param, xv) for xv in xs])
    counts, stable, stats = count_rows(grid, n_gamma, rad_per_step, stability)
    return np.array(counts), np.array(stable), stats


@no_contact("map")
def multiplicity_map(scene: Scene, x_param: str, x_values, y_param: str, y_values, *,
                     n_gamma: int = 161, rad_per_step: float = 0.3, stability: bool = True,
                     workers: Optional[int] = None, rows_per_task: Optional[int] = None,
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
    rows_per_task : int, optional
        Grid rows counted together in one task (default: about :data:`POINTS_PER_TASK` points; the
        bigger the block of points integrated at once, the smaller the overhead per point). A grid
        of one task is counted in this process. The counts depend neither on it nor on ``workers``.
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
    if rows_per_task is None:
        rows_per_task = max(1, POINTS_PER_TASK // xs.size)
    # task t counts rows t, t + T, t + 2T, ... (T tasks): every task gets a share of each part of
    # the grid, so that the tasks cost about the same and the workers finish together
    n_tasks = -(-ys.size // int(rows_per_task))
    chunks = [list(range(t, ys.size, n_tasks)) for t in range(n_tasks)]
    samples = {"samples": 0, "fine_samples": 0}
    bar = tqdm(total=ys.size, disable=not progress, file=sys.stderr, desc="multiplicity map", unit="row")
    args = (n_gamma, rad_per_step, stability)

    def collect(rows, result):
        counts[rows], stable[rows] = result[0], result[1]
        for k in samples:
            samples[k] += result[2][k]
        bar.update(len(rows))

    if workers == 1 or len(chunks) == 1:
        for rows in chunks:
            collect(rows, _rows(scene, x_param, xs, y_param, ys[rows], *args))
    else:
        with ProcessPoolExecutor(max_workers=min(workers, len(chunks))) as pool:
            futs = {pool.submit(_rows, scene, x_param, xs, y_param, ys[rows], *args): rows for rows in chunks}
            for fut in as_completed(futs):
                collect(futs[fut], fut.result())
    bar.close()
    return MultiplicityMap(x_param, y_param, xs, ys, counts, stable,
                           {"n_gamma": int(n_gamma) | 1, "rad_per_step": rad_per_step,
                            "stability": stability, "workers": workers},
                           {"time_s": time.perf_counter() - t0, "grid": [int(ys.size), int(xs.size)],
                            "gamma_samples": samples["samples"],
                            "gamma_samples_full_scan": samples["fine_samples"]})


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
