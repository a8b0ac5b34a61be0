"""Compute one equilibrium of a cantilever and report its shape, tip, energy and stability.

Without CONFIG the scene is THEORY §5's dimensionless cantilever
    E[theta] = 1/2 int theta'^2 ds - h^2 int cos^2(theta + alpha - phi) ds - p int sin(theta) ds,
clamped at the origin along x, in a uniform field at angle phi with a vertical tip load p, with
defaults h = 1.0, phi = 45 deg, p = 0, alpha = 0 deg. With CONFIG the flags override its values.

Units: lengths in rod lengths l, energies in B0/l, forces in B0/l^2, moments in B0/l; angles are
given in degrees on the command line and reported in radians.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys

from .common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                     finite_float, load_config, nonnegative_float,
                     stdout_to_stderr)
from .output import print_written, write_out

__all__ = ["HELP", "add_args", "run", "build_inputs"]

HELP = "compute one equilibrium (default: THEORY §5's dimensionless cantilever)"

#: Defaults of the scene flags when no CONFIG is given (the API's ``default_scene`` inputs).
DEFAULTS = {"h": 1.0, "phi_deg": 45.0, "p": 0.0, "alpha_deg": 0.0}

#: Solver flags and the SolverOptions field each overrides.
_SOLVER_FLAGS = {"transcription": "--transcription", "elements": "--elements",
                 "degree": "--degree", "method": "--method", "tol": "--tol", "accuracy": "--accuracy",
                 "start": "--start", "residual_tol": "--residual-tol",
                 "keep_self_intersecting": "--keep-self-intersecting", "adapt": "--no-adapt"}


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``solve``."""
    from ..options import SolverOptions
    d = SolverOptions()
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene and solver configuration (YAML); omit for the default scene")
    g = parser.add_argument_group("scene (dimensionless, THEORY §5; override CONFIG)")
    g.add_argument("--h", type=nonnegative_float, metavar="H",
                   help="field group h >= 0, h^2 = mu0 chi H^2 A l^2 / (2 B) (dimensionless; "
                        f"default without CONFIG {DEFAULTS['h']:g})")
    g.add_argument("--phi-deg", type=finite_float, metavar="DEG",
                   help="angle of the uniform field to the undeformed rod, degrees "
                        f"(default without CONFIG {DEFAULTS['phi_deg']:g})")
    g.add_argument("--p", type=finite_float, metavar="P",
                   help="vertical dead tip load p = P l^2 / B (dimensionless, units of B0/l^2; "
                        f"default without CONFIG {DEFAULTS['p']:g})")
    g.add_argument("--alpha-deg", type=finite_float, metavar="DEG",
                   help="constant fibre angle alpha, degrees (default without "
                        f"CONFIG {DEFAULTS['alpha_deg']:g})")
    from .scene_args import add_hard_magnetic_args
    add_hard_magnetic_args(g)
    s = parser.add_argument_group("solver (override CONFIG)")
    s.add_argument("--transcription", choices=("lgl", "midpoint"),
                   help=f"lgl: spectral elements; midpoint: second-order midpoint rule (default {d.transcription})")
    s.add_argument("--elements", type=int, metavar="N", help=f"number of elements (>= 1; default {d.elements})")
    s.add_argument("--degree", type=int, metavar="D",
                   help=f"polynomial degree per lgl element (>= 2; default {d.degree})")
    s.add_argument("--method", choices=("ipopt", "newton", "fast"),
                   help=f"ipopt: interior point; newton: damped Newton with IPOPT fallback; fast: "
                        f"low-overhead Newton (falls back to newton, then ipopt) (default {d.method})")
    s.add_argument("--accuracy", type=finite_float, metavar="TOL",
                   help="target tip accuracy in rod lengths, in (0, 1): picks the cheapest resolution "
                        "that meets it and reports the estimated error (overrides --elements/--degree)")
    s.add_argument("--tol", type=finite_float, metavar="TOL",
                   help=f"tolerance on the stationarity residual, dimensionless, in (0, 1) (default {d.tol:g})")
    s.add_argument("--start", choices=("rest", "straight"),
                   help="rest: the state reached from rest (loads and field ramped from zero; says when "
                        "the straight-rod start reaches another stable state); straight: the straight "
                        f"rod (default {d.start})")
    s.add_argument("--residual-tol", type=finite_float, metavar="TOL",
                   help="accuracy asked for: largest Euler-Lagrange residual relative to the moment "
                        f"scale, in (0, 1) (default {d.residual_tol:g}); a result above it exits 3")
    s.add_argument("--no-adapt", dest="adapt", action="store_false", default=None,
                   help="keep the mesh as given (no grading towards the clamp, no refinement); the "
                        "residual is still checked")
    s.add_argument("--keep-self-intersecting", action="store_true", default=None,
                   help="accept a self-intersecting shape (contact is not modelled; default: exit 3)")
    s.add_argument("--no-ensure-stable", dest="ensure_stable", action="store_false", default=None,
                   help="do not leave an unstable equilibrium along its unstable mode")
    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true",
                   help="print exactly one JSON object (the result contract) on stdout")
    o.add_argument("--out", metavar="DIR",
                   help="write result.json, shape.csv and shape.png into DIR (created if needed)")


