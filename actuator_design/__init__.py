"""actuator-design: equilibria, stability and design of magneto-elastic soft actuators.

The package's face: ``import actuator_design as ad`` gives the scene, the configuration reader,
every analysis and the result types under one name::

    import actuator_design as ad

    r = ad.solve(ad.default_scene(h=1.5, phi=1.5708))      # a stable buckled state
    d = ad.design((0.3, 0.5))                               # the main job
    cfg = ad.load_config("configs/strip.yaml")              # a YAML study / scene

Names are resolved on first use (PEP 562), so ``import actuator_design`` stays cheap (the CLI's
``--version`` imports it) and loads CasADi, SciPy and matplotlib only when an analysis is used.
Units: everything is dimensionless (THEORY §5) unless a scene is physical; see each function.
"""
from __future__ import annotations

import importlib
from typing import Dict, Tuple

from actuator_design.physics import TERM_CLASSES

__version__ = "0.1.0"

#: Public name → (module, attribute). Every name here is part of the API users' scripts rely on.
_EXPORTS: Dict[str, Tuple[str, str]] = {
    # the model: scenes, fields, options, configuration
    "Scene": ("model.scene", "Scene"),
    "default_scene": ("model.scene", "default_scene"),
    "UniformField": ("model.scene", "UniformField"),
    "DipoleField": ("model.scene", "DipoleField"),
    "ExpressionField": ("model.scene", "ExpressionField"),
    "SourceField": ("model.scene", "SourceField"),
    "MagnetSource": ("model.field_sources", "MagnetSource"),
    "CoilSource": ("model.field_sources", "CoilSource"),
    "source_field": ("model.field_sources", "source_field"),
    "constant_profile": ("model.profiles", "constant_profile"),
    # obstacles the rod can touch (contact)
    "Wall": ("contact.obstacles", "Wall"),
    "Peg": ("contact.obstacles", "Peg"),
    "Polygon": ("contact.obstacles", "Polygon"),
    "Lumen": ("contact.obstacles", "Lumen"),
    "SolverOptions": ("equilibrium.options", "SolverOptions"),
    "load_config": ("config.model", "load_config"),
    "load_scene": ("config.model", "load_scene"),
    # the energy terms
    "EnergyTerm": ("physics.term_protocol", "EnergyTerm"),
    "build_terms": ("physics.registry", "build_terms"),
    # writing a term of your own (the shipped extra terms are written this way)
    "register_term": ("physics.registry", "register_term"),
    "plugin_parameter": ("physics.parameters", "plugin_parameter"),
    "term_class": ("physics.registry", "term_class"),
    # analyses
    "solve": ("equilibrium.pipeline", "solve"),
    "equilibria": ("analysis.equilibria", "find_equilibria"),
    # (the continuation engine's own ``continuation`` cannot be ad.continuation: that name is the
    # subpackage actuator_design.continuation, bound on the package when it is imported)
    "continue_branch": ("continuation.follow", "continue_branch"),
    "critical_points": ("continuation.critical", "critical_points"),
    "follow_path": ("continuation.loading", "follow_path"),
    "tip_stiffness": ("analysis.stiffness", "tip_stiffness"),
    "design": ("inverse.design", "design"),
    "design_poses": ("inverse.poses", "design_poses"),
    "design_contact_force": ("contact.design", "design_contact_force"),
    "design_currents": ("hardware.current_design", "design_currents"),
    "design_pose": ("hardware.pose_design", "design_pose"),
    "design_current_shape": ("hardware.current_shape", "design_current_shape"),
    "design_pose_shape": ("hardware.pose_shape", "design_pose_shape"),
    "design_current_stiffness": ("hardware.current_stiffness", "design_current_stiffness"),
    "design_pose_stiffness": ("hardware.pose_stiffness", "design_pose_stiffness"),
    "field_schedule": ("schedules.schedule", "field_schedule"),
    "optimal_schedule": ("schedules.schedule_ocp", "optimal_schedule"),
    "current_schedule": ("schedules.current_schedule", "current_schedule"),
    "RateLimits": ("schedules.schedule_ocp", "RateLimits"),
    "DesignSettings": ("inverse.settings", "DesignSettings"),
    "Tolerances": ("robust.tolerances", "Tolerances"),
    "fit": ("calibration", "fit"),
    "prepare_fit": ("calibration", "prepare_fit"),
    "plan_study": ("study.runner", "plan_study"),
    "run_study": ("study.runner", "run_study"),
    # result types
    "EquilibriumResult": ("equilibrium.result", "EquilibriumResult"),
    "EquilibriaResult": ("analysis.equilibria", "EquilibriaResult"),
    "DesignResult": ("inverse.settings", "DesignResult"),
    "ScheduleResult": ("schedules.schedule", "ScheduleResult"),
    "OptimalSchedule": ("schedules.schedule_ocp", "OptimalSchedule"),
    "CurrentDesign": ("hardware.current_design", "CurrentDesign"),
    "PoseDesign": ("hardware.pose_design", "PoseDesign"),
    "CurrentShapeDesign": ("hardware.current_shape", "CurrentShapeDesign"),
    "PoseShapeDesign": ("hardware.pose_shape", "PoseShapeDesign"),
    "CurrentStiffnessDesign": ("hardware.current_stiffness", "CurrentStiffnessDesign"),
    "PoseStiffnessDesign": ("hardware.pose_stiffness", "PoseStiffnessDesign"),
    "CurrentSchedule": ("schedules.current_schedule", "CurrentSchedule"),
    "FitResult": ("calibration", "FitResult"),
    "StudyReport": ("study.runner", "StudyReport"),
    # saved results read back
    "read_result": ("io.saved", "read_result"),
    "scene_from_dict": ("io.saved", "scene_from_dict"),
    "SavedResult": ("io.saved", "SavedResult"),
}
# the built-in energy term classes, as the physics room lists them (ad.Bending, ad.TipForce, …)
_EXPORTS.update((name, ("physics", name)) for name in TERM_CLASSES)

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    try:
        module, attribute = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'actuator_design' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f".{module}", __name__), attribute)
    globals()[name] = value  # resolved once
    return value


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
