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

JSON (--json): groups, trajectories (theta, dtheta, level, spread of H, stable, morse_index,
tip_angle, energy, gamma), theta/dtheta ranges. --out DIR writes phase.json, trajectories.csv and
phase.png. Exit codes: 0 success, 2 bad input (e.g. a scene whose equation is not autonomous).
"""
from __future__ import annotations

import argparse
import math

from .common import EXIT_OK, InputError, bad_input, check_out_dir, load_config, stdout_to_stderr
from .output import print_written, write_out
from .path import add_scene_flags, csv_text, scene_and_options, study_settings

__all__ = ["HELP", "add_args", "run"]

HELP = "phase portrait (theta, theta') with the equilibria's trajectories"

DEFAULTS = {"h": 1.5, "phi_deg": 90.0, "p": 0.0, "alpha_deg": 0.0}


def _study_model():
    from typing import List, Literal, Optional as O

    from pydantic import BaseModel, ConfigDict, Field

    class PhaseStudy(BaseModel):
        """``study: {type: phase, ...}`` — the flags of ``actuator-design phase``."""

        model_config = ConfigDict(extra="forbid")
        type: Literal["phase"] = "phase"
        theta_range: O[List[float]] = Field(None, min_length=2, max_length=2)
        dtheta_range: O[List[float]] = Field(None, min_length=2, max_length=2)
        h: O[float] = Field(None, ge=0)
        phi_deg: O[float] = None
        p: O[float] = None
        alpha_deg: O[float] = None

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

    from ..analysis.phase import check_autonomous, phase_portrait
    from ..io import dumps_json

    with bad_input():
        check_autonomous(scene)
    with stdout_to_stderr(args.json), bad_input():
        portrait = phase_portrait(scene, None, options, theta_range=th_rng, dtheta_range=dth_rng)
    data = portrait.to_dict()
    written = None
    if args.out is not None:
        written = write_out(args.out, _render(portrait, data, raw), args.json)
    if args.json:
        print(dumps_json(data))
    else:
        print(_summary(portrait))
    if written is not None:
        print_written(written, args.json)
    return EXIT_OK


def _summary(portrait) -> str:
    sc = portrait.scene
    lines = [f"phase portrait: h = {sc.h:.6g}, phi = {math.degrees(sc.phi):.6g} deg, p = {sc.p:.6g}: "
             f"{len(portrait.trajectories)} equilibria "
             f"({sum(t.stable for t in portrait.trajectories)} stable)"]
    for t in portrait.trajectories:
        lines.append(f"  gamma = theta'(0) = {t.gamma:12.6f}, theta(1) = {t.tip_angle:10.6f} rad, "
                     f"H = {t.level:.8g} (spread {t.spread:.1e}), "
                     + ("stable" if t.stable else f"unstable (Morse index {t.morse_index})")
                     + (", self-intersecting" if t.self_intersecting else ""))
    for n in portrait.notes:
        lines.append(f"  note: {n}")
    return "\n".join(lines)


def _render(portrait, data, raw):
    from ..io import dumps_json
    from ..viz.phase import phase_figure
    from ..viz.style import png_bytes

    payload = dict(data)
    payload["config"] = raw
    rows = [[i, j, float(th), float(dth)] for i, t in enumerate(portrait.trajectories)
            for j, (th, dth) in enumerate(zip(t.theta, t.dtheta))]
    png = png_bytes(phase_figure(portrait), dpi=150)
    return {"phase.json": dumps_json(payload, indent=1) + "\n",
            "trajectories.csv": csv_text(["equilibrium", "point", "theta", "dtheta"], rows,
                                         "units: theta in rad, dtheta in rad per rod length; "
                                         "s = point/(n-1) along each equilibrium"),
            "phase.png": png}
