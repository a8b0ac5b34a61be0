"""Load and check a configuration without solving, and summarise the scene it describes.

Prints the dimensionless groups (h, h^2, phi, p, h_r, ...), the energy terms that will be built, the
fibre, magnetisation and stiffness profiles, the solver settings and, for physical scenes, the
scales that convert results to SI units and the magnetic numbers: particle-only and effective
susceptibilities (the body's demagnetisation, THEORY §10), saturation (§11), remanence (§9). A field
that exerts no force on the rod is explained, not reported as silently valid. User expression fields are checked to be divergence- and curl-free over the
disc of radius l the rod can reach.

Units: lengths in rod lengths l, energies in B0/l, forces in B0/l^2; angles in degrees (and rad).
"""
from __future__ import annotations

import argparse
import math

from actuator_design.cli.common import EXIT_OK, load_config

__all__ = ["HELP", "add_args", "run", "describe"]

HELP = "check a configuration (no solve) and summarise its scene"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``validate``."""
    parser.add_argument("config", metavar="CONFIG.yaml", help="scene and solver configuration (YAML)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (scene, groups, terms, solver) instead of text")


def run(args: argparse.Namespace) -> int:
    """Run ``validate``: load, check the field, print the summary."""
    scene, options, raw = load_config(args.config)
    from actuator_design.physics.registry import build_terms
    terms = [t.name for t in build_terms(scene)]
    summary = _magnetics_summary(raw)
    notes = list(summary.notes) if summary is not None else []
    zero = zero_coupling(scene)
    if zero:
        notes.append(zero)
    if args.json:
        from actuator_design.io.save import dumps_json, scene_to_dict
        out = {"valid": True, "config": str(args.config), "scene": scene_to_dict(scene),
               "groups": scene.describe_groups(), "terms": terms, "solver": options.as_dict()}
        if scene.magnetization is not None:
            out["magnetization"] = scene.magnetization.as_dict()
        if summary is not None:
            out["magnetics"] = _summary_dict(summary)
        out["notes"] = notes
        print(dumps_json(out))
    else:
        from actuator_design.io.user_units import user_units
        print(describe(scene, options, terms, source=args.config, summary=summary,
                       notes=[n for n in notes if n != zero], units=user_units(scene, raw)))
    return EXIT_OK


def _magnetics_summary(raw):
    """The physical scene's magnetic numbers (None for dimensionless scenes or no magnetics)."""
    from actuator_design.config import load_config as load_model
    from actuator_design.config.physical import PhysicalScene

    import warnings
    with warnings.catch_warnings():  # already issued once while loading
        warnings.simplefilter("ignore")
        model = load_model(raw)
    return model.scene.magnetics_summary() if isinstance(model.scene, PhysicalScene) else None


def _summary_dict(m) -> dict:
    return {"chi_bar": m.chi_bar, "chi_hat": m.chi_hat, "particle_chi_bar": m.particle_chi_bar,
            "particle_chi_hat": m.particle_chi_hat, "effective_fibre_angle": m.fibre_angle,
            "demagnetizing_factor": m.demagnetizing_factor, "chi_max": m.chi_max,
            "saturation_A_per_m": m.saturation, "remanence_A_per_m": m.remanence}


def zero_coupling(scene) -> str:
    """Why the scene's field exerts no force or torque on the rod, or ``""`` when it does."""
    if scene.field is None:
        return ""
    hard = scene.magnetization is not None and scene.h_r != 0.0
    positional = not scene.field.is_uniform and scene.h_pos != 0.0
    if scene.h != 0.0 or hard or positional:
        return ""
    why = "h = 0" + (", h_r = 0" if scene.magnetization is not None else "")
    if scene.field.is_uniform:
        why += " (in a uniform field the chi_hat term is a constant)"
    return f"the field exerts no force or torque on the rod: {why}; the rod stays as the loads leave it"


