"""Load and check a configuration without solving, and summarise the scene it describes.

Prints the dimensionless groups (h, h^2, phi, p, ...), the energy terms that will be built, the
fibre and stiffness profiles, the solver settings and, for physical scenes, the scales that convert
results to SI units. User expression fields are checked to be divergence- and curl-free over the
disc of radius l the rod can reach.

Units: lengths in rod lengths l, energies in B0/l, forces in B0/l^2; angles in degrees (and rad).
"""
from __future__ import annotations

import argparse
import math

from .common import EXIT_OK, load_config

__all__ = ["HELP", "add_args", "run", "describe"]

HELP = "check a configuration (no solve) and summarise its scene"


def add_args(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``validate``."""
    parser.add_argument("config", metavar="CONFIG.yaml", help="scene and solver configuration (YAML)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (scene, groups, terms, solver) instead of text")


def run(args: argparse.Namespace) -> int:
    """Run ``validate``: load, check the field, print the summary."""
    scene, options, _ = load_config(args.config)
    from ..physics.terms import build_terms
    terms = [t.name for t in build_terms(scene)]
    if args.json:
        from ..io import dumps_json, scene_to_dict
        print(dumps_json({"valid": True, "config": str(args.config), "scene": scene_to_dict(scene),
                          "groups": scene.describe_groups(), "terms": terms,
                          "solver": options.as_dict()}))
    else:
        print(describe(scene, options, terms, source=args.config))
    return EXIT_OK


def describe(scene, options, terms, source: str = "") -> str:
    """A readable multi-line summary of a validated scene (no solve)."""
    from ..scene import DipoleField, ExpressionField, UniformField

    groups = f"h = {scene.h:.6g}, h^2 = {scene.h ** 2:.6g}"
    if isinstance(scene.field, UniformField):
        groups += f", phi = {math.degrees(scene.field.phi):.6g} deg ({scene.field.phi:.6g} rad)"
    if scene.field is not None and not scene.field.is_uniform:
        groups += f", h_pos = {scene.h_pos:.6g}"
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
        f"loads       : {'; '.join(loads) or 'none'}",
        f"clamp angle : {math.degrees(scene.theta0):.6g} deg",
        f"fibres      : {_profile(scene.fibres, 'alpha', deg=True)}",
        f"stiffness   : {_profile(scene.stiffness, 'b')}",
        f"terms       : {', '.join(terms)}",
        f"solver      : {o.transcription} (elements {o.elements}"
        + (f", degree {o.degree}" if o.transcription == "lgl" else "")
        + f"), {o.method}, tol {o.tol:g}, max_iter {o.max_iter}, ensure_stable {o.ensure_stable}",
        f"scales      : {_scales(scene.scales)}",
        "valid       : yes (configuration checked; nothing solved)",
    ]
    return "\n".join(line for line in lines if line is not None)


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
