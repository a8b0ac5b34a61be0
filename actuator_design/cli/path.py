"""Follow the stable equilibrium along a quasi-static loading path; report snaps and hysteresis.

Ramp one parameter (--param NAME) through --schedule A,B,C,... or --from A --to B [--back]
[--steps N]; the other values are fixed by CONFIG and the scene flags. The rod follows its stable
equilibrium (warm-started Newton with adaptive steps); where it loses stability at a fold it snaps
to the stable state it lands on (IPOPT from the fold pushed along its null mode). The report lists
every jump (where, from which state to which, energy released), continuous bifurcations, whether
the path is snap-free, and the hysteresis loop (width in the parameter, area in the
(parameter, tip angle) plane). A scene with obstacles (scene.obstacles) is followed by contact
equilibria, each from the state before it; every touch-down and lift-off is located (where the
free rod just touches the obstacle) and listed with the obstacle and the touching point; so is a
rod with a thickness that meets itself on the way (self-contact, "rod itself").

NAME is one of <dimensionless> (dimensionless, THEORY §5 and §9),
<degrees> (degrees) or <radians> (radians). Without CONFIG the scene is
THEORY §5's cantilever with h = 0, phi = 0, p = 0, alpha = 0 unless flags set them. A CONFIG may
carry the settings in a section
    study: {type: path, param: h, from: 0, to: 2, back: true, steps: 40}
or  study: {type: path, schedule: [{h: 0, phi_deg: 60}, {h: 1.5, phi_deg: 60}, {h: 1.5, phi_deg: 120}]}
(a list of settings of several parameters: a multi-parameter path; on a physical scene a value may
be a quantity, e.g. {h: '15 mT', phi: '60 deg'}); flags override it.

Units: lengths (tip x, y) in rod lengths l, energies in B0/l, loads in B0/l^2 (moments B0/l),
stiffness in B0/l^3 (and N/m for physical scenes); angles in degrees on the command line and
radians in the output. --from/--to/--schedule values may carry units where NAME has a physical
meaning: angles ('30 deg'), and for a physical scene fields ('2 mT', '5 kA/m'; h = H dh/dH) and
loads ('1 mN'); a physical scene's points and jumps then also carry field_mT and field_A_per_m
(or value_N, ...) beside param. A physical scene reports the user's units beside the dimensionless
values everywhere: lengths in the unit rod.length is written in, fields as mu0 H in mT, loads in N,
energies in J — text lines (schedule, final tip, jumps, hysteresis width), JSON 'physical' keys
(top level and on every point, jump and bifurcation), path.csv columns (tip_x_<unit>,
tip_y_<unit>, energy_J, value_<name>_mT / _N / _N_m / _N_per_m) and path.png's axes.

JSON (--json): one object with points (param, tip {x, y, angle}, energy, stable, min_eigenvalue,
...), jumps (param, from, to, energy_released, ...), snap_free, hysteresis {width, area, loops},
contact_events (kind touch-down/lift-off, param, values, obstacle, obstacle_text, s, located).
--out DIR writes path.json, path.csv and path.png. Exit codes: 0 success, 2 bad input, 3 the path
could not be followed to its end (the part computed is still reported).
"""
from __future__ import annotations

import argparse
import csv
import io as _io
import math
import re
import sys
from typing import Dict, Optional, Union

from actuator_design.io.display import number
from actuator_design.io.unit_results import unit_suffix
from actuator_design.io.user_units import VALUE_KEY_UNITS
from actuator_design.physics.parameters import degree_aliases, names as parameter_names
from actuator_design.cli.scene_args import add_scene_args, build_scene, validate_study
from actuator_design.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, InputError, bad_input, check_angle_deg,
                     check_out_dir, check_parameter_angle, finite_float, load_config,
                     stdout_to_stderr)
from actuator_design.cli.common import print_written, write_out

__all__ = ["HELP", "add_args", "run", "add_scene_flags", "scene_and_options", "study_settings",
           "csv_text"]

HELP = "quasi-static loading path: follow the stable state, snaps, hysteresis"

