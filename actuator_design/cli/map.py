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
angles in rad (the --phi-deg and --alpha-deg flags take degrees). --x-range/--y-range accept units
for parameters with a physical meaning ('10 deg,80 deg'; for a physical scene '2 mT,60 mT',
'0 mN,1 mN').

A physical scene (`type: physical`) also speaks its own units: lengths in the unit rod.length is
written in, fields as mu0 H in mT, loads in N, energies in J — the ranges in the text, the JSON's
`physical` keys beside the dimensionless ones, extra CSV columns (<param>_mT, <param>_N, ...) and
the figure's axes.

With CONFIG, its `study:` section (type: map; keys x_param, x_range, y_param, y_range, n [nx, ny],
n_gamma, workers, curves and the scene values h, phi_deg, p, alpha_deg) and then the flags apply.
"""
from __future__ import annotations

import argparse
import os
import sys
from actuator_design.cli.common import EXIT_OK, InputError, bad_input, check_out_dir, stdout_to_stderr
from actuator_design.config.studies.parameters import PARAM_NAMES, MapStudy
from actuator_design.cli.equilibria import add_output_args, add_scene_args, build_scene
from actuator_design.cli.common import print_written, write_out

__all__ = ["HELP", "add_args", "run", "MapStudy"]

HELP = "number of equilibria over a 2-D parameter grid (parallel), with critical curves"


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
    c.add_argument("--x-range", metavar="A,B",
                   help="x range (default 0,20); units allowed where the parameter has them, e.g. '10 mT,60 mT'")
    c.add_argument("--y-param", choices=PARAM_NAMES, help="y parameter (default p)")
    c.add_argument("--y-range", metavar="A,B",
                   help="y range (default 0,60); units allowed where the parameter has them, e.g. '0 mN,2 mN'")
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
    from actuator_design.physics.parameters import parameter
    from actuator_design.io.user_units import pair_from_text, user_units

    units = user_units(scene, raw)
    with bad_input():
        xr = pair_from_text(args.x_range, parameter(xp), units, "--x-range") if args.x_range else tuple(d.x_range)
        yr = pair_from_text(args.y_range, parameter(yp), units, "--y-range") if args.y_range else tuple(d.y_range)
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

    from actuator_design.physics.parameters import set_value as set_param
    from actuator_design.continuation.critical import critical_curves
    from actuator_design.analysis.multiplicity import multiplicity_map
    from actuator_design.io.save import dumps_json

    with bad_input():
        from actuator_design.config.checks import check_scene_groups

        for v in (xr[0], xr[1]):
            for w in (yr[0], yr[1]):
                # the corners of the map within the groups' valid ranges (p = 1e9 overflowed)
                check_scene_groups(set_param(set_param(scene, xp, v), yp, w),
                                   prefix=f"map corner ({xp} = {v:g}, {yp} = {w:g}): ")
        from actuator_design.analysis.equilibria import gamma_bound
        gamma_bound(scene)  # uniform field required
    xs, ys = np.linspace(*xr, nx), np.linspace(*yr, ny)
    with stdout_to_stderr(args.json), bad_input():
        m = multiplicity_map(scene, xp, xs, yp, ys, n_gamma=n_gamma, workers=workers,
                             progress=False if args.quiet else None)
        curves = []
        if curves_on:
            try:
                curves = critical_curves(set_param(scene, xp, xr[0]), yp, xp, yr, xr, options=options,
                                         seeds=fold_seeds(m))
            except RuntimeError as err:
                print(f"actuator-design: warning: critical curves not computed: {err}", file=sys.stderr)
    payload = {**m.to_dict(), "critical_curves": [c.to_dict() for c in curves]}
    add_units(payload, m, curves, scene, units)
    written = None
    if args.out is not None:
        from actuator_design.viz.landscape import plot_landscape_map
        from actuator_design.viz.style import png_bytes
        from actuator_design.viz.units import parameter_axis
        with stdout_to_stderr(args.json):
            axes = plot_landscape_map(m, curves)
            for ax in axes:  # fields in mT, loads in N, ...
                parameter_axis(ax, parameter(xp), units, xp, "x", data_max=xr[1])
                parameter_axis(ax, parameter(yp), units, yp, "y", data_max=yr[1])
            files = {"map.json": dumps_json({**payload, "config": raw}, indent=1) + "\n",
                     "map.csv": _csv(m, units),
                     "map.png": png_bytes(axes[0], dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        _in = _in_units(units)
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
            print(f"  fold curve of {yp}: {yp} = {c.lam[0]:.8g}{_in(yp, c.lam[0])} at {xp} = "
                  f"{c.mu[0]:.6g}{_in(xp, c.mu[0])} ... {c.lam[-1]:.8g}{_in(yp, c.lam[-1])} at {xp} = "
                  f"{c.mu[-1]:.6g}{_in(xp, c.mu[-1])}")
        if units is not None:
            from actuator_design.io.unit_results import physical_header, units_line
            print(f"  user units: {units_line(units)}; {xp} in [{xr[0]:g}, {xr[1]:g}]{_in(xp, xr[0], xr[1])}, "
                  f"{yp} in [{yr[0]:g}, {yr[1]:g}]{_in(yp, yr[0], yr[1])}")
            for note in physical_header(units, [xp, yp])["notes"]:
                print(f"  note: {note}")
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK


def fold_seeds(m, at_most: int = 4) -> list:
    """Values of the x parameter where the map's count of equilibria changes along y (a fold of y
    lies in the window there), at most ``at_most`` evenly chosen: seeds for the fold curves."""
    import numpy as np

    cols = [j for j in range(len(m.x))
            if len({int(c) for c in m.counts[:, j] if c >= 0}) > 1]
    if not cols:
        return []
    pick = np.unique(np.linspace(0, len(cols) - 1, min(at_most, len(cols))).round().astype(int))
    return [float(m.x[cols[i]]) for i in pick]


def _in_units(units):
    """``_in(name, *values)``: `` (25 mT)`` / `` (10 to 60 mT)`` of lens-parameter values in their
    unit on a physical scene, else ``""``."""
    def _in(name, *values):
        if units is None:
            return ""
        from actuator_design.io.display import number
        from actuator_design.io.unit_results import parameter_conversion, values_in_unit
        conv = values_in_unit(name, values, units)
        if conv is None:
            return ""
        unit = parameter_conversion(name, units)[0]
        return " (" + " to ".join(number(v, ".6g") for v in conv[1]) + f" {unit})"
    return _in


def _csv(m, units=None) -> str:
    """``map.csv``: the map's long-format CSV; a physical scene adds each parameter in its unit."""
    text = m.csv_text()
    if units is None:
        return text
    from actuator_design.io.unit_results import column_note, values_in_unit

    conv = [(name, values_in_unit(name, vals, units)) for name, vals in ((m.x_param, m.x), (m.y_param, m.y))]
    conv = [(name, c) for name, c in conv if c is not None]
    if not conv:
        return text
    comment, header, *rows = text.splitlines()
    comment += "; " + "; ".join(column_note(name, units) for name, _c in conv)
    header += "".join(f",{name}_{c[0]}" for name, c in conv)
    nx = len(m.x)
    out = [comment, header]
    for k, row in enumerate(rows):  # rows run over x fastest, then y
        i, j = divmod(k, nx)
        vals = [c[1][j] if name == m.x_param else c[1][i] for name, c in conv]
        out.append(row + "".join("," + repr(float(v)) for v in vals))
    return "\n".join(out) + "\n"


def add_units(payload: dict, m, curves, scene, units) -> None:
    """A physical scene's units in ``map``'s JSON, in place: the top-level ``physical`` with
    ``x_<unit>``/``y_<unit>`` (the grid in each parameter's unit, where it has one) and each
    critical curve's points in those units."""
    if units is None:
        return
    from actuator_design.io.unit_results import command_physical, values_in_unit

    phys = command_physical(scene, units, [m.x_param, m.y_param])
    for axis, name, vals in (("x", m.x_param, m.x), ("y", m.y_param, m.y)):
        conv = values_in_unit(name, vals, units)
        if conv is not None:
            phys[f"{axis}_{conv[0]}"] = conv[1]
    payload["physical"] = phys
    for cd in payload.get("critical_curves", []):
        for pt in cd["points"]:
            for name in (cd["param"], cd["second"]):
                conv = values_in_unit(name, [pt[name]], units)
                if conv is not None:
                    pt[f"{name}_{conv[0]}"] = conv[1][0]
