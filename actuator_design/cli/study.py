"""Run a study: a scene swept over values (cartesian or zipped grids, with units), the named
analyses at every point, in parallel, resumable, into one output folder.

CONFIG has the usual 'scene' (and 'solver') plus
    study:
      type: sweep
      grid: cartesian          # or zip
      sweep:                   # dotted paths into the scene (solver.<key> for solver settings)
        field.magnitude: {from: 0 kA/m, to: 30 kA/m, n: 61}
        field.angle: [0 deg, 45 deg, 90 deg]
      analyses: [solve]        # registered analyses, {type: name, ...} to pass settings
      outputs: [solve.tip.*]   # result columns kept (glob patterns; default all)

The folder (--out, default study_<config name>) gets manifest.json (resolved config, versions,
solver settings, times, status of every point), results.csv (tidy: one row per point; also
results.parquet when pyarrow is installed), figures/*.png and journal.jsonl (one JSON line per
finished point; --resume skips the points it holds). Every file is written to a temporary name
and renamed. With --scheduler tcp://HOST:PORT the points run on a Dask distributed cluster.

Safety: a grid of more than 1 000 000 points is refused before any work (--max-points N or
study.max_points raises the limit); one run at a time writes into a folder (a second one exits 2
naming the holder; a lock left by a dead run is taken over with a warning); worker processes die
with the study process; journal records that do not match the grid are computed again.

Units: sweep values carry their units ('5 kA/m', '30 deg'; table columns say which); results of a
dimensionless scene are in rod lengths l, energies in B0/l, forces in B0/l^2, angles in rad.

Exit codes: 0 every point computed (some may have failed: see the manifest), 2 bad input,
130 interrupted (resume with --resume).
"""
from __future__ import annotations

import argparse
import os
import sys

from .common import EXIT_OK, PROG, InputError, bad_input, check_out_dir, stdout_to_stderr

__all__ = ["HELP", "add_args", "run"]

HELP = "run a sweep study (parallel, resumable; --scheduler for a Dask cluster)"

_SCHEMES = ("tcp://", "tls://", "inproc://", "ucx://", "ws://", "wss://")


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: must be an integer >= 1")
    return n


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``study``."""
    parser.add_argument("config", metavar="CONFIG.yaml",
                        help="scene and 'study: {type: sweep, sweep: ..., analyses: [...]}' (YAML)")
    parser.add_argument("--out", metavar="DIR",
                        help="output folder (default: study_<config file name> in the current "
                             "directory)")
    parser.add_argument("--workers", type=_positive_int, metavar="N",
                        help=f"local worker processes (default: all cores, here {os.cpu_count()})")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted study in DIR without recomputing its "
                             "finished points")
    parser.add_argument("--max-points", type=_positive_int, metavar="N",
                        help="largest grid run (default: study.max_points, else 1000000); a larger "
                             "one is refused before any work")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on a Dask distributed cluster, e.g. tcp://127.0.0.1:8786 "
                             "(needs the 'distributed' package)")
    parser.add_argument("--no-progress", dest="progress", action="store_false",
                        help="no progress bar on stderr")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (the study summary) on stdout")


def _warning(message: str) -> None:
    print(f"{PROG}: warning: {message}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    """Run ``study``."""
    from pathlib import Path

    check_out_dir(args.out)
    if not Path(args.config).is_file():
        raise InputError(f"config file not found: {args.config}")
    if args.scheduler is not None and not args.scheduler.startswith(_SCHEMES):
        raise InputError(f"--scheduler: expected an address such as tcp://127.0.0.1:8786, got "
                         f"{args.scheduler!r}")
    if args.scheduler is not None and args.workers is not None:
        raise InputError("--workers: the Dask cluster decides its workers; give either "
                         "--workers or --scheduler")
    out = args.out or f"study_{Path(args.config).stem}"
    from ..io import dumps_json
    from ..study.runner import StudyError, StudyInterrupted, plan_study, run_study

    with bad_input():
        plan = plan_study(args.config, out, resume=args.resume, max_points=args.max_points)
    try:
        with stdout_to_stderr(args.json):
            report = run_study(plan, workers=args.workers, scheduler=args.scheduler,
                               progress=args.progress, notify=_warning)
    except StudyInterrupted as exc:
        print(f"{PROG}: interrupted: {exc}", flush=True, file=sys.stderr)
        return 130
    except StudyError as exc:
        raise InputError(str(exc)) from exc
    if args.json:
        print(dumps_json(report.to_dict()))
    else:
        print(report.summary())
    return EXIT_OK
