"""Phase portrait (theta, theta') of a uniform-field scene with its equilibria highlighted.

For a uniform field, constant stiffness and constant fibre angle the Euler-Lagrange equation is
autonomous and H = 1/2 theta'^2 + h^2 cos^2(theta + alpha - phi) + p sin(theta) (+ fx cos theta)
is constant along every solution; the portrait draws its level lines and the trajectory of every
equilibrium (from theta = theta0 at the clamp to theta' = 0 at the free end), stable ones solid,
unstable ones dashed, as in the paper's phase-diagram figures.

Without CONFIG the scene is THEORY §5's cantilever with h = 1.5, phi = 90 deg, p = 0, alpha = 0
unless flags set them. A CONFIG may carry `study: {type: phase, theta_range: [A, B],
dtheta_range: [C, D]}` (plus h, phi_deg, p, alpha_deg); flags override it.

Units: lengths (tip x, y) in rod lengths l, energies in B0/l, loads in B0/l^2 (moments B0/l),
theta' in rad per rod length; field and fibre angles in degrees on the command line, theta (and
the --theta-range window) in radians.

A physical scene (`type: physical`) also speaks its own units: lengths in the unit rod.length is
written in, fields as mu0 H in mT, loads in N, energies in J, H in J/m — a text line per state, the JSON's
`physical` keys beside the dimensionless ones, extra CSV columns (s_<unit>, dtheta_rad_per_<unit>) and
the figure's axes.

JSON (--json): groups, trajectories (theta, dtheta, level, spread of H, stable, morse_index,
tip_angle, energy, gamma), theta/dtheta ranges. --out DIR writes phase.json, trajectories.csv and
phase.png; `complete` says whether the equilibria drawn are certified to be all of them. Exit codes:
0 success, 2 bad input (e.g. a scene whose equation is not autonomous), 3 when the equilibria
search could not certify that it found them all (the portrait is written and may miss some).
"""
from __future__ import annotations

import argparse
import math
import sys

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                                        load_config, stdout_to_stderr)
from actuator_design.cli.common import print_written, write_out
from actuator_design.cli.path import add_scene_flags, csv_text, scene_and_options, study_settings

__all__ = ["HELP", "add_args", "run"]

HELP = "phase portrait (theta, theta') with the equilibria's trajectories"

DEFAULTS = {"h": 1.5, "phi_deg": 90.0, "p": 0.0, "alpha_deg": 0.0}


def _study_model():
    from actuator_design.config.studies.commands import PhaseStudy  # (pydantic loads only when a study is read)

    return PhaseStudy