#: Scene values without CONFIG (THEORY §5's cantilever).
DEFAULTS = {"h": 0.0, "phi_deg": 0.0, "p": 0.0, "alpha_deg": 0.0}

#: Command-line names in degrees and the API name they map to.
_DEGREE_NAMES = degree_aliases()  # the lens angles: phi_deg, alpha_deg, theta0_deg, ...
#: the names NAME may take, from the parameter lens (so the help lists what the lens accepts)
_NAME_LISTS = {"dimensionless": ", ".join(n for n in parameter_names() if n not in _DEGREE_NAMES.values()),
               "degrees": ", ".join(_DEGREE_NAMES), "radians": ", ".join(_DEGREE_NAMES.values())}
for _key, _names in _NAME_LISTS.items():
    __doc__ = __doc__.replace(f"<{_key}>", _names)


# -- helpers shared by path, stiffness and phase ---------------------------------------------------
def study_settings(raw: Optional[dict], kind: str, model):
    """The CONFIG's ``study:`` section validated by ``model`` (``model()`` when absent)."""
    return validate_study(raw, model, kind) or model()


def add_scene_flags(parser: argparse.ArgumentParser, defaults: Dict[str, float]) -> None:
    """The scene flags and the solver resolution flags (the shared implementation)."""
    add_scene_args(parser, defaults, config=False)


scene_and_options = build_scene  # (args, defaults, study, loaded) -> (scene, options, raw)


