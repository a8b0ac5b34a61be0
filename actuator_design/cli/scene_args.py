"""Scene flags and study sections shared by the analysis commands (one implementation for all).

Precedence of the dimensionless scene values (THEORY §5): command-line flags, then the CONFIG's
``study:`` section, then the CONFIG's scene, then the command's defaults (without CONFIG).
"""
from __future__ import annotations

import argparse
import math
import re
import warnings
from dataclasses import replace
from typing import Dict, Optional

from actuator_design.cli.common import (InputError, bad_input, check_angle_deg, check_parameter_angle,
                                        finite_float, load_config, nonnegative_float)

__all__ = ["SCENE_KEYS", "add_scene_args", "validate_study", "build_scene", "add_term_flags",
           "apply_term_flags", "add_set_arg", "apply_set_flags", "check_flags"]

#: The dimensionless scene values a command line may set (angles in degrees).
SCENE_KEYS = ("h", "phi_deg", "p", "alpha_deg")


def add_scene_args(parser: argparse.ArgumentParser, defaults: Dict[str, float], *, config: bool = True,
                   resolution: bool = True) -> None:
    """CONFIG (optional positional), --h, --phi-deg, --p, --alpha-deg and --elements/--degree."""
    if config:
        parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                            help="scene, solver and study configuration (YAML); omit for THEORY §5's scene")
    g = parser.add_argument_group("scene (dimensionless, THEORY §5; override CONFIG and its study)")
    g.add_argument("--h", type=nonnegative_float, metavar="H",
                   help=f"field group h >= 0 (default without CONFIG {defaults['h']:g}); on a physical CONFIG the "
                        "applied field it stands for: every group the field drives follows it")
    g.add_argument("--phi-deg", type=finite_float, metavar="DEG",
                   help=f"uniform field angle, degrees (default without CONFIG {defaults['phi_deg']:g})")
    g.add_argument("--p", type=finite_float, metavar="P",
                   help=f"vertical dead tip load p, units of B0/l^2 (default without CONFIG {defaults['p']:g})")
    g.add_argument("--alpha-deg", type=finite_float, metavar="DEG",
                   help=f"constant fibre angle, degrees (default without CONFIG {defaults['alpha_deg']:g})")
    add_term_flags(g)
    add_set_arg(parser)
    if resolution:
        s = parser.add_argument_group("solver (override CONFIG)")
        s.add_argument("--elements", type=int, metavar="N", help="number of elements (>= 1)")
        s.add_argument("--degree", type=int, metavar="D", help="polynomial degree per lgl element (>= 2)")


def validate_study(raw_config: Optional[dict], model, kind: str):
    """The CONFIG's ``study:`` section validated by the pydantic ``model`` (None when absent).

    Raises
    ------
    InputError
        ``study.type`` is not ``kind``, or a field is invalid: one line naming ``study.<field>``.
    """
    from pydantic import ValidationError

    raw = (raw_config or {}).get("study")
    if raw is None:
        return None
    if not isinstance(raw, dict):
        raise InputError(f"study: expected a mapping with a 'type' key, got {type(raw).__name__}")
    if raw.get("type") != kind:
        raise InputError(f"study.type: expected '{kind}' for this command, got {raw.get('type')!r}")
    try:
        return model.model_validate(raw)
    except ValidationError as err:
        e = err.errors()[0]
        loc = ".".join(str(p) for p in e["loc"])
        if e["type"] == "extra_forbidden":
            allowed = ", ".join(f.alias or n for n, f in model.model_fields.items())
            msg = f"unknown key (allowed: {allowed})"
        else:
            msg = e["msg"].removeprefix("Value error, ")
            msg = f"{msg[:1].lower()}{msg[1:]}, got {e.get('input')!r}"
        raise InputError(f"study.{loc}: {msg}") from None


