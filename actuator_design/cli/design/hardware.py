"""``design`` over hardware: which scenes are designed in coil currents or in a magnet's pose, and
the flags of those designs (:mod:`actuator_design.cli.design.currents`,
:mod:`actuator_design.cli.design.pose`)."""
from __future__ import annotations

from actuator_design.cli.common import InputError
from actuator_design.cli.design.currents import run_current_shape, run_current_stiffness, run_currents
from actuator_design.cli.design.pose import run_pose, run_pose_shape, run_pose_stiffness

__all__ = ["hardware_design", "add_hardware_args", "is_coil_scene", "has_moving_magnet", "check_position_tolerance",
           "hardware_shape"]


def add_hardware_args(parser) -> None:
    """The flags of a design over hardware (a magnet's pose)."""
    parser.add_argument("--position-tolerance", metavar="LENGTH",
                        help="a design over a magnet's pose (a magnet with a travel): half-width of the magnet's "
                             "position error in x and y, e.g. '0.5 mm' (the default; 0 for none)")


def hardware_design(args, scene, options, raw, target, vary, settings, stiffness):
    """Route a design over hardware: coil currents on a scene of coils, a magnet's pose on a scene
    with a moving magnet (one tip target, a stiffness, or both); the exit code, or None for every
    other design."""
    check_position_tolerance(args, scene)
    if stiffness is not None and not isinstance(target, list):
        if is_coil_scene(scene):
            return run_current_stiffness(args, scene, options, raw, target, vary, settings, stiffness)
        if has_moving_magnet(scene):
            return run_pose_stiffness(args, scene, options, raw, target, vary, settings, stiffness)
    if stiffness is not None or target is None or isinstance(target, list):
        return None
    if is_coil_scene(scene):
        return run_currents(args, scene, options, raw, target, vary, settings)
    if has_moving_magnet(scene):
        return run_pose(args, scene, options, raw, target, vary, settings)
    return None


def hardware_shape(args, scene, options, raw, vary, settings):
    """Route ``design --target-shape`` over hardware: the coils' currents on a scene of coils, a
    magnet's pose on a scene with a moving magnet; the exit code, or None for every other scene."""
    if is_coil_scene(scene):
        return run_current_shape(args, scene, options, raw, vary, settings)
    if has_moving_magnet(scene):
        return run_pose_shape(args, scene, options, raw, vary, settings)
    return None


def check_position_tolerance(args, scene) -> None:
    """--position-tolerance applies to a design over a magnet's pose only (InputError otherwise:
    another design would ignore it)."""
    if getattr(args, "position_tolerance", None) is not None and not has_moving_magnet(scene):
        raise InputError("--position-tolerance: applies to a design over a magnet's pose (a magnet with a "
                         "travel) only")


def has_moving_magnet(scene) -> bool:
    """Whether a magnet of the scene's field has a travel (its pose is then the design)."""
    from actuator_design.model.field_sources import MagnetSource

    f = scene.field
    return getattr(f, "kind", "") == "sources" and any(isinstance(s, MagnetSource) and s.travel for s in f.sources)


def is_coil_scene(scene) -> bool:
    """Whether the scene's field comes from coils only (their currents are then the design)."""
    from actuator_design.model.field_sources import CoilSource

    f = scene.field
    return getattr(f, "kind", "") == "sources" and all(isinstance(s, CoilSource) for s in f.sources)
