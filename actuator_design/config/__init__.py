"""Configuration files → validated models → the dimensionless :class:`~actuator_design.model.scene.Scene`.

A configuration is YAML (or the equivalent dict) with the top-level keys ``scene`` (required),
``solver``, ``name`` and ``description``. Every mapping is validated by a pydantic model that rejects
unknown keys; ``type:`` tags pick variants (discriminated unions). Any failure becomes a one-line
:class:`ConfigError` whose message starts with the dotted path of the offending field, e.g.
``scene.rod.length: must be > 0, got -1 mm``.

Values with units are read by :func:`actuator_design.model.units.parse_quantity`: write ``"27.5 mm"``,
``"2.25 MPa"``, ``"5 kA/m"`` or ``"10 mT"`` (H = B/μ0), ``"30 deg"``. A plain number is in SI base
units, except angles: a plain number is radians and must lie in [-2π, 2π].

Modules (one job each)
----------------------
errors         ConfigError and the translation of pydantic errors into dotted field paths
base           the strict base model, quantity fields ``Q``, ``type:``-tagged unions
limits         valid ranges of the dimensionless groups and of the mesh size (memory budget)
checks         checks of a scene against the mesh that discretises it (also used by the CLI)
yaml_source    bounded YAML reading: file size, UTF-8, nesting, aliases, duplicate keys
profile_specs  fibre angle and stiffness profiles (constant, table, expression)
field_specs    vectors and applied fields (uniform, dipole, expression), dimensionless and physical
dimensionless  the ``type: dimensionless`` scene (THEORY §5 groups given directly)
physical       the ``type: physical`` scene (SI quantities, non-dimensionalised by ℓ, B0, H0)
model          the top-level Config, SolverSpec, load_config and load_scene
"""
import importlib

#: Each public name and the module that defines it: loaded on first use (PEP 562), so that
#: importing one module of the package (e.g. ``config.limits`` during a design) does not build
#: every pydantic model (0.13 s at start-up).
_HOME = {
    "FibreConstant": "profile_specs",
    "FibreExpression": "profile_specs",
    "FibreProfile": "profile_specs",
    "FibreTable": "profile_specs",
    "StiffnessConstant": "profile_specs",
    "StiffnessExpression": "profile_specs",
    "StiffnessProfile": "profile_specs",
    "StiffnessTable": "profile_specs",
    "Angle": "base",
    "Number": "base",
    "Positive": "base",
    "Q": "base",
    "StrictModel": "base",
    "tagged": "base",
    "check_mesh": "checks",
    "check_profiles_at": "checks",
    "check_profiles_on_mesh": "checks",
    "check_scene_and_options": "checks",
    "check_scene_groups": "checks",
    "DimensionlessScene": "dimensionless",
    "ConfigError": "errors",
    "DimensionlessField": "field_specs",
    "DipoleSpec": "field_specs",
    "ExpressionSpec": "field_specs",
    "ForceXY": "field_specs",
    "LengthXY": "field_specs",
    "LineLoadXY": "field_specs",
    "NumberXY": "field_specs",
    "PhysicalDipole": "field_specs",
    "PhysicalExpression": "field_specs",
    "PhysicalField": "field_specs",
    "PhysicalUniform": "field_specs",
    "UniformSpec": "field_specs",
    "GROUP_RANGES": "limits",
    "MAX_BANDED_ENTRIES": "limits",
    "MAX_DENSE_UNKNOWNS": "limits",
    "Config": "model",
    "SceneSpec": "model",
    "SolverSpec": "model",
    "load_config": "model",
    "load_scene": "model",
    "Clamp": "physical",
    "Magnetics": "physical",
    "MagneticSummary": "physical",
    "Particles": "physical",
    "Loads": "physical",
    "PhysicalScene": "physical",
    "Rod": "physical",
    "Weight": "physical",
    "magnetic_group": "physical",
    "remanent_group": "physical",
}


def __getattr__(name):
    if name in _HOME:
        value = getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_HOME))

__all__ = ["ConfigError", "Config", "load_config", "load_scene", "magnetic_group", "StrictModel",
           "check_scene_groups", "check_mesh", "check_profiles_at", "check_profiles_on_mesh",
           "check_scene_and_options", "GROUP_RANGES", "MAX_BANDED_ENTRIES", "MAX_DENSE_UNKNOWNS"]
