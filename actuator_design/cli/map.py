"""Map the number of equilibria (and of stable ones) over a grid of two parameters.

Every grid point's equilibria are counted by the vectorised shooting scan (sign changes of the
free-end residual over the a-priori window of theta'(0); Morse indices by Sturm's count of the
Jacobi field), rows in parallel over --workers processes with a progress bar on stderr (off when
stderr is not a terminal or with --quiet). The fold curves of the y parameter are continued in the
x parameter and drawn over the map (skip with --no-curves). map.png shows the number of equilibria
beside the number of stable ones, with bistable regions (two or more stable states) hatched; a
grid point where the scan cannot be trusted (large h) is counted -1 (unknown) and drawn grey. Defaults: the paper's phase diagram,
phi = 0, x = h2 in [0, 20], y = p in [0, 60].
A hard-magnetic rod (--h-r, --magnetization-deg; THEORY §9) is counted with its remanent torque;
h_r and magnetization are grid parameters like the others (e.g. --x-param h_r --y-param phi).

Units: dimensionless (THEORY §5): lengths in rod lengths l, energies in B0/l, loads in B0/l^2,
angles in rad (the --phi-deg and --alpha-deg flags take degrees).

With CONFIG, its `study:` section (type: map; keys x_param, x_range, y_param, y_range, n [nx, ny],
n_gamma, workers, curves and the scene values h, phi_deg, p, alpha_deg) and then the flags apply.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Literal, Optional, Tuple

from pydantic import Field

from .common import EXIT_OK, InputError, bad_input, check_out_dir, stdout_to_stderr
from .continue_ import PARAM_NAMES, ParamName
from .equilibria import StudyBase, add_output_args, add_scene_args, build_scene, pair
from .output import print_written, write_out

__all__ = ["HELP", "add_args", "run", "MapStudy"]

HELP = "number of equilibria over a 2-D parameter grid (parallel), with critical curves"


class MapStudy(StudyBase):
    type: Literal["map"]
    x_param: ParamName = "h2"
    x_range: Tuple[float, float] = (0.0, 20.0)
    y_param: ParamName = "p"
    y_range: Tuple[float, float] = (0.0, 60.0)
    n: Tuple[int, int] = (50, 50)
    n_gamma: int = Field(161, ge=11, le=100001)
    workers: Optional[int] = Field(None, ge=1, le=1024)
    curves: bool = True


def _grid(text: str):
    parts = text.split(",")
    try:
        vals = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: expected N or NX,NY (integers)")
    if len(vals) not in (1, 2) or min(vals) < 2 or max(vals) > 5000:
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: expected N or NX,NY with 2 <= N <= 5000")
    return (vals[0], vals[-1])


def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``map``."""
    add_scene_args(parser)
    c = parser.add_argument_group("grid")
    c.add_argument("--x-param", choices=PARAM_NAMES, help="x parameter (default h2)")
    c.add_argument("--x-range", type=pair, metavar="A,B", help="x range (default 0,20)")
    c.add_argument("--y-param", choices=PARAM_NAMES, help="y parameter (default p)")
    c.add_argument("--y-range", type=pair, metavar="A,B", help="y range (default 0,60)")
    c.add_argument("--n", type=_grid, metavar="N[,NY]", help="grid points per axis (default 50)")
    c.add_argument("--n-gamma", type=int, metavar="N", help="gamma samples per grid point (default 161)")
    c.add_argument("--workers", type=int, metavar="N", help=f"processes (default: all {os.cpu_count()} cores)")
    c.add_argument("--no-curves", dest="curves", action="store_false", default=None,
                   help="do not compute and draw the critical (fold) curves")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    add_output_args(parser, "map.json, map.csv and map.png")


