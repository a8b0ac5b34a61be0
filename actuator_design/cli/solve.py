"""Compute one equilibrium of a cantilever and report its shape, tip, energy and stability.

Without CONFIG the scene is THEORY §5's dimensionless cantilever
    E[theta] = 1/2 int theta'^2 ds - h^2 int cos^2(theta + alpha - phi) ds - p int sin(theta) ds,
clamped at the origin along x, in a uniform field at angle phi with a vertical tip load p, with
defaults h = 1.0, phi = 45 deg, p = 0, alpha = 0 deg. With CONFIG the flags override its values.

Units: lengths in rod lengths l, energies in B0/l, forces in B0/l^2, moments in B0/l; angles are
given in degrees on the command line and reported in radians. A physical scene also reports the
user's units: lengths in the unit rod.length is written in, the field as mu0 H in mT, forces in N,
moments in N m, energies in J — two text lines, keys added to the JSON's 'physical' (tip_x_<unit>,
tip_y_<unit>, shape_<unit>, field_mT, tip_force_N, ...), shape.csv columns s_<unit>, x_<unit>,
y_<unit>, dtheta_rad_per_<unit> and shape.png's axes, field and load in them.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                                        finite_float, load_config, nonnegative_float, stdout_to_stderr)
from actuator_design.cli.common import print_written, write_out
from actuator_design.io.display import number

__all__ = ["HELP", "add_args", "run", "build_inputs"]

HELP = "compute one equilibrium (default: THEORY §5's dimensionless cantilever)"

#: Defaults of the scene flags when no CONFIG is given (the API's ``default_scene`` inputs).
DEFAULTS = {"h": 1.0, "phi_deg": 45.0, "p": 0.0, "alpha_deg": 0.0}

#: Solver flags and the SolverOptions field each overrides.
_SOLVER_FLAGS = {"transcription": "--transcription", "elements": "--elements",
                 "degree": "--degree", "method": "--method", "tol": "--tol", "accuracy": "--accuracy",
                 "start": "--start", "residual_tol": "--residual-tol",
                 "keep_self_intersecting": "--keep-self-intersecting", "adapt": "--no-adapt",
                 "self_contact": "--no-self-contact"}


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``solve``."""
    from actuator_design.equilibrium.options import SolverOptions
    d = SolverOptions()
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene and solver configuration (YAML); omit for the default scene")
    g = parser.add_argument_group("scene (dimensionless, THEORY §5; override CONFIG)")
    g.add_argument("--h", type=nonnegative_float, metavar="H",
                   help="field group h >= 0, h^2 = mu0 chi H^2 A l^2 / (2 B) (dimensionless; "
                        f"default without CONFIG {DEFAULTS['h']:g}); on a physical CONFIG the applied field it "
                        "stands for: every group the field drives follows it")
    g.add_argument("--phi-deg", type=finite_float, metavar="DEG",
                   help="angle of the uniform field to the undeformed rod, degrees "
                        f"(default without CONFIG {DEFAULTS['phi_deg']:g})")
    g.add_argument("--p", type=finite_float, metavar="P",
                   help="vertical dead tip load p = P l^2 / B (dimensionless, units of B0/l^2; "
                        f"default without CONFIG {DEFAULTS['p']:g})")
    g.add_argument("--alpha-deg", type=finite_float, metavar="DEG",
                   help="constant fibre angle alpha, degrees (default without "
                        f"CONFIG {DEFAULTS['alpha_deg']:g})")
    from actuator_design.cli.scene_args import add_set_arg, add_term_flags
    add_term_flags(g)
    add_set_arg(parser)
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
                   help="accept a self-intersecting shape as it is (no self-contact)")
    s.add_argument("--no-self-contact", dest="self_contact", action="store_false", default=None,
                   help="refuse a shape that crosses itself (exit 3) instead of solving it with "
                        "self-contact (default: self-contact, with the rod's half-thickness as gap)")
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
    from actuator_design.equilibrium.options import SolverOptions
    from actuator_design.model.scene import default_scene

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
            from actuator_design.cli.scene_args import with_scene_values
            scene = with_scene_values(scene, **overrides)
    from actuator_design.cli.scene_args import apply_term_flags
    scene = apply_term_flags(scene, args)
    changes = {f: getattr(args, f) for f in _SOLVER_FLAGS if getattr(args, f) is not None}
    if args.ensure_stable is not None:
        changes["ensure_stable"] = args.ensure_stable
    try:
        options = dataclasses.replace(options, **changes)
    except ValueError as exc:
        field = str(exc).split(" ", 1)[0]
        raise InputError(f"{_SOLVER_FLAGS.get(field, 'solver options')}: {exc}") from exc
    from actuator_design.config.checks import check_scene_and_options
    with bad_input():  # flags applied on top of CONFIG: the mesh caps and profiles on the new mesh
        check_scene_and_options(scene, options)
    return scene, options, raw


