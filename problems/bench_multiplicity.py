"""Benchmark: the φ = 0 multiplicity map on a 200 × 200 grid of (h², p) (target: ≤ 10 s on 2 cores).

h² ∈ [0, 20], p ∈ [0, 60] (the paper's phase diagram), at least 161 shooting parameters per grid
point, the Jacobi field integrated too (stable counts). The residual is evaluated coarse to fine
(:mod:`actuator_design.analysis.multiplicity_scan`): the script prints how many γ samples were
evaluated against those of a full fine scan, and the time per grid point. Run:
``python problems/bench_multiplicity.py [--n 200] [--workers 2] [--no-stability]``.
"""
from __future__ import annotations

import argparse
import os
import resource
import time

START = time.perf_counter()  # the whole script's time includes the imports below

import numpy as np  # noqa: E402

from actuator_design.analysis.multiplicity import multiplicity_map  # noqa: E402
from actuator_design.model.scene import default_scene  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--no-stability", action="store_true")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    t = time.perf_counter()
    cpu0 = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
               for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    m = multiplicity_map(default_scene(h=0.0, p=0.0), "h2", np.linspace(0, 20, args.n), "p",
                         np.linspace(0, 60, args.n), workers=args.workers,
                         stability=not args.no_stability, progress=not args.quiet)
    dt = time.perf_counter() - t
    cpu = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
              for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)) - cpu0
    vals, freq = np.unique(m.counts, return_counts=True)
    print(f"{args.n} x {args.n} grid, {args.workers} worker(s), stability "
          f"{'on' if not args.no_stability else 'off'}: {dt:.1f} s "
          f"({args.n * args.n / dt:.0f} grid points/s); counts "
          + ", ".join(f"{v}: {f}" for v, f in zip(vals, freq)))
    print(f"{1e6 * dt / (args.n * args.n):.0f} us per grid point; gamma samples evaluated "
          f"{m.stats['gamma_samples']} of the full scan's {m.stats['gamma_samples_full_scan']} "
          f"({m.stats['gamma_samples'] / max(1, m.stats['gamma_samples_full_scan']):.1%})")
    print(f"CPU time of all processes {cpu:.1f} s -> {cpu / args.workers:.1f} s of wall time on "
          f"{args.workers} otherwise idle cores (the machine may be shared: load average "
          f"{os.getloadavg()[0]:.1f})")
    total = time.perf_counter() - START
    print(f"whole script (imports included): {total:.1f} s")
    ok = total <= 10.0
    print("target (200 x 200 in <= 10 s on 2 cores):", "met" if ok else "NOT met",
          "(this run: %d x %d, %d workers)" % (args.n, args.n, args.workers))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
