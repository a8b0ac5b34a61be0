"""The bench's study section: points per second of whole commands, against a solve_bvp walk.

Two measurements, each a pair of *whole commands* (start-up, imports, builds and output files
included) timed from outside in the same run, alternating, ``repeats`` times:

``sweep``
    ``actuator-design study`` of the transverse-field sweep (paper case 2: h ∈ [0, 2.5] × the
    field angles 30°, 60°, 80°, 90°; ``points`` points in all), against
    :mod:`actuator_design.benchmarks.study_peer` (``solve_bvp`` at tol 1e-8 walking the same grid,
    warm-started). The tips of the two are compared where both follow the same branch (φ ≠ 90°:
    at 90° the peer, which checks no stability, stays on the straight rod past the pitchfork).
``map``
    ``actuator-design map --no-curves`` on the φ = 0 (h², p) grid (h² ∈ [0, 20], p ∈ [0, 60],
    ``map_n``² points, stable counts, the fold curves not traced), against the ``solve_bvp`` walk
    of every ``peer_every``-th line of that grid in each direction (one state per point: the map
    counts every equilibrium, so the comparison is per point, not per answer; the peer is slow at
    large loads, hence the subsample).
"""
from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

__all__ = ["run_study_bench", "format_study_bench", "SWEEP_ANGLES_DEG"]

SWEEP_ANGLES_DEG = (30.0, 60.0, 80.0, 90.0)


def _sweep_yaml(n_h: int) -> str:
    angles = ", ".join(f"{a:g} deg" for a in SWEEP_ANGLES_DEG)
    return f"""name: "bench sweep: transverse field"
scene: {{type: dimensionless, h: 1.0, phi: 90 deg, p: 0, fibres: 0 deg}}
solver: {{elements: 4, degree: 10}}
study:
  type: sweep
  sweep:
    h: {{from: 0.0, to: 2.5, n: {n_h}}}
    phi: [{angles}]
  analyses: [solve]
  outputs: ["solve.success", "solve.stable", "solve.morse_index", "solve.tip.*", "solve.energy",
            "solve.gamma", "solve.el_residual"]
  figures:
    - {{x: h, y: solve.tip.angle, hue: phi}}
"""


def _map_peer_yaml(n: int, every: int) -> str:
    h2 = np.linspace(0.0, 20.0, n)[::every]
    p = np.linspace(0.0, 60.0, n)[::every]
    hs = ", ".join(repr(float(math.sqrt(v))) for v in h2)
    ps = ", ".join(repr(float(v)) for v in p)
    return f"""name: "bench: solve_bvp walk of the map grid"
scene: {{type: dimensionless, h: 0.0, phi: 0 deg, p: 0}}
study:
  type: sweep
  sweep:
    p: [{ps}]
    h: [{hs}]
  analyses: [solve]
"""


def _timed(cmd: List[str], cwd: Path) -> float:
    t = time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - t
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd[:4])} … failed (exit {done.returncode}): "
                           f"{done.stderr.strip().splitlines()[-1] if done.stderr.strip() else ''}")
    return elapsed


def _tip_agreement(study_csv: Path, peer_csv: Path) -> float:
    """max |Δ(x, y, θ)(1)| between the study and the peer at φ ≠ 90° (the same branch)."""
    def key(h, phi):
        return round(float(h), 9), round(float(phi), 6)

    with open(peer_csv, newline="") as fh:
        peer = {}
        for r in csv.DictReader(fh):
            phi = float(r["phi"].split()[0])
            if r["success"] == "True" and abs(phi - 90.0) > 1e-9:
                peer[key(r["h"], phi)] = (float(r["tip_x"]), float(r["tip_y"]), float(r["tip_angle"]))
    worst = 0.0
    with open(study_csv, newline="") as fh:
        for r in csv.DictReader(fh):
            k = key(r["h"], r["phi [deg]"])
            if k in peer and r["solve.success"] == "true":
                ours = (float(r["solve.tip.x"]), float(r["solve.tip.y"]), float(r["solve.tip.angle"]))
                worst = max(worst, max(abs(a - b) for a, b in zip(ours, peer[k])))
    return worst


