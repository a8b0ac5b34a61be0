"""Benchmark: the same solve sweep on the local process pool and on a local Dask cluster.

The transverse-field sweep (h ∈ [0, 2.5] × 4 field angles, ``--points`` points, walked in chunks
fixed by the grid) is run, in this process, by :func:`actuator_design.study.run_study` with
``workers=W`` (a ``concurrent.futures`` pool forked from this process) and with ``scheduler=`` a
``distributed.LocalCluster`` of W single-threaded worker processes, each at two chunk sizes
(256, the default, and 16: more tasks, so the per-task cost shows). It prints the wall time of
each run, points per second, and the overhead per task and per point of Dask against the pool,
from the difference of the two chunk sizes (after a warm-up run on the cluster, whose workers
import the package and build the solver once). The tables of the two backends must be identical
at one chunk size (chunks are fixed by the grid); across chunk sizes the tips must agree to the
solver's tolerance. Run:
``python problems/bench_study_dask.py [--points 4000] [--workers 2]``.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import tempfile
import time
from pathlib import Path


def _config(n_h: int, chunk: int) -> dict:
    return {"name": "dask bench", "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
            "solver": {"elements": 4, "degree": 10},
            "study": {"type": "sweep", "chunk_size": chunk,
                      "sweep": {"h": {"from": 0.0, "to": 2.5, "n": n_h},
                                "phi": ["30 deg", "60 deg", "80 deg", "90 deg"]},
                      "analyses": ["solve"], "outputs": ["solve.success", "solve.tip.*"],
                      "figures": []}}


def _table(folder: Path):
    with open(folder / "results.csv", newline="") as fh:
        return [{k: v for k, v in r.items() if k != "time_s"} for r in csv.DictReader(fh)]


def _largest_tip_difference(a, b) -> float:
    cols = ("solve.tip.x", "solve.tip.y", "solve.tip.angle")
    return max(abs(float(r[c]) - float(q[c])) for r, q in zip(a, b) for c in cols)


def main(argv=None):
    from actuator_design.study import run_study

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=4000)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    args = ap.parse_args(argv)
    n_h = max(2, args.points // 4)
    n = 4 * n_h
    from distributed import Client, LocalCluster

    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # the pool first: with no thread running in this process its workers are forked (they
        # inherit the imported package and the built solver); a Dask client starts threads
        run_study(_config(8, 256), tmp / "warm-pool", progress=False, workers=args.workers)
        for chunk in (256, 16):
            out = tmp / f"processes-{chunk}"
            t = time.perf_counter()
            run_study(_config(n_h, chunk), out, progress=False, workers=args.workers)
            results[("processes", chunk)] = (time.perf_counter() - t, _table(out))
        t = time.perf_counter()
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        start = time.perf_counter() - t
        try:  # warm-up: the cluster's workers import the package and build the solver once
            run_study(_config(8, 256), tmp / "warm", progress=False, scheduler=client)
            for chunk in (256, 16):
                out = tmp / f"dask-{chunk}"
                t = time.perf_counter()
                run_study(_config(n_h, chunk), out, progress=False, scheduler=client)
                results[("dask", chunk)] = (time.perf_counter() - t, _table(out))
        finally:
            client.close()
            cluster.close()
    same = all(results[("dask", c)][1] == results[("processes", c)][1] for c in (256, 16))
    across = _largest_tip_difference(results[("processes", 16)][1], results[("processes", 256)][1])
    print(f"{n} points, {args.workers} workers; LocalCluster start-up {start:.2f} s (not counted)")
    for (backend, chunk), (wall, _) in results.items():
        tasks = sum(math.ceil(n_h / chunk) for _ in range(4))
        print(f"  {backend:9s} chunk {chunk:3d} ({tasks:4d} tasks): {wall:6.2f} s, {n / wall:7.0f} points/s")
    extra = {b: results[(b, 16)][0] - results[(b, 256)][0] for b in ("processes", "dask")}
    more_tasks = 4 * (math.ceil(n_h / 16) - math.ceil(n_h / 256))
    per_task = (extra["dask"] - extra["processes"]) / more_tasks
    print(f"  Dask over the pool: {1e3 * per_task:.2f} ms per task (from the extra tasks of chunk 16), "
          f"{1e3 * (results[('dask', 256)][0] - results[('processes', 256)][0]) / n:.3f} ms per point "
          f"at the default chunks")
    print(f"  tables identical on the pool and on Dask (same chunks): {same}; chunk 16 against 256: "
          f"largest tip difference {across:.1e} (each chunk walked from rest)")
    return 0 if same and across < 1e-8 else 1


if __name__ == "__main__":
    raise SystemExit(main())