def build_scene(args, defaults: Dict[str, float], study=None, loaded=None):
    """``(scene, options, raw)`` from CONFIG (``loaded``: its ``load_config`` triple if already
    read), the study's scene values and the flags (flags win); --elements/--degree if present."""
    from actuator_design.equilibrium.options import SolverOptions
    from actuator_design.model.scene import default_scene

    vals = {k: getattr(study, k, None) for k in SCENE_KEYS} if study is not None else {}
    for k in SCENE_KEYS:  # the study's angles are in degrees, as the flags (checked in main)
        if k.endswith("_deg") and getattr(args, k, None) is None:
            check_angle_deg(vals.get(k), f"study.{k}")
    for k in SCENE_KEYS:
        if getattr(args, k, None) is not None:
            vals[k] = getattr(args, k)
    rad = lambda k: None if vals.get(k) is None else math.radians(vals[k])
    if getattr(args, "config", None) is None:
        raw, options = None, SolverOptions()
        full = {k: defaults[k] if vals.get(k) is None else vals[k] for k in SCENE_KEYS}
        with bad_input():
            scene = default_scene(h=full["h"], phi=math.radians(full["phi_deg"]), p=full["p"],
                                  alpha=math.radians(full["alpha_deg"]))
    else:
        scene, options, raw = loaded if loaded is not None else load_config(args.config)
        with bad_input("cannot apply the scene values to CONFIG: "):
            scene = with_scene_values(scene, h=vals.get("h"), p=vals.get("p"), phi=rad("phi_deg"), alpha=rad("alpha_deg"))
    scene = apply_term_flags(scene, args)
    changes = {k: getattr(args, k) for k in ("elements", "degree") if getattr(args, k, None) is not None}
    with bad_input("solver options: "):
        options = replace(options, **changes)
    # the study's values and the flags changed the scene and the mesh after CONFIG was checked:
    # the groups' ranges, the memory budget and the profiles on this mesh again (README "Units and
    # scenes")
    from actuator_design.config.checks import check_scene_and_options

    with bad_input():
        check_scene_and_options(scene, options)
    return scene, options, raw


def with_scene_values(scene, h=None, **values):
    """``scene.with_values(h=…, p=…, phi=…, alpha=…)``, where on a physical scene a field group h is
    the applied field: every group it drives follows it (the lens's rule; from zero field its groups
    per unit field), so that no flag leaves h_r or h_pos at another field than h."""
    from actuator_design.physics import parameters as lens

    if h is not None and lens.per_field(scene) and scene.field is not None:
        scene, h = lens.apply_values(scene, {"h": h}), None
    return scene.with_values(h=h, **values)


def add_set_arg(parser) -> None:
    """--set NAME=VALUE (repeatable), in its own argument group: any value of the parameter lens,
    e.g. a plug-in term's."""
    parser.add_argument_group("any value of the parameter lens").add_argument("--set", action="append", metavar="NAME=VALUE", dest="set_values",
                       help="set a scene value of the parameter lens (THEORY §5), adding its term when "
                            "absent, e.g. a plug-in term's stiffness (repeatable; `actuator-design continue "
                            "--help` lists the names under --param). A plain number is dimensionless (angles "
                            "in rad); a value with a unit is converted: angles ('phi=30deg') always, fields, "
                            "loads and stiffnesses on a physical scene ('h=2mT': the applied field, which "
                            "moves every group it drives with it, as h given as a number does there)")


