"""Fit scene parameters to measured equilibria and report them with confidence intervals.

CONFIG gives the scene (what is known) and a 'study:' section of 'type: fit' naming the
parameters to fit (chi_bar, youngs_modulus or bending_stiffness, remanence of a hard-magnetic rod,
h, clamp_angle, field_scale, field_offset, field_angle_offset) with initial values and bounds in
units. DATA is a CSV file whose header names the columns with their units, e.g. 'field [kA/m],
tip_angle [deg]' or 'field [kA/m], load [mN], tip_deflection [mm]' or 'field [mT], field_angle
[deg], tip_x [mm], tip_y [mm]'. Each row's equilibrium is solved on the branch the measurement lies
on; the least-squares fit uses exact sensitivities (implicit function theorem); intervals come from
s^2 (J^T J)^-1. Parameters the data cannot separate (e.g. chi_bar and E, or remanence and E, from
field data alone) are reported, one is held and the identifiable combination is fitted.

Units: every value carries its unit (the CSV header, '2 MPa' in the config); results are in SI
(rad, m, Pa, A/m). In a dimensionless scene lengths are in rod lengths l and loads in B0/l^2.
A physical scene also reports the user's units: lengths in the unit rod.length is written in,
fields as mu0 H in mT, forces in N (JSON 'physical' with every row, rms and sigma in them; a
remanence, field offset or critical field also in mT; fit_points.csv columns and figure axes in
them where the data file's unit differs).

Rows sharing a condition (same field, field angle and loads) share one forward solve. Progress
goes to stderr (when it is a terminal, or with --progress). Ctrl-C (SIGINT) or SIGTERM stops the
fit after the forward solve in progress (before the fit, while the inputs are read and the solver
is built, or while the results are written, at once; a partly written --out set is removed).

Goodness of fit: with study.uncertainty given for every measured column, the fit fails (status
poor_fit) when its chi-square exceeds the upper study.min_p_value quantile (default 0.001) of the
chi-square distribution with m - k degrees of freedom. A fitted parameter that ends on one of its
bounds fails it too (status at_bound, naming the parameter and the bound). Data magnitudes that
are implausible for the scene (e.g. 'field [kA/mm]' for kA/m) are warned about.

Limits: the data file must be a regular file (not a FIFO, device or directory) of at most 16 MiB
and 100000 rows, with at most 5000 distinct conditions.

Exit codes: 0 fitted, 2 bad input (one line naming the field, column or row), 3 the fit or an
equilibrium did not converge, the data do not determine a fitted parameter, the fit did not move
from its start, a fitted parameter is at a bound or the model does not explain the data (the
result is still printed / written; its status and message say which), 130 interrupted (SIGINT or
SIGTERM; nothing printed on stdout or written).
"""
from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, PROG, bad_input,
                                        check_out_dir, stdout_to_stderr)

#: Exit code of a fit stopped by SIGINT or SIGTERM (the shell's 128 + SIGINT, as ``study``).
EXIT_INTERRUPTED = 130

__all__ = ["HELP", "add_args", "run"]

HELP = "calibrate scene parameters against measured data (CSV with units), with intervals"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``fit``."""
    parser.add_argument("config", metavar="CONFIG.yaml",
                        help="scene and 'study: {type: fit, parameters: ...}' (YAML)")
    parser.add_argument("--data", required=True, metavar="DATA.csv",
                        help="measurements: CSV with 'name [unit]' column headers")
    parser.add_argument("--json", action="store_true",
                        help="print exactly one JSON object (the fit result) on stdout")
    parser.add_argument("--out", metavar="DIR",
                        help="write fit.json, fit_points.csv, fit_data_vs_model.png and "
                             "fit_residuals.png into DIR (created if needed)")
    parser.add_argument("--progress", action="store_true",
                        help="show a progress bar on stderr (default: only when stderr is a "
                             "terminal; never on stdout)")


@contextlib.contextmanager
def _sigterm_as_sigint():
    """Within the block SIGTERM raises ``KeyboardInterrupt`` as SIGINT does (exit 130, not a kill
    that leaves no message and perhaps a staging folder); the fit itself installs its own
    handlers (:mod:`actuator_design.calibration.interrupt`). Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def run(args: argparse.Namespace) -> int:
    """Run ``fit``: load and check the inputs, fit, print and optionally write the result."""
    with _sigterm_as_sigint():
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    """:func:`run` with SIGTERM raising ``KeyboardInterrupt`` outside the fit."""
    check_out_dir(args.out)
    from pathlib import Path

    if not Path(args.config).is_file():
        raise InputError(f"config file not found: {args.config}")
    from actuator_design.calibration import fit, prepare_fit
    from actuator_design.calibration.interrupt import FitInterrupted
    from actuator_design.io.save import dumps_json

    with bad_input():
        problem = prepare_fit(args.config, args.data)
    try:
        with stdout_to_stderr(args.json):
            result = fit(problem, progress=bool(args.progress or sys.stderr.isatty()))
    except FitInterrupted as exc:
        print(f"{PROG}: interrupted: {exc}", file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
    written = None
    if args.out is not None:  # the files first, all or nothing; then stdout
        from actuator_design.calibration.outputs import fit_files
        from actuator_design.cli.common import write_out
        written = write_out(args.out, fit_files(result, config=problem.config.raw), args.json, "results ")
    from actuator_design.calibration.report import fit_units, result_dict, summary_text
    units = fit_units(problem.config.raw)  # a physical scene: also the user's units
    if args.json:
        print(dumps_json(result_dict(result, units)))
        for w in result.warnings:
            print(f"{PROG}: warning: {w}", file=sys.stderr)
    else:
        print(summary_text(result, units))
    if written is not None:
        from actuator_design.cli.common import print_written
        print_written(written, args.json)
    return EXIT_OK if result.success else EXIT_NOT_CONVERGED
