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
results.parquet when pyarrow is installed), results.nc (the same on the grid: one dimension per
swept key, a netCDF file for xarray.open_dataset), figures/*.png and journal.jsonl (one JSON line
per finished point; --resume skips the points it holds). Every file is written to a temporary name
and renamed. With --scheduler tcp://HOST:PORT the points run on a Dask distributed cluster.

Safety: every swept value and grid point is checked like a scene from a file before the folder is
created (exit 2 naming study.sweep.<key>, the point and the field's range; a grid of more than
20 000 points at its corners and through each value); a grid of more than 1 000 000 points is
refused before any work (--max-points N or study.max_points raises the limit); one run at a time writes into a folder (a second one exits 2
naming the holder; a lock left by a dead run is taken over with a warning); worker processes die
with the study process; journal records that do not match the grid are computed again.

Units: sweep values carry their units ('5 kA/m', '30 deg'; table columns say which); a physical
unit on a dimensionless scene is refused (physical units need a physical scene); results of a
dimensionless scene are in rod lengths l, energies in B0/l, forces in B0/l^2, angles in rad. A
physical scene's table also has columns in the user's units (the summary and --json 'physical'
list them): a swept field as mu0 H in mT ('field.magnitude [mT]'), a swept force in N, lengths in
the unit rod.length is written in ('solve.tip.x_mm', 'solve.physical.tip_x_mm'), fields in mT
('solve.physical.field_mT', 'solve.h_mT'); results.nc has them with their units, and the
figures draw them.

Files: the folder's entries must be the tool's own: a study.lock, journal.jsonl, manifest.json,
results.csv, results.nc or figures that is a symbolic link or of the wrong kind (a directory
where a file goes, a FIFO, ...) is refused (exit 2, naming it); nothing outside the folder is
ever written. Journal records carry a digest of their inputs and a checksum: an edited, damaged
or older record is computed again (with a warning giving the count).

Exit codes: 0 every point computed (some may have failed: see the manifest), 2 bad input (also a
write the file system refused before anything was journaled), 3 a write refused (read-only or full
file system) after points were journaled: free space and resume with --resume, 130 interrupted
(resume with --resume).
"""
from __future__ import annotations

import argparse
import os
import sys

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, PROG, InputError, bad_input,
                                        check_out_dir, error_line, stdout_to_stderr)

__all__ = ["HELP", "add_args", "run"]

HELP = "run a sweep study (parallel, resumable; --scheduler for a Dask cluster)"


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
                             "(needs the 'distributed' package). Bounded waits: 10 s to connect "
                             "(env ACTUATOR_DESIGN_DASK_TIMEOUT), 60 s for a worker to join, at "
                             "the start or after every worker left "
                             "(ACTUATOR_DESIGN_DASK_WORKER_TIMEOUT); then one line and exit 2, "
                             "or 3 when the folder holds a run that --resume continues")
    parser.add_argument("--no-progress", dest="progress", action="store_false",
                        help="no progress bar on stderr")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (the study summary) on stdout")


def _warning(message: str) -> None:
    print(f"{PROG}: warning: {message}", file=sys.stderr, flush=True)


def _cluster_failure(exc, plan) -> int:
    """Exit 3 when the study folder holds a run that --resume continues (the run had started, or
    it resumes a journal), else bad input (2)."""
    from actuator_design.study.journal import JOURNAL_NAME

    if not (exc.resumable or (plan.resume and (plan.out / JOURNAL_NAME).is_file())):
        raise InputError(str(exc)) from None
    text = str(exc) if exc.resumable else (f"{exc}; {plan.out} keeps the journaled points: run "
                                           "again with --resume once the cluster answers")
    print(error_line(text), flush=True, file=sys.stderr)
    return EXIT_NOT_CONVERGED  # 3: a partial run that --resume continues


def run(args: argparse.Namespace) -> int:
    """Run ``study``."""
    from pathlib import Path

    check_out_dir(args.out)
    if not Path(args.config).is_file():
        raise InputError(f"config file not found: {args.config}")
    if args.scheduler is not None:
        from actuator_design.study.dask_cluster import (ClusterError, check_address, quiet_distributed_logs,
                                          timeouts)
        try:
            check_address(args.scheduler)
            timeouts()
        except ClusterError as exc:
            raise InputError(str(exc)) from None
        try:
            quiet_distributed_logs()
        except ImportError:
            pass  # run_study names the missing package
    if args.scheduler is not None and args.workers is not None:
        raise InputError("--workers: the Dask cluster decides its workers; give either "
                         "--workers or --scheduler")
    out = args.out or f"study_{Path(args.config).stem}"
    from actuator_design.io.save import dumps_json
    from actuator_design.io.safe_files import OutputFolderError
    from actuator_design.study.dask_cluster import ClusterError
    from actuator_design.study.runner import (StudyError, StudyInterrupted, StudyStorageError, plan_study,
                                run_study)

    from actuator_design.io.unit_columns import study_config

    with bad_input():
        plan = plan_study(args.config, out, resume=args.resume, max_points=args.max_points)
    try:
        with stdout_to_stderr(args.json), study_config(plan.raw):  # tables in the user's units too
            report = run_study(plan, workers=args.workers, scheduler=args.scheduler,
                               progress=args.progress, notify=_warning)
    except StudyInterrupted as exc:
        print(f"{PROG}: interrupted: {exc}", flush=True, file=sys.stderr)
        return 130
    except StudyStorageError as exc:  # read-only or full file system
        if not exc.resumable:
            raise InputError(str(exc)) from exc
        print(error_line(exc), flush=True, file=sys.stderr)
        return EXIT_NOT_CONVERGED  # 3: a partial run that --resume continues
    except ClusterError as exc:  # Dask: unreachable, no workers, workers or scheduler lost
        return _cluster_failure(exc, plan)
    except (StudyError, OutputFolderError) as exc:
        raise InputError(str(exc)) from exc
    physical = _physical(plan, report)
    if args.json:
        data = report.to_dict()
        if physical is not None:
            data["physical"] = physical
        print(dumps_json(data))
    else:
        print(report.summary())
        if physical is not None:
            cols = ", ".join(physical["columns"])  # every name says its unit
            print(f"  user units  : lengths in {physical['length_unit']} (rod.length), fields as mu0 H in "
                  f"mT, forces in N; columns {cols or '(none to add)'}")
    return EXIT_OK


def _physical(plan, report):
    """A physical study's units: ``length_unit`` and ``columns`` (column of results.csv in the
    user's units → its unit), read from the header of the table written; None otherwise."""
    import csv

    from actuator_design.io.unit_columns import axis_unit_columns, derived_name, table_units

    units = table_units(plan.raw, plan.axes)
    name = (report.files or {}).get("csv")
    if units is None or not name:
        return None
    try:
        with open(report.out / name, newline="", encoding="utf-8") as fh:
            header = next(csv.reader(fh), [])
    except OSError:
        return None
    table = dict.fromkeys(header)
    columns = {c: u for a in plan.axes for c, u, _f in axis_unit_columns(a, table)}
    for c in header:
        d = derived_name(c, units)
        if d is not None and d[0] in table:
            columns[d[0]] = d[1]
    return {"length_unit": units.length_unit,
            "columns": {c: u + (" (mu0 H)" if u == "mT" else "") for c, u in columns.items()}}