def describe(scene, options, terms, source: str = "", summary=None, notes=(), units=None) -> str:
    """A readable multi-line summary of a validated scene (no solve); ``summary`` is the physical
    scene's :class:`~actuator_design.config.magnetic_specs.MagneticSummary`, ``notes`` the reasons
    and warnings to print, ``units`` a physical scene's :class:`~actuator_design.io.user_units.UserUnits`
    (obstacles in its length unit)."""
    from actuator_design.model.scene import DipoleField, ExpressionField, UniformField

    groups = f"h = {scene.h:.6g}, h^2 = {scene.h ** 2:.6g}"
    if isinstance(scene.field, UniformField):
        groups += f", phi = {math.degrees(scene.field.phi):.6g} deg ({scene.field.phi:.6g} rad)"
    if scene.field is not None and not scene.field.is_uniform:
        groups += f", h_pos = {scene.h_pos:.6g}"
    if scene.magnetization is not None:
        groups += f", h_r = {scene.h_r:.6g}"
    if scene.tip_force is not None:
        groups += f", p = {scene.p:.6g}"
    field = scene.field
    if field is None:
        field_text = "none (no magnetic term)"
    elif isinstance(field, UniformField):
        field_text = f"uniform, direction phi = {math.degrees(field.phi):.6g} deg"
    elif isinstance(field, DipoleField):
        field_text = (f"dipole at (x0, y0) = ({field.x0:.6g}, {field.y0:.6g}) l, moment at "
                      f"{math.degrees(field.moment_angle):.6g} deg")
    elif isinstance(field, ExpressionField):
        field_text = f"expression hx = {field.hx}, hy = {field.hy} (div- and curl-free: checked)"
    elif hasattr(field, "describe"):
        field_text = field.describe()
    else:  # pragma: no cover - future field kinds
        field_text = getattr(field, "kind", type(field).__name__)
    loads = []
    if scene.tip_force is not None:
        loads.append(f"tip force (fx, fy) = ({scene.tip_force[0]:.6g}, {scene.tip_force[1]:.6g}) B0/l^2")
    if scene.tip_moment is not None:
        loads.append(f"tip moment {scene.tip_moment:.6g} B0/l")
    if scene.distributed_load is not None:
        q = scene.distributed_load
        loads.append(f"distributed load (qx, qy) = ({q[0]:.6g}, {q[1]:.6g}) B0/l^3")
    o = options
    lines = [
        f"config      : {source}" if source else None,
        f"scene       : {scene.name}",
        f"groups      : {groups}",
        f"field       : {field_text}",
        (f"obstacles   : {_obstacles_text(scene, units)} (contact, frictionless)" if scene.obstacles else None),
        f"loads       : {'; '.join(loads) or 'none'}",
        f"clamp angle : {math.degrees(scene.theta0):.6g} deg",
        f"fibres      : {_profile(scene.fibres, 'alpha', deg=True)}",
        (f"magnetisation: remanent, {_profile(scene.magnetization, 'beta', deg=True)}"
         if scene.magnetization is not None else None),
        _magnetics_line(summary),
        f"stiffness   : {_profile(scene.stiffness, 'b')}",
        f"terms       : {', '.join(terms)}",
        f"solver      : {o.transcription} (elements {o.elements}"
        + (f", degree {o.degree}" if o.transcription == "lgl" else "")
        + f"), {o.method}, tol {o.tol:g}, max_iter {o.max_iter}, ensure_stable {o.ensure_stable}",
        f"scales      : {_scales(scene.scales)}",
        *[f"note        : {n}" for n in notes],
        ("valid       : yes, but " + zero_coupling(scene) if zero_coupling(scene)
         else "valid       : yes (configuration checked; nothing solved)"),
    ]
    return "\n".join(line for line in lines if line is not None)


def _obstacles_text(scene, units) -> str:
    """The obstacles and the gap the rod keeps from them, in rod lengths or the user's length unit."""
    scale, unit = (1.0, "l") if units is None else (units.length(1.0), units.length_unit)
    return (f"{'; '.join(ob.describe(scale, unit) for ob in scene.obstacles)}; the rod keeps "
            f"{scale * scene.contact_gap:.4g} {unit} from them")


def _profile(profile, name: str, deg: bool = False) -> str:
    d = profile.as_dict()
    if d["type"] == "constant":
        v = d["value"]
        return f"constant {name} = {math.degrees(v):.6g} deg" if deg else f"constant {name} = {v:.6g}"
    if d["type"] == "table":
        unit = " (rad)" if deg else ""
        return f"table of {len(d['s'])} points{unit}, linear interpolation in s"
    return f"{name}(s) = {d['expression']}" + (" (rad)" if deg else "")


def _magnetics_line(m):
    if m is None:
        return None
    out = f"magnetics   : chi_bar = {m.chi_bar:.6g}, chi_hat = {m.chi_hat:.6g}"
    if m.particle_chi_bar is not None:
        out += f" (particles only: chi_bar = {m.particle_chi_bar:.6g}, chi_hat = {m.particle_chi_hat:.6g})"
    if m.demagnetizing_factor is not None:
        out += f", body N_t = {m.demagnetizing_factor:.6g}"
    if m.fibre_angle is not None:
        out += f", effective fibre angle = {math.degrees(m.fibre_angle):.6g} deg"
    if m.saturation is not None:
        out += f", saturation nu M_s = {m.saturation:.6g} A/m"
    if m.remanence is not None:
        out += f", remanence M_r = {m.remanence:.6g} A/m"
    return out


def _scales(scales) -> str:
    if scales is None:
        return "none (dimensionless scene)"
    return (f"l = {scales.length:.6g} m, B0 = {scales.bending_stiffness:.6g} N m^2, "
            f"H0 = {scales.field:.6g} A/m, force B0/l^2 = {scales.force:.6g} N, "
            f"energy B0/l = {scales.moment:.6g} J")
