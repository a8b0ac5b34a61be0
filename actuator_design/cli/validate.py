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
    from actuator_design.physics.registry import build_terms, describe_groups
    terms = [t.name for t in build_terms(scene)]
    summary = _magnetics_summary(raw)
    notes = list(summary.notes) if summary is not None else []
    zero = zero_coupling(scene)
    if zero:
        notes.append(zero)
    reach = getattr(scene.field, "reach_note", lambda: None)()  # (a point dipole within the rod's reach)
    if reach and not scene.obstacles:
        notes.append(reach + " once the field is strong enough to pull it in")
    if args.json:
        from actuator_design.io.save import dumps_json, scene_to_dict
        out = {"valid": True, "config": str(args.config), "scene": scene_to_dict(scene),
               "groups": describe_groups(scene), "terms": terms, "solver": options.as_dict()}
        for said in _summaries(scene):  # the profiles terms carry (a remanent β(s): "magnetization")
            if said.profile is not None:
                out[said.profile.key] = said.profile.profile.as_dict()
        if summary is not None:
            out["magnetics"] = summary.as_dict()
        out["notes"] = notes
        print(dumps_json(out))
    else:
        from actuator_design.io.user_units import user_units
        print(describe(scene, options, terms, source=args.config, summary=summary,
                       notes=[n for n in notes if n != zero], units=user_units(scene, raw)))
    return EXIT_OK


def _magnetics_summary(raw):
    """The physical scene's magnetic numbers (None for dimensionless scenes or no magnetics)."""
    import warnings

    from actuator_design.config import load_config as load_model
    from actuator_design.config.physical import PhysicalScene
    with warnings.catch_warnings():  # already issued once while loading
        warnings.simplefilter("ignore")
        model = load_model(raw)
    return model.scene.magnetics_summary() if isinstance(model.scene, PhysicalScene) else None


def _summaries(scene):
    """What every registered term says of ``scene`` (``EnergyTerm.summary``), in registration order."""
    from actuator_design.physics.registry import registered_terms

    return [cls.summary(scene) for cls in registered_terms()]


def zero_coupling(scene) -> str:
    """Why the scene's field exerts no force or torque on the rod, or ``""`` when it does."""
    if scene.field is None:
        return ""
    from actuator_design.physics import parameters as lens
    from actuator_design.physics.registry import term_class

    # the groups the field drives besides its magnitude (h_pos, h_r), of the terms the scene has
    driven = [p for p in lens.parameters().values() if p.field_power and not p.field_magnitude and not p.per_point
              and (p.term is None or term_class(p.term).present(scene))]
    if scene.h != 0.0 or any(p.get(scene) != 0.0 for p in driven):
        return ""
    why = "h = 0" + "".join(f", {p.name} = 0" for p in driven)
    if scene.field.is_uniform:
        why += " (in a uniform field the isotropic-susceptibility term, proportional to |H|^2, is a constant)"
    return f"the field exerts no force or torque on the rod: {why}; the rod stays as the loads leave it"


def describe(scene, options, terms, source: str = "", summary=None, notes=(), units=None) -> str:
    """A readable multi-line summary of a validated scene (no solve); ``summary`` is the physical
    scene's :class:`~actuator_design.physics.magnetics_block.MagneticSummary`, ``notes`` the reasons
    and warnings to print, ``units`` a physical scene's :class:`~actuator_design.io.user_units.UserUnits`
    (obstacles in its length unit)."""
    from actuator_design.model.scene import DipoleField, ExpressionField, UniformField

    said = _summaries(scene)
    groups = f"h = {scene.h:.6g}, h^2 = {scene.h ** 2:.6g}"
    if isinstance(scene.field, UniformField):
        groups += f", phi = {math.degrees(scene.field.phi):.6g} deg ({scene.field.phi:.6g} rad)"
    groups += "".join(f", {name} = {value:.6g}" for s in said for name, value in s.groups)
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
    loads = [s.load for s in said if s.load]
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
        *[f"{s.profile.label}, {_profile(s.profile.profile, s.profile.symbol, deg=s.profile.angle)}"
          for s in said if s.profile is not None],
        summary.line() if summary is not None else None,
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


def _scales(scales) -> str:
    if scales is None:
        return "none (dimensionless scene)"
    return (f"l = {scales.length:.6g} m, B0 = {scales.bending_stiffness:.6g} N m^2, "
            f"H0 = {scales.field:.6g} A/m, force B0/l^2 = {scales.force:.6g} N, "
            f"energy B0/l = {scales.moment:.6g} J")
