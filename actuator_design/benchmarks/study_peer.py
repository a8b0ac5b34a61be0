"""The peer of a study sweep: scipy's ``solve_bvp`` walking the same grid, warm-started.

A plain loop a user could write without this package's solvers: every grid point's configuration
is validated and turned into a scene exactly as the study does (:func:`actuator_design.config.load_config`),
the points are walked line by line along the swept key with the most values (ascending, so each
point starts from its neighbour's solution; the first of a line from the straight rod), each
solved by :func:`~actuator_design.benchmarks.bvp.solve_bvp_peer` at ``tol``, and the tips are
written to a CSV. It checks no stability and follows whatever branch continuity gives it, so it
does less than the study it is compared with.

Run as a whole command (the bench times it from outside, start-up included)::

    python -m actuator_design.benchmarks.study_peer CONFIG.yaml --out tips.csv [--tol 1e-8]
"""
from __future__ import annotations

import argparse
import csv
import itertools
import sys
import time
from typing import List, Optional

from actuator_design.benchmarks.bvp import bvp_from_scene, solve_bvp_peer
from actuator_design.config import load_config
from actuator_design.study.grid import resolve_axes, substitute
from actuator_design.config.studies.sweep import SweepSpec
from actuator_design.config.studies.validation import validate_spec

__all__ = ["walk_order", "bvp_walk", "main"]


def walk_order(sizes: List[int], grid: str) -> List[List[tuple]]:
    """Lines of value indices: along the axis with the most values, every other axis fixed
    (cartesian), or the zipped points as one line."""
    if grid == "zip":
        return [[(i,) * len(sizes) for i in range(sizes[0])]]
    k = max(range(len(sizes)), key=lambda a: sizes[a])
    others = [range(n) if a != k else [None] for a, n in enumerate(sizes)]
    lines = []
    for fixed in itertools.product(*others):
        lines.append([tuple(j if a == k else fixed[a] for a in range(len(sizes)))
                      for j in range(sizes[k])])
    return lines


def bvp_walk(config_path: str, tol: float = 1e-8, out: Optional[str] = None) -> dict:
    """Solve every point of a sweep study with ``solve_bvp``, warm-started along grid lines.

    Returns
    -------
    dict
        ``points``, ``converged``, ``elapsed_s`` (the loop only) and ``points_per_s``.
    """
    config = load_config(config_path)
    spec = validate_spec(SweepSpec, config.study)
    axes = resolve_axes(spec)
    rows, converged, n = [], 0, 0
    t0 = time.perf_counter()
    for line in walk_order([len(a.values) for a in axes], spec.grid):
        previous = None
        for idx in line:
            scene = load_config(substitute(config.raw, axes, idx)).to_scene()
            sol = solve_bvp_peer(bvp_from_scene(scene), tol, initial=previous)
            previous = sol if sol.success else None
            converged += bool(sol.success)
            n += 1
            rows.append([a.values[j] for a, j in zip(axes, idx)] + [sol.success, *sol.tip])
    elapsed = time.perf_counter() - t0
    if out:
        with open(out, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([a.key for a in axes] + ["success", "tip_x", "tip_y", "tip_angle"])
            w.writerows(rows)
    return {"points": n, "converged": converged, "elapsed_s": elapsed,
            "points_per_s": n / elapsed if elapsed > 0 else None}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("--out", help="CSV of the tips")
    ap.add_argument("--tol", type=float, default=1e-8)
    args = ap.parse_args(argv)
    r = bvp_walk(args.config, args.tol, args.out)
    print(f"solve_bvp walk: {r['points']} points ({r['converged']} converged) in {r['elapsed_s']:.2f} s, "
          f"{r['points_per_s']:.1f} points/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
