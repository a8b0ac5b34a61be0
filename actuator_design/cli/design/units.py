"""Design outputs shared by one pose and several: the payload's unit labels, the schedule's
physical columns, the quasi-static line of a timed schedule and the closing lines and tip columns of
a hardware schedule (coil currents, a magnet's pose)."""
from __future__ import annotations

import math

from actuator_design.cli.common import InputError, bad_input
from actuator_design.physics.parameters import designable

__all__ = ["refuse_unknown_keys", "unit_labels", "add_schedule_units", "quasi_static_line", "positive_target", "closing_lines",
           "tip_columns", "finish_schedule", "path_line", "hold_path", "substeps_arg"]


def refuse_unknown_keys(study: dict, allowed, what: str = "") -> None:
    """InputError ``study.<key>: unknown key[ for <what>] (allowed: …)`` for the first key of the
    ``study:`` section (sorted) that is not in ``allowed`` (listed in its given order)."""
    unknown = sorted(set(study) - set(allowed))
    if unknown:
        raise InputError(f"study.{unknown[0]}: unknown key{' for ' + what if what else ''} "
                         f"(allowed: {', '.join(allowed)})")


def positive_target(value, scene, flag: str, dimension: str, scale: str, unit: str):
    """A target > 0 given as a number (dimensionless, in ``unit``) or, on a physical scene, as a
    quantity of ``dimension`` divided by ``scene.scales.<scale>``; None when not given."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"{flag}: expected a number or a quantity such as '0.5 mm', got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        if scene.scales is None:
            raise InputError(f"{flag}: {value!r} has units, but the scene is dimensionless "
                             f"(give a number in units of {unit})")
        from actuator_design.model.units import parse_quantity
        with bad_input():
            v = parse_quantity(value, dimension, flag) / getattr(scene.scales, scale)
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{flag}: must be a finite number > 0, got {value!r}")
    return v


def unit_labels(units) -> dict:
    """The ``physical.units`` of a design payload: what each added physical key is in."""
    return {"target": units.length_unit, "tip": units.length_unit, "field_mT": "mT (mu0 H)",
            "field_A_per_m": "A/m", "angle_deg": "deg", "time_s": "s"}


def add_schedule_units(payload: dict, table) -> None:
    """Add the schedule table's physical columns (field_A_per_m, field_mT, angle_deg, time_s) to
    each step of ``payload["schedule"]`` in place; the existing keys stay."""
    if table and len(table) == len(payload["schedule"]):
        extra = [{k: v for k, v in row.items() if k not in ("step", "h", "phi_rad")} for row in table]
        payload["schedule"] = [dict(s, **e) for s, e in zip(payload["schedule"], extra)]


def quasi_static_line(qs, scales=None) -> str:
    """One line: the slowest relaxation time along a timed schedule and the steps faster than it."""
    if qs is None:
        if scales is None:
            return ("  quasi-static: not checked (a dimensionless scene has no mass: give the scene in physical "
                    "units, with rod.density, to compare the steps with the rod's relaxation time)")
        if scales.mass_per_length > 0:
            return ("  quasi-static: not checked (no equilibrium at every schedule step to take the relaxation "
                    "time of: the schedule was not followed to its end)")
        return ("  quasi-static: not checked (give rod.density, and rod.damping_ratio, to compare the steps "
                "with the rod's relaxation time)")
    zeta = f"damping ratio {qs['damping_ratio']:g}" + (", assumed" if qs["damping_assumed"] else "")
    fast = qs["too_fast"]
    times = "its relaxation time" if qs["factor"] == 1 else f"{qs['factor']:g} relaxation times"
    verdict = (f"every step lasts at least {times}" if not fast else
               f"{len(fast)} step(s) shorter than {times} (the first: step {fast[0]['step']}, "
               f"{fast[0]['duration_s']:.3g} s): the rod lags the field there")
    lag = qs.get("largest_tip_lag", math.nan)
    trail = ("" if not (math.isfinite(lag) and lag > 0) else
             f"; the tip strays from its quasi-static path by up to {lag:.3g} rod lengths "
             f"({qs['largest_tip_lag_m'] * 1e3:.3g} mm, step {qs['tip_lag_step']}: the slowest mode driven along the steps)")
    return (f"  quasi-static: slowest relaxation time {qs['slowest_relaxation_time_s']:.3g} s (step {qs['step']}; "
            f"{zeta}); {verdict}{trail}")


def closing_lines(res, solves: str = "", path=None) -> list:
    """The last lines of a hardware schedule's text: the quasi-static line, the path's (``path``:
    the payload's, None: not asked), the note, the time (with ``solves``, e.g. " (1532 solves)")
    and the result."""
    lines = [] if res.verification is None else [quasi_static_line(res.quasi_static, res.verification.scene.scales)]
    lines += [] if path is None else [path_line(path)]
    return lines + [f"  note: {res.message}", f"  time: {res.timings.get('total', float('nan')):.2f} s{solves}",
                    f"  RESULT: {'SUCCESS' if res.success else res.status.upper()}"]


def tip_columns(state, units) -> dict:
    """A schedule step's replayed tip (rod lengths, rad; in the scene's length unit too) and its verdict."""
    row = {"tip_x": float(state.tip["x"]), "tip_y": float(state.tip["y"]), "tip_angle_rad": float(state.tip["angle"]),
           "stable": state.stable}
    if units is not None:
        row[f"tip_x_{units.length_unit}"] = units.length(state.tip["x"])
        row[f"tip_y_{units.length_unit}"] = units.length(state.tip["y"])
    return row


def finish_schedule(args, res, payload: dict, files, summary) -> int:
    """Write ``files()`` to ``--out`` (all or nothing), print the payload (``--json``) or the lines of
    ``summary(res, payload)``, and return the exit code of a hardware schedule: 0 verified, 4 a
    waypoint out of reach, 3 otherwise."""
    from actuator_design.cli.common import print_written, write_out
    from actuator_design.io.save import dumps_json

    written = write_out(args.out, files(), args.json) if args.out is not None else None
    if args.json:
        print(dumps_json(payload))
    else:
        for line in summary(res, payload):
            print(line)
    if written is not None:
        print_written(written, args.json)
    if res.success:
        return 0
    return 4 if res.status == "unreachable" else 3


def hold_path(res, waypoints, tolerance, payload: dict) -> None:
    """With a path tolerance (rod lengths; None: none), hold ``res`` to the path through the
    waypoints (:func:`~actuator_design.schedules.path_corridor.hold_to_path`) and add ``path`` to
    ``payload`` (with the success, status and message the check may have changed)."""
    if tolerance is None:
        return
    from actuator_design.schedules.path_corridor import hold_to_path

    payload["path"] = hold_to_path(res, waypoints, tolerance)
    payload.update({k: getattr(res, k) for k in ("success", "status", "message") if hasattr(res, k)})


def path_line(path: dict) -> str:
    """One line: the tip's largest distance from the path through the waypoints, against the tolerance."""
    if path["largest_deviation"] is None:
        return f"  path: not checked (no replayed state at every step), tolerance {path['tolerance']:.3g} rod lengths"
    verdict = "within" if path["within"] else "BEYOND"
    return (f"  path: the tip stays within {path['largest_deviation']:.3g} rod lengths of the path through the "
            f"waypoints (largest at step {path['step']}), {verdict} the tolerance {path['tolerance']:.3g}")