def run(args: argparse.Namespace) -> int:
    """Run ``map``."""
    import numpy as np

    check_out_dir(args.out)
    if args.config is None and args.phi_deg is None:
        args.phi_deg = 0.0  # the paper's phase diagram is for an axial field
    scene, options, raw, study = build_scene(args, MapStudy, "map")
    d = study or MapStudy(type="map")
    xp, yp = args.x_param or d.x_param, args.y_param or d.y_param
    xr, yr = args.x_range or tuple(d.x_range), args.y_range or tuple(d.y_range)
    nx, ny = args.n or tuple(d.n)
    n_gamma = args.n_gamma if args.n_gamma is not None else d.n_gamma
    workers = args.workers if args.workers is not None else d.workers
    curves_on = d.curves if args.curves is None else args.curves
    if xp == yp:
        raise InputError(f"--x-param and --y-param must differ, got {xp} twice")
    if not 11 <= n_gamma <= 100001:
        raise InputError(f"--n-gamma: must lie in [11, 100001], got {n_gamma}")
    if workers is not None and workers < 1:
        raise InputError(f"--workers: must be >= 1, got {workers}")
    for name, rng in ((xp, xr), (yp, yr)):
        if not rng[0] < rng[1]:
            raise InputError(f"range of {name}: must be increasing, got {rng}")

    from ..parameters import set_value as set_param
    from ..analysis.critical import critical_curves
    from ..analysis.multiplicity import multiplicity_map
    from ..io import dumps_json

    with bad_input():
        from ..config.checks import check_scene_groups

        for v in (xr[0], xr[1]):
            for w in (yr[0], yr[1]):
                # the corners of the map within the groups' valid ranges (p = 1e9 overflowed)
                check_scene_groups(set_param(set_param(scene, xp, v), yp, w),
                                   prefix=f"map corner ({xp} = {v:g}, {yp} = {w:g}): ")
        from ..analysis.equilibria import gamma_bound
        gamma_bound(scene)  # uniform field required
    xs, ys = np.linspace(*xr, nx), np.linspace(*yr, ny)
    with stdout_to_stderr(args.json), bad_input():
        m = multiplicity_map(scene, xp, xs, yp, ys, n_gamma=n_gamma, workers=workers,
                             progress=False if args.quiet else None)
        curves = []
        if curves_on:
            try:
                curves = critical_curves(set_param(scene, xp, xr[0]), yp, xp, yr, xr, options=options)
            except RuntimeError as err:
                print(f"actuator-design: warning: critical curves not computed: {err}", file=sys.stderr)
    payload = {**m.to_dict(), "critical_curves": [c.to_dict() for c in curves]}
    written = None
    if args.out is not None:
        from ..viz.landscape import plot_landscape_map
        from ..viz.style import png_bytes
        with stdout_to_stderr(args.json):
            files = {"map.json": dumps_json({**payload, "config": raw}, indent=1) + "\n",
                     "map.csv": m.csv_text(),
                     "map.png": png_bytes(plot_landscape_map(m, curves)[0], dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        vals, freq = np.unique(m.counts, return_counts=True)
        print(f"{ny} x {nx} grid of ({xp}, {yp}) in {m.stats['time_s']:.2f} s: "
              + ", ".join(f"{f} points with {v} equilibria" for v, f in zip(vals, freq) if v >= 0))
        svals, sfreq = np.unique(m.stable, return_counts=True)
        print("  stable: " + ", ".join(f"{f} points with {v}" for v, f in zip(svals, sfreq) if v >= 0)
              + f"; bistable (>= 2 stable) at {int(m.bistable.sum())} points")
        if not np.all(m.complete):
            print(f"  unknown: {int(np.sum(~m.complete))} points where the shooting scan cannot be "
                  f"trusted (counted -1)")
        for c in curves:
            print(f"  fold curve of {yp}: {yp} = {c.lam[0]:.8g} at {xp} = {c.mu[0]:.6g} ... "
                  f"{c.lam[-1]:.8g} at {xp} = {c.mu[-1]:.6g}")
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK
