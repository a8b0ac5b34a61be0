"""Configuration files → validated models → the dimensionless :class:`~actuator_design.scene.Scene`.

A configuration is YAML (or the equivalent dict) with the top-level keys ``scene`` (required),
``solver``, ``name`` and ``description``. Every mapping is validated by a pydantic model that rejects
unknown keys; ``type:`` tags pick variants (discriminated unions). Any failure becomes a one-line
:class:`ConfigError` whose message starts with the dotted path of the offending field, e.g.
``scene.rod.length: must be > 0, got -1 mm``.

Values with units are read by :func:`actuator_design.units.parse_quantity`: write ``"27.5 mm"``,
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
from .base import Angle, Number, Positive, Q, StrictModel, tagged
from .checks import (check_mesh, check_profiles_at, check_profiles_on_mesh, check_scene_and_options,
                     check_scene_groups)
from .dimensionless import DimensionlessScene
from .errors import ConfigError
from .field_specs import (DimensionlessField, DipoleSpec, ExpressionSpec, ForceXY, LengthXY,
                          LineLoadXY, NumberXY, PhysicalDipole, PhysicalExpression, PhysicalField,
                          PhysicalUniform, UniformSpec)
from .limits import GROUP_RANGES, MAX_BANDED_ENTRIES, MAX_DENSE_UNKNOWNS
from .model import Config, SceneSpec, SolverSpec, load_config, load_scene
from .magnetic_specs import Magnetics, MagneticSummary, Particles
from .physical import Clamp, Loads, PhysicalScene, Rod, Weight, magnetic_group, remanent_group
from .profile_specs import (FibreConstant, FibreExpression, FibreProfile, FibreTable,
                            StiffnessConstant, StiffnessExpression, StiffnessProfile, StiffnessTable)

__all__ = ["ConfigError", "Config", "load_config", "load_scene", "magnetic_group", "StrictModel",
           "check_scene_groups", "check_mesh", "check_profiles_at", "check_profiles_on_mesh",
           "check_scene_and_options", "GROUP_RANGES", "MAX_BANDED_ENTRIES", "MAX_DENSE_UNKNOWNS"]