def _pair(text: str, flag: str):
    try:
        ab = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"{flag}: expected A,B numbers, got {text!r}") from None
    if len(ab) != 2 or not all(math.isfinite(v) for v in ab) or not ab[1] > ab[0]:
        raise InputError(f"{flag}: expected two finite increasing values A,B, got {text!r}")
    return tuple(ab)


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``phase``."""
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene (and optional `study: {type: phase, ...}`); omit for the default")
    g = parser.add_argument_group("window")
    g.add_argument("--theta-range", metavar="A,B", help="theta window, rad (default: around the trajectories)")
    g.add_argument("--dtheta-range", metavar="A,B", help="theta' window, rad per l (default: around them)")
    add_scene_flags(parser, DEFAULTS)
    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    o.add_argument("--out", metavar="DIR", help="write phase.json, trajectories.csv and phase.png into DIR")


def run(args: argparse.Namespace) -> int:
    """Run ``phase``."""
    check_out_dir(args.out)
    study, loaded = _study_model()(), None
    if args.config is not None:
        loaded = load_config(args.config)
        study = study_settings(loaded[2], "phase", _study_model())
    scene, options, raw = scene_and_options(args, DEFAULTS, study, loaded)
    th_rng = _pair(args.theta_range, "--theta-range") if args.theta_range else (
        tuple(study.theta_range) if study.theta_range else None)
    dth_rng = _pair(args.dtheta_range, "--dtheta-range") if args.dtheta_range else (
        tuple(study.dtheta_range) if study.dtheta_range else None)

    from actuator_design.analysis.phase import check_autonomous, phase_portrait
    from actuator_design.io.save import dumps_json

    with bad_input():
        check_autonomous(scene)
    with stdout_to_stderr(args.json), bad_input():
        portrait = phase_portrait(scene, None, options, theta_range=th_rng, dtheta_range=dth_rng)
    data = portrait.to_dict()
    from actuator_design.io.user_units import user_units

    units = user_units(scene, raw)
    add_units(data, portrait, units)
    written = None
    if args.out is not None:
        written = write_out(args.out, _render(portrait, data, raw, units), args.json)
    if args.json:
        print(dumps_json(data))
    else:
        print(_summary(portrait, units))
    if written is not None:
        print_written(written, args.json)
    if not portrait.complete:
        print("actuator-design: warning: not complete: the portrait may miss equilibria (" + portrait.notes[0] + ")",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def add_units(data: dict, portrait, units) -> None:
    """A physical scene's units in ``phase``'s JSON, in place: the top-level ``physical`` and each
    trajectory's ``physical``: energy_J, gamma and dtheta in rad per length unit, the level of H
    in J/m (H is an energy per length, B0/ℓ²)."""
    if units is None:
        return
    from actuator_design.io.unit_results import command_physical, curvature_per_unit

    u = units.length_unit
    data["physical"] = command_physical(portrait.scene, units)
    data["physical"]["units"].update({f"dtheta_rad_per_{u}": f"rad/{u}", "level_J_per_m": "J/m"})
    for item, t in zip(data["trajectories"], portrait.trajectories):
        item["physical"] = {"energy_J": float(t.energy) * units.moment_scale,
                            f"gamma_rad_per_{u}": curvature_per_unit(t.gamma, units),
                            "level_J_per_m": float(t.level) * units.force_scale,
                            f"dtheta_rad_per_{u}": [curvature_per_unit(v, units) for v in t.dtheta]}


def _summary(portrait, units=None) -> str:
    sc = portrait.scene
    lines = [f"phase portrait: h = {sc.h:.6g}, phi = {math.degrees(sc.phi):.6g} deg, p = {sc.p:.6g}: "
             f"{len(portrait.trajectories)} equilibria "
             f"({sum(t.stable for t in portrait.trajectories)} stable)"]
    for t in portrait.trajectories:
        lines.append(f"  gamma = theta'(0) = {t.gamma:12.6f}, theta(1) = {t.tip_angle:10.6f} rad, "
                     f"H = {t.level:.8g} (spread {t.spread:.1e}), "
                     + ("stable" if t.stable else f"unstable (Morse index {t.morse_index})")
                     + (", self-intersecting" if t.self_intersecting else ""))
        if units is not None:
            from actuator_design.io.display import number
            from actuator_design.io.unit_results import curvature_per_unit
            u = units.length_unit
            lines.append(f"      in the user's units: gamma = {number(curvature_per_unit(t.gamma, units), '.6g', 1e-12)} "
                         f"rad/{u}, energy = {number(t.energy * units.moment_scale, '.6g', 1e-12 * units.moment_scale)} J, "
                         f"H = {number(t.level * units.force_scale, '.6g', 1e-12 * units.force_scale)} J/m")
    if units is not None:
        from actuator_design.io.unit_results import scene_text, units_line
        given = scene_text(sc, units)
        lines.append(f"  user units: {units_line(units)}" + (f"; {given}" if given else ""))
    for n in portrait.notes:
        lines.append(f"  note: {n}")
    return "\n".join(lines)


def _render(portrait, data, raw, units=None):
    from actuator_design.io.save import dumps_json
    from actuator_design.viz.phase import phase_figure
    from actuator_design.viz.style import png_bytes

    payload = dict(data)
    payload["config"] = raw
    cols = ["equilibrium", "point", "theta", "dtheta"]
    note = "units: theta in rad, dtheta in rad per rod length; s = point/(n-1) along each equilibrium"
    rows = []
    for i, t in enumerate(portrait.trajectories):
        n = len(t.theta)
        for j, (th, dth) in enumerate(zip(t.theta, t.dtheta)):
            row = [i, j, float(th), float(dth)]
            if units is not None:  # s and θ' in the user's length unit
                row += [units.length(j / max(n - 1, 1)), float(dth) / units.length(1.0)]
            rows.append(row)
    if units is not None:
        u = units.length_unit
        cols += [f"s_{u}", f"dtheta_rad_per_{u}"]
        note += f"; s_{u} in {u} (the unit of rod.length), dtheta_rad_per_{u} in rad/{u}"
    png = png_bytes(phase_figure(portrait, units=units), dpi=150)
    return {"phase.json": dumps_json(payload, indent=1) + "\n",
            "trajectories.csv": csv_text(cols, rows, note),
            "phase.png": png}
