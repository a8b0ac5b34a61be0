"""Forward benchmark for one scene: build time, warm re-solve time and tip error per method and N.

Usage::

    .venv/bin/python problems/bench_forward.py [--scene transverse|axial|elastica] [--repeats 15]

For the chosen scene (the paper's cases, THEORY §6) it prints, for every transcription and
resolution and for scipy's ``solve_bvp`` at a range of tolerances (the peer), one row with

* ``build_s``  — one-off construction (CasADi build for the project's methods; 0 for solve_bvp),
* ``error``    — max(|Δx(1)|, |Δy(1)|, |Δθ(1)|) against the independent reference (elliptic closed
  form for the transverse case, the DOP853 shooting solver at rtol 1e-12 otherwise),
* ``time_ms``  — median wall time of one warm re-solve at a slightly perturbed parameter, started
  from the previous solution (the build excluded).

This is the script version of ``actuator-design bench`` for one scene; the full benchmark set and
the Pareto figure live in :mod:`actuator_design.benchmarks`.
"""
from __future__ import annotations

import argparse
import sys

from actuator_design.benchmarks.problems import get_problem, problem_names
from actuator_design.benchmarks.runner import default_methods, format_table, run_problem


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="paper_transverse", choices=problem_names(),
                    help="benchmark problem (default paper_transverse)")
    ap.add_argument("--repeats", type=int, default=15, help="warm re-solves timed per row")
    ap.add_argument("--quick", action="store_true", help="fewer resolutions")
    args = ap.parse_args(argv)
    prob = get_problem(args.scene)
    rows = run_problem(prob, default_methods(quick=args.quick), repeats=args.repeats, progress=True)
    print(f"# {prob.name}: {prob.description}\n# reference: {prob.reference_note}")
    print(format_table(rows, with_build=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
