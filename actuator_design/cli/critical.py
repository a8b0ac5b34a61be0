"""Find every fold and branch point of one parameter in a window, over all equilibrium branches.

All equilibria are computed (complete shooting scan) at a few values of the parameter across the
window, each is continued until its branch leaves the window, the branches bifurcating at branch
points are followed too, and the critical points are located accurately (root of the reduced
Hessian's eigenvalue along the branch) and deduplicated. Each is reported with the parameter value,
the tip angle (rad) and the number of equilibria just below and above it (shooting counts between
consecutive critical values). Parameters (--param) as for `continue`: h, h2, phi, p, fx, fy,
m_tip, qx, qy, alpha, h_pos, h_r, magnetization, theta0 (angles in rad). E.g. an axial remanent
magnetisation in an anti-parallel field (--h 0 --phi-deg 180 --h-r 0 --param h_r --window 0,5)
buckles at h_r = pi^2/4 (THEORY §9).

Units: dimensionless (THEORY §5): lengths in rod lengths l, energies in B0/l, loads in B0/l^2,
angles in rad (the --phi-deg and --alpha-deg flags take degrees). --window accepts units for
parameters with a physical meaning: angles ('10 deg,80 deg') always; for a physical scene fields
('2 mT,6 mT', '5 kA/m,8 kA/m'; h = H dh/dH) and loads ('1 mN,3 mN'). A physical scene's critical
points also carry field_mT and field_A_per_m (or value_N, ...) beside their value.

With CONFIG, its `study:` section (type: critical; keys param, window [a, b], n_samples and the
scene values h, phi_deg, p, alpha_deg) and then the flags apply.
"""
from __future__ import annotations

import argparse
import sys
from typing import Literal, Tuple

from pydantic import Field, field_validator

from .common import (EXIT_OK, InputError, bad_input, check_out_dir, check_parameter_angle,
                     stdout_to_stderr)
from .continue_ import PARAM_NAMES, ParamName
from .equilibria import StudyBase, add_output_args, add_scene_args, build_scene
from .output import print_written, write_out

__all__ = ["HELP", "add_args", "run", "CriticalStudy"]

HELP = "every fold and branch point of a parameter window, over all branches"


class CriticalStudy(StudyBase):
    type: Literal["critical"]
    param: ParamName
    window: Tuple[float, float]
    n_samples: int = Field(5, ge=2, le=200)

    @field_validator("window")
    @classmethod
    def _increasing(cls, w):
        if not w[0] < w[1]:
            raise ValueError("must be increasing [a, b] with a < b")
        return w


def add_args(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``critical``."""
    add_scene_args(parser)
    c = parser.add_argument_group("critical points")
    c.add_argument("--param", choices=PARAM_NAMES, help="the parameter")
    c.add_argument("--window", metavar="A,B",
                   help="parameter window, A < B; units allowed where the parameter has them, e.g. '2 mT,6 mT'")
    c.add_argument("--samples", type=int, metavar="N",
                   help="parameter values where all equilibria are computed (>= 2; default 5)")
    add_output_args(parser, "critical.json, critical.csv and critical.png")


def _csv(res) -> str:
    lines = [f"# critical points of {res.param}; tip angle in rad",
             "kind,value,tip_angle,equilibria_below,equilibria_above,located"]
    for d in res.folds + res.branch_points:
        lines.append(f"{d['kind']},{d['value']!r},{d['tip_angle']!r},{d['equilibria_below']},"
                     f"{d['equilibria_above']},{int(d['located'])}")
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    """Run ``critical``."""
    check_out_dir(args.out)
    scene, options, raw, study = build_scene(args, CriticalStudy, "critical")
    param = args.param or (study.param if study else None)
    if param is None:
        raise InputError("--param: required (or give it in the config's study section)")
    from ..parameters import parameter
    from ..user_units import (add_physical_values, pair_from_text, parameter_unit_label,
                              physical_value_keys, user_units)

    units = user_units(scene, raw)
    with bad_input():
        window = (pair_from_text(args.window, parameter(param), units, "--window") if args.window
                  else (tuple(study.window) if study else None))
    if window is None:
        raise InputError("--window: required as A,B (or give it in the config's study section)")
    if not args.window:  # from the study section, in the parameter's unit
        for v in window:
            check_parameter_angle(param, v, "study.window")
    n_samples = args.samples if args.samples is not None else (study.n_samples if study else 5)
    if n_samples < 2:
        raise InputError(f"--samples: must be >= 2, got {n_samples}")

    from ..parameters import set_value as set_param
    from ..analysis.critical import critical_points
    from ..io import dumps_json

    with bad_input(f"--param {param}: "):
        set_param(scene, param, window[0])
        set_param(scene, param, window[1])
    with stdout_to_stderr(args.json), bad_input():
        res = critical_points(scene, param, window, options=options, n_samples=n_samples)
    payload = res.to_dict()
    add_physical_values(payload["folds"] + payload["branch_points"], parameter(param), units)
    unit = parameter_unit_label(parameter(param), units)
    written = None
    if args.out is not None:
        from ..viz.landscape import plot_branches
        from ..viz.style import png_bytes
        with stdout_to_stderr(args.json):
            ax = plot_branches(res.branches, title=f"branches and critical points in {param}")
            if param == "h":  # h ∝ H: tick the parameter axis in mT
                from ..viz.units import field_axis
                field_axis(ax.xaxis, units)
            full = res.to_dict(branches=True)
            add_physical_values(full["folds"] + full["branch_points"], parameter(param), units)
            files = {"critical.json": dumps_json({**full, "config": raw}, indent=1) + "\n",
                     "critical.csv": _csv(res), "critical.png": png_bytes(ax, dpi=150)}
        written = write_out(args.out, files, args.json)
    if args.json:
        print(dumps_json(payload))
    else:
        ends = [physical_value_keys(parameter(param), v, units) for v in window]
        span = (f" ({ends[0]['field_mT']:.6g} to {ends[1]['field_mT']:.6g} mT)" if "field_mT" in ends[0] else "")
        print(f"{param} in [{window[0]:g}, {window[1]:g}]{span}: {len(res.folds)} fold(s), "
              f"{len(res.branch_points)} branch point(s) over {res.stats['branches']} branch(es)"
              f" (complete: {res.complete})")
        for d in res.folds + res.branch_points:
            phys = f" ({d['field_mT']:.6g} mT)" if "field_mT" in d else (
                f" ({next(v for k, v in d.items() if k.startswith('value_')):.6g} {unit})" if unit else "")
            print(f"  {d['kind']:12s} {param} = {d['value']:.12g}{phys}  tip angle {d['tip_angle']:+.8f} rad  "
                  f"equilibria {d['equilibria_below']} -> {d['equilibria_above']}")
    if written is not None:
        print_written(written, args.json)
    for why in res.incomplete_reasons:
        print(f"actuator-design: warning: not complete at {why}", file=sys.stderr)
    return EXIT_OK
