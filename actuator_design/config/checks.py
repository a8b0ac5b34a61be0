"""Checks of a scene against the solver settings that will discretise it, shared by the config
layer and the command line (whose flags may change the scene and the mesh after loading).

* every dimensionless group in its range (:mod:`actuator_design.config.limits`);
* the mesh within the memory budget for the scene's Hessian structure (dense in a non-uniform field or with a term that couples every node);
* expression profiles (fibre angle, stiffness) finite — and stiffness positive — on the
  transcription's own nodes and quadrature points, where the solver evaluates them (a function that
  is NaN only near a collocation node passes a check on a uniform grid).
"""
from __future__ import annotations

from typing import Mapping, Tuple

import numpy as np

from actuator_design.config.errors import ConfigError
from actuator_design.config.limits import group_problem, mesh_problem, scene_group_values
from actuator_design.config.profile_specs import profile_problem
from actuator_design.model.scene import profile_fields
from actuator_design.physics.registry import dense_hessian
from actuator_design.transcription import make_transcription

__all__ = ["check_scene_groups", "check_mesh", "check_profiles_at", "check_profiles_on_mesh",
           "check_scene_and_options"]

def check_scene_groups(scene, prefix: str = "") -> None:
    """Every group of ``scene`` (a :class:`~actuator_design.model.scene.Scene`) within its range.

    Raises
    ------
    ConfigError
        ``"<prefix><group>: must be a finite number in [lo, hi], got ..."``.
    """
    for name, value in scene_group_values(scene):
        problem = group_problem(name, float(value))
        if problem is not None:
            raise ConfigError(f"{prefix}{name}", problem)


def _is_dense(scene) -> bool:
    """A non-uniform field, or a plug-in term that couples every node (``EnergyTerm.dense_hessian``)."""
    if scene.field is not None and not scene.field.is_uniform:
        return True
    if not scene.extra_terms:
        return False

    return dense_hessian(scene)


def check_mesh(options, scene=None, field: str = "elements") -> None:
    """The mesh of ``options`` (a :class:`~actuator_design.equilibrium.options.SolverOptions`) within the memory
    budget; the stricter dense bound when ``scene`` has a non-uniform field.

    Raises
    ------
    ConfigError
        Named ``field`` (e.g. ``"solver.elements"`` or ``"--elements"``).
    """
    if getattr(options, "accuracy", None) is not None:
        return  # the resolution is chosen by the accuracy driver, within its own bounds
    problem = mesh_problem(options.transcription, options.elements, options.degree,
                           dense=scene is not None and _is_dense(scene), tol=options.tol)
    if problem is not None:
        raise ConfigError(field, problem.removeprefix("elements "))


def check_profiles_at(profiles: Mapping[str, Tuple[object, bool]], options) -> None:
    """Expression profiles finite (and > 0 where asked) at the nodes and quadrature points of the
    transcription that ``options`` (a :class:`~actuator_design.equilibrium.options.SolverOptions`) names.

    Parameters
    ----------
    profiles : mapping
        Field name to report → ``(Profile, positive)``.
    options : SolverOptions

    Raises
    ------
    ConfigError
        Named by the mapping's key, giving the first bad value and its arc length s.
    """
    wanted = {k: v for k, v in profiles.items() if v[0] is not None and v[0].kind == "expression"}
    if not wanted:
        return

    tr = make_transcription(options)
    s = np.concatenate([np.asarray(tr.nodes, float), np.asarray(tr.quadrature_points, float)])
    for name, (profile, positive) in wanted.items():
        problem = profile_problem(profile, s, positive)
        if problem is not None:
            raise ConfigError(name, f"{profile.expression[:60]!r} {problem} (a point where the "
                                    f"{options.transcription} transcription evaluates it)")


def check_profiles_on_mesh(scene, options, prefix: str = "") -> None:
    """:func:`check_profiles_at` for the fibre and stiffness profiles of a Scene."""
    # every profile of the scene (the fibres, the stiffness, a term's); only the stiffness must be positive
    check_profiles_at({f"{prefix}{name}.expression": (getattr(scene, name), name == "stiffness")
                       for name in profile_fields()}, options)


def check_scene_and_options(scene, options, prefix: str = "") -> None:
    """All three checks above, naming fields with ``prefix`` (e.g. ``"scene."``)."""
    check_scene_groups(scene, prefix)
    check_mesh(options, scene, f"{prefix}elements" if prefix else "elements")
    check_profiles_on_mesh(scene, options, prefix)