def substeps_arg(args, study: dict) -> int:
    """Schedule steps per move from ``--substeps`` or the study's ``substeps`` (default 8), in [1, 200]."""
    name = "--substeps" if args.substeps is not None else "study.substeps"
    substeps = args.substeps if args.substeps is not None else study.get("substeps", 8)
    if not (isinstance(substeps, int) and 1 <= substeps <= 200):
        raise InputError(f"{name}: must be a whole number in [1, 200], got {substeps!r}")
    return substeps


def vary_help() -> str:
    """``design --vary``'s help: the lens's designable variables, a profile as a Legendre series."""
    def text(p):
        return f"{p.description.replace('constant ', '')} as a profile {p.slot}(s)" if p.per_point else p.description
    return ("design variables, comma separated from: "
            + ", ".join(f"{n} ({text(p)})" for n, p in designable().items())
            + "; a profile is a Legendre series of --alpha-terms terms; default: h,phi, adding alpha "
              "automatically when needed (a remanent rod: (h,)phi, then its own profile instead of alpha)")


def profile_terms_help(default: int) -> str:
    """``design --alpha-terms``' help: the Legendre terms of every profile a design can vary."""
    profiles = ", ".join(f"{p.slot}(s)" for p in designable().values() if p.per_point)
    return f"Legendre terms of each designed profile ({profiles}; default {default})"