def build_inputs(args: argparse.Namespace):
    """Scene, solver options and raw config from CONFIG and the flags (no solving).

    Returns
    -------
    scene : Scene
    options : SolverOptions
    raw : dict or None
        The config as loaded, for embedding in ``result.json``.

    Raises
    ------
    InputError
        Any invalid input (exit code 2).
    """
    from ..options import SolverOptions
    from ..scene import default_scene

    overrides = {"h": args.h, "phi": _rad(args.phi_deg), "p": args.p, "alpha": _rad(args.alpha_deg)}
    if args.config is None:
        raw = None
        options = SolverOptions()
        with bad_input():
            scene = default_scene(
                h=DEFAULTS["h"] if args.h is None else args.h,
                phi=math.radians(DEFAULTS["phi_deg"] if args.phi_deg is None else args.phi_deg),
                p=DEFAULTS["p"] if args.p is None else args.p,
                alpha=math.radians(DEFAULTS["alpha_deg"] if args.alpha_deg is None else args.alpha_deg))
    else:
        scene, options, raw = load_config(args.config)
        with bad_input("cannot apply the scene flags to CONFIG: "):
            scene = scene.with_values(**overrides)
    from .scene_args import apply_hard_magnetic_flags
    scene = apply_hard_magnetic_flags(scene, args)
    changes = {f: getattr(args, f) for f in _SOLVER_FLAGS if getattr(args, f) is not None}
    if args.ensure_stable is not None:
        changes["ensure_stable"] = args.ensure_stable
    try:
        options = dataclasses.replace(options, **changes)
    except ValueError as exc:
        field = str(exc).split(" ", 1)[0]
        raise InputError(f"{_SOLVER_FLAGS.get(field, 'solver options')}: {exc}") from exc
    from ..config.checks import check_scene_and_options
    with bad_input():  # flags applied on top of CONFIG: the mesh caps and profiles on the new mesh
        check_scene_and_options(scene, options)
    return scene, options, raw


def run(args: argparse.Namespace) -> int:
    """Run ``solve``: build inputs, solve, print and optionally write the result."""
    check_out_dir(args.out)
    scene, options, raw = build_inputs(args)

    from ..equilibrium import solve
    from ..io import dumps_json

    with stdout_to_stderr(args.json):
        result = solve(scene, options)
    written = None
    if args.out is not None:
        written = write_out(args.out, _output_files(result, raw), args.json, what="results ")
    if args.json:
        print(dumps_json(result.to_dict()))
    else:
        print(result.summary())
    if written is not None:
        print_written(written, args.json)
    if not result.success:
        what = {"inaccurate": "the result misses the accuracy asked for",
                "self_intersecting": "the shape intersects itself"}.get(result.status,
                                                                       "the solver did not converge")
        print(f"actuator-design: warning: {what} ({result.status}): "
              f"{' '.join(result.message.split())}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _output_files(result, raw) -> dict:
    """``result.json``, ``shape.csv`` and ``shape.png`` of ``--out``, in memory."""
    from ..io import result_files
    from ..viz.shape import shape_figure
    from ..viz.style import png_bytes

    return dict(result_files(result, raw), **{"shape.png": png_bytes(shape_figure(result), dpi=150)})


def _rad(deg):
    return None if deg is None else math.radians(deg)