def apply_set_flags(scene, args, warn: bool = True):
    """``scene`` with every ``--set NAME=VALUE`` applied through the parameter lens, in order (after
    the other scene flags: ``--set h=2`` wins over ``--h``). A command that does not rebuild its
    scene through :func:`build_scene` checks it again with :func:`check_flags`."""
    from actuator_design.config.limits import group_problem, scene_group_values
    from actuator_design.io.user_units import parameter_from_text, user_units
    from actuator_design.model.units import parse_quantity
    from actuator_design.physics import parameters as lens

    for text in getattr(args, "set_values", None) or ():
        name, eq, value = text.partition("=")
        name, value = name.strip(), value.strip()
        if not eq or not name:
            raise InputError(f"--set: expected NAME=VALUE, got {text!r:.80}")
        with bad_input("--set: "):
            param = lens.parameter(name)
        table = lens.per_field(scene)
        if _has_unit(value) and param.field_power and (table.get(name) or param.field_magnitude and any(table.values())):
            # a field group given as a field is the applied field: every group it drives follows
            with bad_input():
                H = parse_quantity(value, "magnetic_field", f"--set {name}")
            if not H >= 0:
                raise InputError(f"--set {name}: the applied field must be >= 0, got {value!r} (turn the field "
                                 "round with its angle instead)")
            with bad_input(f"--set {name}: "):
                scene = lens.set_field(scene, H)
            for group, v in scene_group_values(scene):  # the groups the field gives, in their ranges
                problem = group_problem(group, v) if group in table else None
                if problem is not None:
                    raise InputError(f"--set {name}: the field {value} gives {group} = {v:g}, which "
                                     f"{problem.split(', got')[0]}")
        elif _has_unit(value):  # converted by the scene's scales (one line naming --set NAME if it cannot be)
            with bad_input():
                number = parameter_from_text(value, param, user_units(scene), f"--set {name}")
            with bad_input("--set "):
                scene = lens.set_value(scene, name, number)
        elif param.field_magnitude and table and scene.field is not None:  # a physical scene's field group
            with bad_input("--set "):  # the applied field: every group it drives follows it
                scene = lens.apply_values(scene, {name: value})
        else:
            with bad_input("--set "):  # the lens names the parameter, its range and the value
                scene = lens.set_value(scene, name, value)
            check_parameter_angle(name, float(value), f"--set {name}")  # an angle in rad within ±MAX_ANGLE_DEG
    if warn and getattr(args, "set_values", None):
        warn_beyond_model(scene)
    return scene


def warn_beyond_model(scene) -> None:
    """Warn (ModelAssumptionWarning) when flags put the rod in a field beyond the one its
    magnetisation model holds to, as a YAML field beyond the particles' saturation is warned of."""
    from actuator_design.physics.magnetic_composite import ModelAssumptionWarning
    from actuator_design.physics import parameters as lens

    beyond = lens.beyond_model(scene)
    if beyond is not None:
        warnings.warn(f"the scene flags set a field beyond the model: {beyond}", ModelAssumptionWarning,
                      stacklevel=3)


def _has_unit(value: str) -> bool:
    """Whether a --set value is a number followed by a unit ('30deg', '2 mT'), not a plain number
    (which the lens reads and range-checks itself, 'nan' and 'inf' included)."""
    try:
        float(value)
    except ValueError:
        return bool(re.match(r"^\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*[^\W\d_]", value)
                    or re.match(r"^\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*°", value))
    return False


def check_flags(scene, options) -> None:
    """The scene's groups, the mesh's memory budget for its Hessian (a term may make it dense) and
    its profiles on the mesh, checked again after flags changed them (InputError, one line)."""
    from actuator_design.config.checks import check_scene_and_options

    with bad_input():
        check_scene_and_options(scene, options)


def add_term_flags(group) -> None:
    """The flags the registered terms declare for their parameters (``Parameter.flag_help``: e.g.
    the hard-magnetic --h-r and --magnetization-deg, THEORY §9) on an argument group."""
    from actuator_design.physics import parameters as lens

    for p in lens.parameters().values():
        if p.flag_help:
            kind = nonnegative_float if p.lower == 0.0 else finite_float
            group.add_argument(p.flag, type=kind, metavar="DEG" if p.unit == "rad" else p.name.upper(),
                               dest=_dest(p), help=p.flag_help)


def _dest(p) -> str:
    return p.flag[2:].replace("-", "_")


def apply_term_flags(scene, args):
    """``scene`` with the terms' own flags applied through the parameter lens (each adds its term
    when absent; angles given in degrees), then every --set."""
    from actuator_design.physics import parameters as lens

    for p in lens.parameters().values():
        value = getattr(args, _dest(p), None) if p.flag_help else None
        if value is not None:
            with bad_input(f"{p.flag}: "):
                scene = lens.set_value(scene, p.name, math.radians(value) if p.unit == "rad" else value)
    scene = apply_set_flags(scene, args, warn=False)
    if any(getattr(args, k, None) is not None for k in SCENE_KEYS) or getattr(args, "set_values", None):
        warn_beyond_model(scene)  # once, whichever flag moved the field
    return scene