def run_study_bench(points: int = 8000, map_n: int = 200, peer_every: int = 20, repeats: int = 3,
                    workers: int = 0, progress=print) -> Dict[str, dict]:
    """Run both measurements (module doc); ``workers`` 0 means every core.

    Returns
    -------
    dict
        ``{"sweep": {...}, "map": {...}}`` with the wall times of every run (s), their medians,
        points per second and the speed-up per point over the peer.
    """
    py = sys.executable
    n_h = max(2, points // len(SWEEP_ANGLES_DEG))
    n_points = n_h * len(SWEEP_ANGLES_DEG)
    w = ["--workers", str(workers)] if workers else []
    out: Dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="ad-bench-") as tmp:
        tmp = Path(tmp)
        sweep = tmp / "sweep.yaml"
        sweep.write_text(_sweep_yaml(n_h))
        ours, peer = [], []
        for k in range(repeats):
            progress(f"study bench: sweep run {k + 1}/{repeats} ({n_points} points)")
            ours.append(_timed([py, "-m", "actuator_design.cli.main", "study", str(sweep), "--out",
                                str(tmp / f"study{k}"), "--no-progress", *w], tmp))
            peer.append(_timed([py, "-m", "actuator_design.benchmarks.study_peer", str(sweep),
                                "--out", str(tmp / "peer.csv"), "--tol", "1e-8"], tmp))
        out["sweep"] = _summary(n_points, ours, peer)
        out["sweep"]["max_tip_difference"] = _tip_agreement(tmp / "study0" / "results.csv",
                                                            tmp / "peer.csv")
        peer_yaml = tmp / "map_peer.yaml"
        peer_yaml.write_text(_map_peer_yaml(map_n, peer_every))
        n_peer = len(np.linspace(0, 1, map_n)[::peer_every]) ** 2
        ours, peer = [], []
        for k in range(repeats):
            progress(f"study bench: map run {k + 1}/{repeats} ({map_n}x{map_n} points)")
            ours.append(_timed([py, "-m", "actuator_design.cli.main", "map", "--phi-deg", "0",
                                "--n", str(map_n), "--no-curves", "--quiet", "--out",
                                str(tmp / f"map{k}"), *w], tmp))
            peer.append(_timed([py, "-m", "actuator_design.benchmarks.study_peer", str(peer_yaml),
                                "--tol", "1e-8"], tmp))
        out["map"] = _summary(map_n * map_n, ours, peer, n_peer)
    out["protocol"] = {"repeats": repeats, "workers": workers or os.cpu_count(),
                       "timing": "wall time of the whole command, start-up and files included"}
    return out


def _summary(n: int, ours: List[float], peer: List[float], n_peer: int = None) -> dict:
    n_peer = n if n_peer is None else n_peer
    mo, mp = float(np.median(ours)), float(np.median(peer))
    return {"points": n, "peer_points": n_peer, "wall_s": ours, "peer_wall_s": peer,
            "median_s": mo, "peer_median_s": mp, "points_per_s": n / mo,
            "peer_points_per_s": n_peer / mp, "speedup_per_point": (n / mo) / (n_peer / mp)}


def format_study_bench(res: Dict[str, dict]) -> str:
    """The two measurements as a small table."""
    lines = ["study bench (whole commands, median wall time; peer: solve_bvp tol 1e-8 walking the grid)",
             f"{'measurement':<10s} {'points':>8s} {'time':>8s} {'points/s':>10s} "
             f"{'peer pts':>9s} {'peer time':>10s} {'peer pts/s':>11s} {'speed-up':>9s}"]
    for name in ("sweep", "map"):
        r = res[name]
        lines.append(f"{name:<10s} {r['points']:>8d} {r['median_s']:>7.2f}s {r['points_per_s']:>10.0f} "
                     f"{r['peer_points']:>9d} {r['peer_median_s']:>9.2f}s {r['peer_points_per_s']:>11.0f} "
                     f"{r['speedup_per_point']:>8.1f}x")
    lines.append(f"sweep tips against the peer (phi != 90 deg): max difference "
                 f"{res['sweep']['max_tip_difference']:.1e}")
    return "\n".join(lines)