def csv_text(columns, rows, comment: str = "") -> str:
    buf = _io.StringIO()
    if comment:
        buf.write(f"# {comment}\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([repr(float(v)) if isinstance(v, float) else v for v in r])
    return buf.getvalue()


# -- the path command ------------------------------------------------------------------------------
def _study_model():
    from actuator_design.config.studies.commands import PathStudy  # (pydantic loads only when a study is read)

    return PathStudy


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``path``."""
    parser.add_argument("config", nargs="?", metavar="CONFIG.yaml",
                        help="scene (and optional `study: {type: path, ...}`); omit for the default scene")
    g = parser.add_argument_group("path")
    g.add_argument("--param", metavar="NAME",
                   help="parameter to ramp: {dimensionless}, {degrees} (degrees) or {radians} (radians)".format(
                       **_NAME_LISTS))
    g.add_argument("--schedule", metavar="A,B,C,...", help="values of NAME in order (e.g. up and back down)")
    g.add_argument("--from", dest="start", metavar="A", help="first value of NAME (units allowed, e.g. '2 mT')")
    g.add_argument("--to", metavar="B", help="turning value of NAME (units allowed, e.g. '6 mT')")
    g.add_argument("--back", action="store_true", default=None, help="ramp back from B to A")
    g.add_argument("--steps", type=int, metavar="N",
                   help="at least N steps per ramp (default: adaptive, about 20 per path)")
    add_scene_flags(parser, DEFAULTS)
    o = parser.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    o.add_argument("--out", metavar="DIR", help="write path.json, path.csv and path.png into DIR")


def _value(text, key: str, units, flag: str) -> float:
    """A value of parameter ``key`` (a CLI name, ``phi_deg`` …) in its CLI unit; a quantity with a
    unit is converted (angles to degrees for the *_deg names, fields through the scene's scales)."""
    from actuator_design.physics.parameters import parameter
    from actuator_design.io.user_units import parameter_from_text

    if key in _DEGREE_NAMES:
        try:
            value = finite_float(str(text))
        except Exception:
            pass
        else:
            check_angle_deg(value, flag)  # in degrees, the unit of the *_deg name
            return value
        with bad_input():
            return math.degrees(parameter_from_text(text, parameter(_DEGREE_NAMES[key]), units, flag))
    with bad_input():
        return parameter_from_text(text, parameter(key), units, flag)


def _schedule(args, study, units=None):
    """(schedule for the API, name as given, factor API → given units, max_step)."""
    from actuator_design.physics.parameters import names as parameter_names

    PARAMETERS = parameter_names()

    steps = args.steps if args.steps is not None else study.steps
    if steps is not None and steps < 1:
        raise InputError(f"--steps: must be >= 1, got {steps}")
    text = args.schedule
    start, to = args.start, args.to
    back = args.back if args.back is not None else study.back
    sched_study = study.schedule if (text is None and args.start is None and args.to is None) else None
    max_step = study.max_step
    if sched_study and isinstance(sched_study[0], dict):  # multi-parameter schedule from the config
        rows = []
        for i, row in enumerate(sched_study):
            conv = {}
            for k, v in row.items():
                name = _DEGREE_NAMES.get(k, k)
                if name not in PARAMETERS:
                    raise InputError(f"study.schedule[{i}].{k}: unknown parameter (allowed: "
                                     f"{', '.join(list(PARAMETERS) + list(_DEGREE_NAMES))})")
                if isinstance(v, str):  # a quantity ('15 mT', '30 deg'), in the parameter's CLI unit
                    v = _value(v, k, units, f"study.schedule[{i}].{k}")
                check_parameter_angle(k, v, f"study.schedule[{i}].{k}")
                conv[name] = math.radians(v) if k in _DEGREE_NAMES else v
            rows.append(conv)
        return rows, None, 1.0, max_step
    name = args.param or study.param
    if name is None:
        raise InputError("--param: required (or `study: {type: path, param: NAME}` in CONFIG)")
    key = name.replace("-", "_")
    api = _DEGREE_NAMES.get(key, key)
    if api not in PARAMETERS:
        raise InputError(f"--param: unknown parameter {name!r} (allowed: "
                         f"{', '.join(list(PARAMETERS) + list(_DEGREE_NAMES))})")
    factor = math.pi / 180.0 if key in _DEGREE_NAMES else 1.0
    for where, given in (("study.from", study.start if start is None else None),
                         ("study.to", study.to if to is None else None)):
        check_parameter_angle(key, given, where)
    start = study.start if start is None else _value(start, key, units, "--from")
    to = study.to if to is None else _value(to, key, units, "--to")
    if text is not None:
        if not all(re.match(r"^\s*[+-]?(\d|\.\d)", v) for v in text.split(",")):
            raise InputError(f"--schedule: expected comma-separated numbers (or quantities such as "
                             f"'2 mT'), got {text!r}")
        values = [_value(v.strip(), key, units, "--schedule") for v in text.split(",")]
    elif sched_study is not None:
        values = [_value(v, key, units, f"study.schedule[{i}]") if isinstance(v, str) else float(v)
                  for i, v in enumerate(sched_study)]
        for i, v in enumerate(values):
            check_parameter_angle(key, v, f"study.schedule[{i}]")
    else:
        if start is None or to is None:
            raise InputError("--schedule or both --from and --to: required")
        values = [start, to] + ([start] if back else [])
        if steps is not None:
            max_step = 1.0 / steps
    if len(values) < 2 or not all(math.isfinite(v) for v in values):
        raise InputError(f"--schedule: need at least 2 finite values, got {values}")
    if steps is not None and max_step is None:
        max_step = 1.0 / steps
    return [{api: v * factor} for v in values], name, factor, max_step


def _scaled_dict(path, factor: float, name: Optional[str]) -> dict:
    """path.to_dict() with the ramped parameter in the units it was given (degrees for *_deg)."""
    d = path.to_dict()
    if name is not None:
        d["param"] = name
        if factor != 1.0:
            for item in d["points"] + d["jumps"] + d["bifurcations"] + d["contact_events"]:
                item["param"] /= factor
            hy = d["hysteresis"]
            hy["width"] /= factor
            hy["area"] /= factor
            for loop in hy.get("loops", []):
                loop["width"] /= factor
                loop["area"] /= factor
                loop["jumps"] = [v / factor for v in loop["jumps"]]
                for key in ("branch_before", "branch_between"):
                    loop[key] = [[a / factor, b] for a, b in loop.get(key, [])]
            d["param_unit"] = "deg"
    return d


def run(args: argparse.Namespace) -> int:
    """Run ``path``."""
    check_out_dir(args.out)
    study, loaded = _study_model()(), None
    if args.config is not None:
        loaded = load_config(args.config)
        study = study_settings(loaded[2], "path", _study_model())
    scene, options, raw = scene_and_options(args, DEFAULTS, study, loaded)
    from actuator_design.io.user_units import add_physical_values, user_units

    units = user_units(scene, raw)
    schedule, name, factor, max_step = _schedule(args, study, units)

    from actuator_design.continuation.loading import follow_path
    from actuator_design.io.save import dumps_json

    with stdout_to_stderr(args.json), bad_input():
        path = follow_path(scene, options, schedule, max_step=max_step)
    data = _scaled_dict(path, factor, name)
    if name is not None and factor == 1.0 and units is not None:
        from actuator_design.physics.parameters import parameter

        p = parameter(name.replace("-", "_"))
        add_physical_values(data["points"] + data["jumps"] + data["bifurcations"] + data["contact_events"], p, units,
                            key="param")
    add_physical_block(data, path, units, factor)
    if units is not None:  # the obstacle of each contact event, in the user's length unit
        for e in data["contact_events"]:
            e.setdefault("physical", {})["obstacle_text"] = ("rod itself" if e["obstacle"] is None else
                                                             scene.obstacles[e["obstacle"]].describe(
                                                                 units.length(1.0), units.length_unit))
    written = None
    if args.out is not None:
        written = write_out(args.out, _render(path, data, raw, factor, units), args.json)
    if args.json:
        print(dumps_json(data))
    else:
        print(path.summary() if factor == 1.0 else _summary_deg(path, data))
        for line in _physical_lines(data, units):
            print(line)
    if written is not None:
        print_written(written, args.json)
    if not path.success:
        print(f"actuator-design: warning: the path could not be followed to its end: {path.message}",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _physical_lines(data, units=None) -> list:
    """The schedule, the final tip and energy, the jumps, bifurcations and hysteresis width in the
    user's units: lengths in the scene's length unit, fields in mT (mu0 H), loads in N, energies
    in J (physical scenes; empty otherwise)."""
    phys = data.get("physical")
    if units is None or phys is None:
        return []
    u, lines = units.length_unit, []
    for n, (unit, values) in phys.get("schedule", {}).items():
        lines.append(f"  schedule of {n} [{unit}]: " + " -> ".join(number(v) for v in values)
                     + (" (mu0 H)" if unit == "mT" else ""))
    if data["points"]:
        fin = phys["final"]
        lines.append(f"  final tip [{u}]: ({_len(fin['tip']['x'], units)}, {_len(fin['tip']['y'], units)}), "
                     f"energy {number(fin['energy_J'], '.6g', noise=1e-12 * units.moment_scale)} J")
    where = _where_text(data)
    for j in data["jumps"]:
        jp = j["physical"]
        lines.append(f"  jump ({j['kind']}) at {where(j)}: tip ({_len(jp['from_tip']['x'], units)}, "
                     f"{_len(jp['from_tip']['y'], units)}) -> ({_len(jp['to_tip']['x'], units)}, "
                     f"{_len(jp['to_tip']['y'], units)}) {u}, energy released "
                     f"{number(jp['energy_released_J'], '.6g')} J")
    for b in data["bifurcations"]:
        bt = b["physical"]["tip"]
        lines.append(f"  continuous bifurcation at {where(b)}: tip ({_len(bt['x'], units)}, "
                     f"{_len(bt['y'], units)}) {u}" + ("" if b.get("located", True) else " (at the step; not located)"))
    for e in data["contact_events"]:
        at = "" if e["s"] is None else f" at s = {_len(e['s'] * units.length_m / units.metres_per_unit, units)} {u}"
        when = where(e) if data["param"] else _values_text(e["values"], units)
        on = f" {'on' if e['kind'] == 'touch-down' else 'from'} the {e['physical']['obstacle_text']}"
        lines.append(f"  {e['kind']}{on} at {when}{at}" + ("" if e["located"] else " (at the step; not located)"))
    hy = phys.get("hysteresis")
    if hy:
        lines.append(f"  hysteresis width [{hy['unit']}]: {number(hy['width'], '.6g')}")
    return lines


def _values_text(values: dict, units) -> str:
    """Scheduled values in the user's units: fields in mT, loads in N, angles in degrees."""
    import math

    from actuator_design.physics.parameters import parameter
    from actuator_design.io.user_units import physical_value_keys

    out = []
    for name, v in values.items():
        keys = physical_value_keys(parameter(name), v, units)
        if "field_mT" in keys:
            out.append(f"mu0 H = {number(keys['field_mT'])} mT")
        elif keys:
            (key, val), = keys.items()
            out.append(f"{name} = {number(val)} {VALUE_KEY_UNITS[key]}")
        elif name in ("phi", "alpha", "theta0"):
            out.append(f"{name} = {number(math.degrees(v))} deg")
        else:
            out.append(f"{name} = {number(v)}")
    return ", ".join(out)


def _len(x: float, units) -> str:
    """A length already in the user's unit, printed (round-off of zero as 0)."""
    from actuator_design.io.unit_columns import length_noise
    return number(x, ".6g", noise=length_noise(units))


def _where_text(data):
    """Where a jump or bifurcation is, in the user's units when the parameter has them."""
    def where(item):
        if "field_mT" in item:
            return f"mu0 H = {number(item['field_mT'])} mT ({number(item['field_A_per_m'])} A/m)"
        for key, unit in VALUE_KEY_UNITS.items():
            if key in item:
                return f"{data['param']} = {number(item[key])} {unit}"
        return (f"{data['param'] or 't'} = {item['param']:.10g}"
                + (" deg" if data.get("param_unit") == "deg" else ""))
    return where


def add_physical_block(data: dict, path, units, factor: float = 1.0) -> None:
    """Add the user's units to ``data`` (``path.to_dict()`` as reported) in place; no key is
    renamed or removed. Every point and bifurcation gains ``physical.tip`` {x, y} (the scene's
    length unit) and ``physical.energy_J``; every jump ``physical.from_tip``, ``to_tip`` and
    ``energy_released_J``; the top level ``physical``: ``length_unit``, ``units``, ``final``
    {tip, energy_J}, ``schedule`` {name: [unit, values]} for parameters with a physical unit
    (fields as mu0 H in mT, loads in N) and ``hysteresis`` {width, unit} of a linear one.
    Nothing for a dimensionless scene (``units`` None)."""
    if units is None:
        return
    from actuator_design.physics.parameters import parameter
    from actuator_design.io.user_units import parameter_physical, parameter_unit_label

    def tip(t):
        return {"x": units.length(t["x"]), "y": units.length(t["y"])}

    for item in data["points"]:
        item["physical"] = {"tip": tip(item["tip"]), "energy_J": item["energy"] * units.moment_scale}
    for j in data["jumps"]:
        j["physical"] = {"from_tip": tip(j["from"]["tip"]), "to_tip": tip(j["to"]["tip"]),
                         "energy_released_J": j["energy_released"] * units.moment_scale}
    for b in data["bifurcations"]:
        b["physical"] = {"tip": tip(b["state"]["tip"]), "energy_J": b["state"]["energy"] * units.moment_scale}
    fin = data["final"]
    phys = {"length_unit": units.length_unit,
            "units": {"tip": units.length_unit, "energy_J": "J", "field_mT": "mT (mu0 H)",
                      "field_A_per_m": "A/m", **VALUE_KEY_UNITS},
            "final": {"tip": tip(fin["tip"]), "energy_J": fin["energy"] * units.moment_scale},
            "schedule": {}}
    for n in path.names:
        p = parameter(n)
        label = parameter_unit_label(p, units)
        if label is not None:
            phys["schedule"][n] = [label, [parameter_physical(p, row[n], units) for row in data["schedule"]]]
    if path.param is not None and factor == 1.0:
        p = parameter(path.param)
        label = parameter_unit_label(p, units)
        if label is not None and p.transform != "sqrt" and data["hysteresis"].get("loops"):
            phys["hysteresis"] = {"width": parameter_physical(p, data["hysteresis"]["width"], units),
                                  "unit": label}
    data["physical"] = phys


def _summary_deg(path, data) -> str:
    lines = path.summary().splitlines()
    lines = [ln for ln in lines if not ln.lstrip().startswith(("jump", "hysteresis", "continuous"))]
    out = lines[:2]
    for j in data["jumps"]:
        out.append(f"  jump ({j['kind']}) at {data['param']} = {j['param']:.10g} deg: tip angle "
                   f"{j['from']['tip']['angle']:.6f} -> {j['to']['tip']['angle']:.6f} rad, energy released "
                   f"{j['energy_released']:.6g} B0/l")
    for b in data["bifurcations"]:
        out.append(f"  continuous bifurcation at {data['param']} = {b['param']:.10g} deg")
    hy = data["hysteresis"]
    if hy.get("loops"):
        out.append(f"  hysteresis: width {hy['width']:.8g} deg, loop area {hy['area']:.6g} deg rad")
    return "\n".join(out + lines[2:])


def _render(path, data, raw, factor: float = 1.0, units=None) -> Dict[str, Union[str, bytes]]:
    """path.json, path.csv and path.png in memory."""
    from actuator_design.io.save import dumps_json
    from actuator_design.viz.loading import path_figure
    from actuator_design.viz.style import png_bytes

    payload = dict(data)
    payload["config"] = raw
    cols = ["t", "param", "tip_x", "tip_y", "tip_angle", "energy", "stable", "min_eigenvalue",
            "morse_index", "branch", "direction", "kind"] + [f"value_{n}" for n in path.names]
    rows = [[p["t"], p["param"], p["tip"]["x"], p["tip"]["y"], p["tip"]["angle"], p["energy"],
             p["stable"], p["min_eigenvalue"], p["morse_index"], p["branch"], p["direction"], p["kind"]]
            + [p["values"][n] for n in path.names] for p in data["points"]]
    comment = ("units: tip x, y in rod lengths l; angles in rad; energy in B0/l; param in the units of "
               "--param; value_* in API units (rad for angles)")
    if units is not None:
        cols, rows, extra = _physical_columns(path, data, cols, rows, units)
        comment += "; " + extra
    xlabel = None if path.param is None else data["param"] + (" [deg]" if factor != 1.0 else "")
    fig = path_figure(path, xscale=1.0 / factor, xlabel=xlabel, units=units)
    png = png_bytes(fig, dpi=150)
    return {"path.json": dumps_json(payload, indent=1) + "\n",
            "path.csv": csv_text(cols, rows, comment),
            "path.png": png}


def _physical_columns(path, data, cols, rows, units):
    """path.csv's columns in the user's units after the existing ones: ``tip_x_<unit>``,
    ``tip_y_<unit>``, ``energy_J`` and ``value_<name>_mT`` (mu0 H), ``_N``, ``_N_m``, ``_N_per_m``
    of each scheduled parameter with a physical unit; and the units line's text for them."""
    from actuator_design.physics.parameters import parameter
    from actuator_design.io.user_units import parameter_physical, parameter_unit_label

    u = units.length_unit
    extra_cols = [f"tip_x_{u}", f"tip_y_{u}", "energy_J"]
    named = [(n, parameter(n), parameter_unit_label(parameter(n), units)) for n in path.names]
    named = [(n, p, lab) for n, p, lab in named if lab is not None]
    extra_cols += [f"value_{n}_{unit_suffix(lab)}" for n, _p, lab in named]
    out = []
    for row, pt in zip(rows, data["points"]):
        ph = pt["physical"]
        out.append(list(row) + [ph["tip"]["x"], ph["tip"]["y"], ph["energy_J"]]
                   + [parameter_physical(p, pt["values"][n], units) for n, p, _lab in named])
    text = f"tip_x_{u}, tip_y_{u} in {u}; energy_J in J" + "".join(
        f"; value_{n}_{unit_suffix(lab)} in {lab}" + (" (mu0 H)" if lab == "mT" else "")
        for n, _p, lab in named)
    return cols + extra_cols, out, text
