"""Measure speed against accuracy of every forward method on the benchmark set.

For each benchmark problem (the paper's cases, oblique fields, tilted and graded fibres, a general
tip load, a dipole field; each with a reference computed independently: THEORY §6 closed forms or
high-accuracy shooting) and each method — LGL spectral elements over elements × degree and the
midpoint rule over N with the fast Newton path, the damped Newton and IPOPT; the public solve() API;
a plain numpy Newton on the same collocation system (the floor); the shooting reference solver;
scipy's solve_bvp (the peer) over a range of tolerances — it measures in one run:

  error    max(|dx(1)|, |dy(1)|, |dtheta(1)|) against the reference (lengths in rod lengths l,
           angles in rad),
  time     median wall time of a warm re-solve at slightly perturbed parameters, started from the
           previous solution (build time excluded and reported separately as build_s).

It prints the table and the target check (tip error <= 1e-8 in <= 0.2 ms, >= 20x faster than
solve_bvp at equal accuracy, distance to the numpy floor). Timings depend on the machine and its
load: run it on an idle machine for publishable numbers.
"""
from __future__ import annotations

import argparse
import csv
import io as _io

from actuator_design.cli.common import EXIT_OK, InputError, check_out_dir, stdout_to_stderr
from actuator_design.cli.common import print_written, write_out

__all__ = ["HELP", "add_args", "run"]

HELP = "benchmark speed against accuracy of the forward solvers (table, JSON, Pareto figure)"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``bench``."""
    parser.add_argument("--quick", action="store_true",
                        help="a subset of resolutions and tolerances and 5 repeats (a smoke run, ~1 min)")
    parser.add_argument("--problems", metavar="NAMES",
                        help="comma-separated problem names (default: all; see --list)")
    parser.add_argument("--list", action="store_true", help="list the problems and exit")
    parser.add_argument("--repeats", type=int, metavar="R",
                        help="warm re-solves timed per row (>= 1; default 15, or 5 with --quick)")
    parser.add_argument("--workers", type=int, default=1, metavar="W",
                        help="problems run in parallel processes (default 1: undisturbed timings)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object {rows, targets, problems} on stdout")
    parser.add_argument("--out", metavar="DIR",
                        help="write bench.json, bench.csv and bench_pareto.png into DIR")
    s = parser.add_argument_group("study section (whole commands against a solve_bvp walk)")
    s.add_argument("--study", action="store_true",
                   help="time a solve sweep and a multiplicity map as whole commands beside scipy's "
                        "solve_bvp walking the same grid, instead of the per-solve table")
    s.add_argument("--points", type=int, default=8000, metavar="N",
                   help="sweep points (h x 4 field angles; default 8000)")
    s.add_argument("--map-n", type=int, default=200, metavar="N", help="map grid N x N (default 200)")


def _csv_text(rows) -> str:
    buf = _io.StringIO()
    keys = ["problem", "method", "label", "n", "error", "time_s", "time_min_s", "build_s", "peer",
            "converged", "note"]
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    return buf.getvalue()


def run(args: argparse.Namespace) -> int:
    """Run ``bench``."""
    from actuator_design.benchmarks.problems import PROBLEMS

    if args.list:
        for name, p in PROBLEMS.items():
            print(f"{name:17s} {p.description}  [reference: {p.reference_note}]")
        return EXIT_OK
    check_out_dir(args.out)
    if args.study:
        return _run_study_section(args)
    names = list(PROBLEMS)
    if args.problems:
        names = [n.strip() for n in args.problems.split(",") if n.strip()]
        bad = [n for n in names if n not in PROBLEMS]
        if bad or not names:
            raise InputError(f"--problems: unknown problem(s) {', '.join(bad) or '(none given)'}; "
                             f"choose from {', '.join(PROBLEMS)}")
    repeats = args.repeats if args.repeats is not None else (5 if args.quick else 15)
    if repeats < 1:
        raise InputError(f"--repeats: must be >= 1, got {repeats}")
    if args.workers < 1:
        raise InputError(f"--workers: must be >= 1, got {args.workers}")

    from actuator_design.benchmarks.runner import format_table, format_targets, run_benchmark, target_summary
    from actuator_design.io.save import dumps_json

    with stdout_to_stderr(args.json):
        rows = run_benchmark(names, quick=args.quick, repeats=repeats, workers=args.workers)
    targets = target_summary(rows)
    problems = {n: {"description": PROBLEMS[n].description, "reference": PROBLEMS[n].reference_note,
                    "reference_tip": list(PROBLEMS[n].reference_tip())} for n in names}
    payload = {"rows": rows, "targets": targets, "problems": problems,
               "protocol": {"repeats": repeats, "quick": bool(args.quick), "workers": args.workers,
                            "error": "max(|dx(1)|, |dy(1)|, |dtheta(1)|) against the reference",
                            "time_s": "median wall time of a warm re-solve at a perturbed parameter"}}
    written = None
    if args.out is not None:
        from actuator_design.viz.bench import pareto_figure
        from actuator_design.viz.style import png_bytes
        files = {"bench.json": dumps_json(payload, indent=1), "bench.csv": _csv_text(rows),
                 "bench_pareto.png": png_bytes(pareto_figure(rows), dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        print(format_table(rows))
        print()
        print(format_targets(targets))
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK


def _run_study_section(args: argparse.Namespace) -> int:
    """``bench --study``: :mod:`actuator_design.benchmarks.study_bench`."""
    import sys

    from actuator_design.benchmarks.study_bench import format_study_bench, run_study_bench
    from actuator_design.io.save import dumps_json

    if args.points < 8 or args.points > 1_000_000:
        raise InputError(f"--points: must be in [8, 1000000], got {args.points}")
    if args.map_n < 2 or args.map_n > 2000:
        raise InputError(f"--map-n: must be in [2, 2000], got {args.map_n}")
    repeats = args.repeats if args.repeats is not None else (1 if args.quick else 3)
    if repeats < 1:
        raise InputError(f"--repeats: must be >= 1, got {repeats}")
    res = run_study_bench(points=args.points, map_n=args.map_n, repeats=repeats,
                          workers=0 if args.workers == 1 else args.workers,
                          progress=lambda m: print(m, file=sys.stderr))
    written = None
    if args.out is not None:
        written = write_out(args.out, {"bench_study.json": dumps_json(res, indent=1)}, args.json)
    print(dumps_json(res) if args.json else format_study_bench(res))
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK
