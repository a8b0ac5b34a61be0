"""Find every equilibrium of a uniform-field cantilever, with its stability.

The shooting parameter gamma = theta'(0) is bounded a priori (|gamma| <= h^2 + |p| for THEORY §5's
scene, + h_r for a hard-magnetic rod, THEORY §9; see actuator_design.analysis.shooting_scan); it is scanned on a grid that is refined until the
number of sign changes of the free-end residual is stable, each root is refined and confirmed by
the collocation NLP. Each equilibrium is reported with its tip (x, y in rod lengths, angle in rad),
energy (B0/l), Morse index, stable flag, gamma (1/l) and whether the shape intersects itself.
The scan runs only where it can be trusted (the initial-value problem's error amplification is
bounded, e.g. h up to about 10 for the default scene); elsewhere (--h 1e4) the result says
complete: false with the reason (`incomplete_reason`) and the command exits 3 — as it does for any
list not certified complete (`--method deflation` never certifies one).

Without CONFIG the scene is THEORY §5's cantilever with h = 1, phi = 45 deg, p = 0, alpha = 0 deg;
with CONFIG its `study:` section (type: equilibria; keys h, phi_deg, p, alpha_deg, n_gamma, method)
and then the flags override it.

A physical scene (`type: physical`) also speaks its own units: lengths in the unit rod.length is
written in, fields as mu0 H in mT, loads in N, energies in J — a text line per state, the JSON's
`physical` keys beside the dimensionless ones, extra CSV columns (tip_x_<unit>, tip_y_<unit>, energy_J, gamma_rad_per_<unit>) and
the figure's axes.
"""
from __future__ import annotations

import argparse
import sys
from typing import Tuple

from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_out_dir,
                     finite_float, load_config, stdout_to_stderr)
from actuator_design.cli.common import print_written, write_out
from actuator_design.config.studies.commands import EquilibriaStudy, StudyBase
from actuator_design.cli.scene_args import (add_scene_args as _add_scene_args, build_scene as _build_scene,
                                            validate_study)

__all__ = ["HELP", "add_args", "run", "add_scene_args", "build_scene", "validate_study",
           "pair", "StudyBase", "EquilibriaStudy"]

HELP = "find all equilibria of a uniform-field scene (complete shooting scan + NLP)"

#: Scene defaults without CONFIG (those of ``solve``).
DEFAULTS = {"h": 1.0, "phi_deg": 45.0, "p": 0.0, "alpha_deg": 0.0}


# -- shared by the landscape commands (equilibria, continue, critical, map) -----------------------
def add_scene_args(parser: argparse.ArgumentParser) -> None:
    """CONFIG, --h, --phi-deg, --p, --alpha-deg (the fixed scene values; shared implementation)."""
    _add_scene_args(parser, DEFAULTS, resolution=False)


def build_scene(args, model, kind: str):
    """(scene, options, raw config, study) from CONFIG, its study section and the flags."""
    loaded = load_config(args.config) if args.config is not None else None
    study = validate_study(loaded[2] if loaded else None, model, kind)
    scene, options, raw = _build_scene(args, DEFAULTS, study, loaded)
    return scene, options, raw, study


def add_output_args(parser: argparse.ArgumentParser, what: str) -> None:
    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    o.add_argument("--out", metavar="DIR", help=f"write {what} into DIR (created if needed)")


# -- the command --------------------------------------------------------------------------------
def pair(text: str) -> Tuple[float, float]:
    """argparse type: ``A,B`` with finite A < B."""
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: expected A,B")
    a, b = (finite_float(p.strip()) for p in parts)
    if not a < b:
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: need A < B")
    return a, b