def run(args: argparse.Namespace) -> int:
    """Run ``solve``: build inputs, solve, print and optionally write the result."""
    check_out_dir(args.out)
    scene, options, raw = build_inputs(args)

    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.io.save import dumps_json

    with stdout_to_stderr(args.json):
        result = solve(scene, options)
    from actuator_design.io.user_units import user_units

    units = user_units(scene, raw)
    payload = result.to_dict()
    add_physical(payload, result, units)
    written = None
    if args.out is not None:
        written = write_out(args.out, _output_files(result, raw, units, payload), args.json,
                            what="results ")
    if args.json:
        print(dumps_json(payload))
    else:
        lines = physical_lines(result, units)
        summary = result.summary().splitlines()
        if lines:  # the user's units in place of the summary's line in mm
            summary = [ln for ln in summary if not ln.startswith("  physical    :")] + lines
        print("\n".join(summary))
    if written is not None:
        print_written(written, args.json)
    if not result.success:
        what = {"inaccurate": "the result misses the accuracy asked for",
                "self_intersecting": "the shape intersects itself",
                "outside_field_region": "the rod lies, or is drawn, where the field is not known",
                "obstacle_at_rest": "an obstacle crosses the rod at rest",
                "not_reached_from_rest": "the state reached from rest was not found"}.get(result.status,
                                                                       "the solver did not converge")
        print(f"actuator-design: warning: {what} ({result.status}): "
              f"{' '.join(result.message.split())}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _output_files(result, raw, units=None, payload=None) -> dict:
    """``result.json``, ``shape.csv`` and ``shape.png`` of ``--out``, in memory (a physical scene's
    ``units``: the shape also in the user's units, the figure drawn in them)."""
    from actuator_design.io.save import result_files
    from actuator_design.viz.shape import shape_figure
    from actuator_design.viz.style import png_bytes

    return dict(result_files(result, raw, units, payload),
                **{"shape.png": png_bytes(shape_figure(result, units=units), dpi=150)})


def add_physical(payload: dict, result, units) -> None:
    """Add the user's units to ``solve --json``'s ``physical`` in place (no key renamed, removed or
    changed; nothing for a dimensionless scene): ``length_unit``, ``tip_x_<unit>``,
    ``tip_y_<unit>``, ``shape_<unit>`` {s, x, y} at the nodes, ``gamma_rad_per_<unit>`` (θ'(0)),
    the scene's ``field_mT`` (μ0 H of h), ``tip_force_N``, ``tip_moment_N_m``,
    ``distributed_load_N_per_m`` (those it has) and ``units``."""
    if units is None or not isinstance(payload.get("physical"), dict):
        return
    from actuator_design.io.unit_results import curvature_per_unit, load_units, scene_physical

    u = units.length_unit
    added = {"length_unit": u, f"tip_x_{u}": units.length(result.tip["x"]),
             f"tip_y_{u}": units.length(result.tip["y"]),
             f"shape_{u}": {"s": [units.length(v) for v in result.s],
                            "x": [units.length(v) for v in result.x],
                            "y": [units.length(v) for v in result.y]},
             f"gamma_rad_per_{u}": curvature_per_unit(result.gamma, units),
             **scene_physical(result.scene, units)}
    added["units"] = {k: v for k, v in {
        f"tip_x_{u}": u, f"tip_y_{u}": u, f"shape_{u}": u, f"gamma_rad_per_{u}": f"rad/{u}",
        "field_mT": "mT (mu0 H)", "field_A_per_m": "A/m", "energy_J": "J",
        "clamp_force_N": "N", "clamp_moment_Nm": "N m", "tip_x_m": "m", "tip_y_m": "m",
        **load_units(units)}.items()
        if k in added or k in payload["physical"]}
    payload["physical"] = {**added, **payload["physical"]}  # the SI keys as they were


def physical_lines(result, units) -> list:
    """The text lines in the user's units (empty for a dimensionless scene): the tip, the field and
    loads, the energy and the clamp reactions, then which units they are in. Replaces the summary's
    ``physical`` line, which is in mm whatever the scene's unit."""
    if units is None:
        return []
    from actuator_design.io.unit_results import length_text, scene_text, units_line

    u = units.length_unit
    noise = 1e-12  # round-off of a zero, in the dimensionless unit of each quantity
    fx, fy = (number(float(v) * units.force_scale, ".4g", noise * units.force_scale)
              for v in result.clamp_force)
    given = scene_text(result.scene, units)
    return [f"  physical    : tip = ({length_text(units.length(result.tip['x']), units)}, "
            f"{length_text(units.length(result.tip['y']), units)}) {u}"
            + (f", {given}" if given else "")
            + f", energy = {number(result.energy * units.moment_scale, '.6g', noise * units.moment_scale)} J"
            f", clamp force = ({fx}, {fy}) N, clamp moment = "
            f"{number(result.clamp_moment * units.moment_scale, '.4g', noise * units.moment_scale)} N m",
            f"  user units  : {units_line(units)}"]


def _rad(deg):
    return None if deg is None else math.radians(deg)
