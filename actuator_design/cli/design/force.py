"""``design --target-force F``: the field at which the rod, loaded from rest, presses an obstacle of
its scene with a given force (a gripper finger on an object): :func:`~actuator_design.contact.design.design_contact_force`, printed in the scene's units and written as design.json,
shape.csv and shape.png."""
from __future__ import annotations

import math

from actuator_design.cli.common import (EXIT_NOT_VERIFIED, EXIT_OK, EXIT_UNREACHABLE, InputError, bad_input,
                                        stdout_to_stderr)
from actuator_design.cli.design.units import positive_target
from actuator_design.cli.common import emit

__all__ = ["parse_force", "run_force", "state_files"]


def parse_force(value, scene):
    """A dimensionless force (units of B0/l^2) or a quantity in N (physical scenes), or None."""
    return positive_target(value, scene, "--target-force", "force", "force", "B0/l^2")


def run_force(args, scene, options, raw, force: float, settings, units) -> int:
    """Design, print, write; exit 0 success, 3 not verified, 4 unreachable."""
    from actuator_design.contact.design import design_contact_force

    if not scene.obstacles:
        raise InputError("--target-force: the scene has no obstacles to press (scene.obstacles)")
    k = 0 if args.obstacle is None else args.obstacle
    if not 0 <= k < len(scene.obstacles):
        raise InputError(f"--obstacle: an index in [0, {len(scene.obstacles) - 1}] (scene.obstacles), got {k}")
    with stdout_to_stderr(args.json), bad_input():
        res = design_contact_force(scene, force, obstacle=k, h_max=settings.h_max, options=options,
                                   tolerances=settings.tolerances)
    payload = _payload(res, units)
    emit(args, res, lambda: _files(res, payload), lambda r: _summary(r, units), payload=payload)
    if res.success:
        return EXIT_OK
    return EXIT_UNREACHABLE if res.status == "unreachable" else EXIT_NOT_VERIFIED


def _payload(res, units) -> dict:
    d = res.to_dict()
    if units is not None and math.isfinite(res.h) and units.h_per_field > 0:
        d.setdefault("physical", {}).update(field_mT=units.field_mT(res.h), field_A_per_m=units.field_A_per_m(res.h))
    return d


def _summary(res, units) -> str:
    force = (lambda f: f"{f * units.force_scale:.6g} N") if units is not None else (lambda f: f"{f:.6g} B0/l^2")
    field = f"h = {res.h:.8g}" + (f" (mu0 H = {units.field_mT(res.h):.6g} mT)" if units is not None and
                                  math.isfinite(res.h) and units.h_per_field > 0 else "")
    lines = ["actuator-design: design for a contact force",
             f"  target      : {force(res.target)} on obstacle {res.obstacle}"]
    if math.isfinite(res.h):
        lines += [f"  design      : {field}",
                  f"  achieved    : {force(res.force)}; from rest {force(res.verification_force)} "
                  f"(verified {res.verified})",
                  f"  robustness  : over the box {force(res.box_force_range[0])} to {force(res.box_force_range[1])}"
                  f"; pressed and stable at every corner: {res.holds_over_box}"]
    lines += [f"  note        : {res.message}",
              f"  RESULT      : {'SUCCESS' if res.success else res.status.upper()}"]
    return "\n".join(lines)


def _files(res, payload) -> dict:
    return state_files(payload, res.state, "designed contact state")


def state_files(payload: dict, state, title: str) -> dict:
    """design.json, and the designed state's shape.csv and shape.png when it converged."""
    from actuator_design.io.save import dumps_json, shape_csv_text
    from actuator_design.viz.shape import plot_shape
    from actuator_design.viz.style import png_bytes

    files = {"design.json": dumps_json(payload, indent=1) + "\n"}
    if state is not None and state.success:
        files["shape.csv"] = shape_csv_text(state)
        files["shape.png"] = png_bytes(plot_shape(state, title=title), dpi=150)
    return files