def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``equilibria``."""
    add_scene_args(parser)
    m = parser.add_argument_group("method")
    m.add_argument("--n-gamma", type=int, metavar="N",
                   help="initial number of gamma samples (>= 11, refined until stable; default 401)")
    m.add_argument("--method", choices=("shooting", "deflation"),
                   help="shooting: complete scan (default); deflation: deflated Newton multistart")
    add_output_args(parser, "equilibria.json, equilibria.csv and equilibria.png")


def _csv(result, units=None) -> str:
    """``equilibria.csv``: one row per equilibrium; a physical scene adds the state in its units."""
    from actuator_design.io.unit_results import state_columns, state_csv_note, state_values

    note = "" if units is None else "; " + state_csv_note(units)
    cols = "gamma,tip_x,tip_y,tip_angle,energy,morse_index,stable,self_intersecting"
    lines = ["# units: tip x, y in rod lengths l; angle in rad; energy in B0/l; gamma = theta'(0) in 1/l"
             + note, cols + ("" if units is None else "," + ",".join(state_columns(units)))]
    for e in result.equilibria:
        row = (f"{e.gamma!r},{e.tip['x']!r},{e.tip['y']!r},{e.tip['angle']!r},{e.energy!r},"
               f"{e.morse_index},{int(e.stable)},{int(e.self_intersecting)}")
        if units is not None:
            row += "," + ",".join(repr(v) for v in state_values(e.tip, e.energy, e.gamma, units))
        lines.append(row)
    return "\n".join(lines) + "\n"


def add_units(payload: dict, result, units) -> None:
    """A physical scene's units in ``equilibria``'s JSON, in place: the top-level ``physical``
    (units, field and loads) and each equilibrium's ``physical`` (tip, energy_J, gamma per unit)."""
    if units is None:
        return
    from actuator_design.io.unit_results import command_physical, point_physical

    payload["physical"] = command_physical(result.scene, units)
    for item, e in zip(payload.get("equilibria", []), result.equilibria):
        item["physical"] = point_physical(e.tip, e.energy, units, e.gamma)


def run(args: argparse.Namespace) -> int:
    """Run ``equilibria``."""
    check_out_dir(args.out)
    scene, options, raw, study = build_scene(args, EquilibriaStudy, "equilibria")
    n_gamma = args.n_gamma if args.n_gamma is not None else (study.n_gamma if study else 401)
    if not 11 <= n_gamma <= 100001:
        raise InputError(f"--n-gamma: must lie in [11, 100001], got {n_gamma}")
    method = args.method or (study.method if study else "shooting")
    from actuator_design.analysis.equilibria import find_equilibria, find_equilibria_deflation
    from actuator_design.analysis.equilibria_found import MAX_CONFIRM_ELEMENTS
    from actuator_design.io.save import dumps_json

    with stdout_to_stderr(args.json), bad_input():
        if method == "shooting":
            result = find_equilibria(scene, options, n_gamma=n_gamma)
        else:
            result = find_equilibria_deflation(scene, options)
    payload = result.to_dict()
    from actuator_design.io.user_units import user_units

    units = user_units(scene, raw)
    add_units(payload, result, units)
    written = None
    if args.out is not None:
        from actuator_design.viz.landscape import plot_equilibria
        from actuator_design.viz.style import png_bytes
        with stdout_to_stderr(args.json):
            files = {"equilibria.json": dumps_json({**payload, "config": raw}, indent=1) + "\n",
                     "equilibria.csv": _csv(result, units),
                     "equilibria.png": png_bytes(plot_equilibria(result, units=units), dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        from actuator_design.io.unit_results import scene_text, state_text, units_line
        noun = "equilibrium" if result.count == 1 else "equilibria"
        print(f"{result.count} {noun} ({result.stable_count} stable) with theta'(0) in "
              f"[{result.window[0]:.6g}, {result.window[1]:.6g}] ({method}; complete: {result.complete})")
        for e in result.equilibria:
            print(f"  gamma = {e.gamma:+.10f}  tip = ({e.tip['x']:.8f}, {e.tip['y']:.8f}), angle "
                  f"{e.tip['angle']:+.8f} rad  energy {e.energy:.10g}  "
                  + ("STABLE" if e.stable else f"unstable (Morse index {e.morse_index})")
                  + ("  [self-intersecting]" if e.self_intersecting else "")
                  + ("" if e.accuracy_problem is None else f"  [INACCURATE: {e.accuracy_problem}]"))
            if units is not None:
                print(f"      in the user's units: {state_text(e.tip, e.energy, units, e.gamma)}")
        if units is not None:
            given = scene_text(result.scene, units)
            print(f"  user units: {units_line(units)}" + (f"; {given}" if given else ""))
    if written is not None:
        print_written(written, args.json)
    if result.failures:
        print(f"actuator-design: warning: {len(result.failures)} shooting root(s) not confirmed by the NLP",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if result.inaccurate:
        print(f"actuator-design: warning: {len(result.inaccurate)} of {result.count} equilibria miss the "
              f"accuracy promise of solve (Euler–Lagrange residual) on meshes up to "
              f"{MAX_CONFIRM_ELEMENTS} elements", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if not result.complete:  # the list may miss equilibria: not an answer to call a success
        print(f"actuator-design: warning: not complete: {result.incomplete_reason}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK
