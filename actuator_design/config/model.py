"""The top-level configuration: scene, solver, name, description and an optional study section;
reading it from YAML or a dict (:func:`load_config`) and turning it into a Scene (:func:`load_scene`).
"""
from __future__ import annotations

import copy
import warnings
from pathlib import Path
from typing import Annotated, Any, Dict, Literal, Optional, Tuple, Union

from pydantic import Field, PrivateAttr, StrictBool, StrictInt, StrictStr, ValidationError, model_validator

from actuator_design.config.base import Q, StrictModel, tagged
from actuator_design.config.checks import _is_dense, check_profiles_at
from actuator_design.config.dimensionless import DimensionlessScene
from actuator_design.config.errors import ConfigError, dotted, error, first_non_finite, translate
from actuator_design.config.field_specs import is_non_uniform
from actuator_design.config.limits import mesh_problem
from actuator_design.config.physical import PhysicalScene
from actuator_design.config.yaml_source import check_structure, read_yaml
from actuator_design.equilibrium.options import MAX_ITERATIONS, SolverOptions
from actuator_design.model.scene import ExpressionField, Scene
from actuator_design.physics.fields import FieldCheckError, check_current_free, field_model

__all__ = ["SceneSpec", "SolverSpec", "Config", "load_config", "load_scene", "validate_config"]

SceneSpec = tagged(("scene",), DimensionlessScene, PhysicalScene)

_DEFAULTS = SolverOptions()


class SolverSpec(StrictModel):
    """Maps to :class:`~actuator_design.equilibrium.options.SolverOptions`."""

    transcription: Literal["lgl", "midpoint"] = _DEFAULTS.transcription
    elements: Annotated[StrictInt, Field(ge=1)] = _DEFAULTS.elements
    degree: Annotated[StrictInt, Field(ge=2, le=60)] = _DEFAULTS.degree
    method: Literal["ipopt", "newton", "fast"] = _DEFAULTS.method
    tol: Q("dimensionless", gt=0, lt=1) = _DEFAULTS.tol
    max_iter: Annotated[StrictInt, Field(ge=1, le=MAX_ITERATIONS)] = _DEFAULTS.max_iter
    ensure_stable: StrictBool = _DEFAULTS.ensure_stable
    jit: StrictBool = False
    #: target tip accuracy (rod lengths): the cheapest resolution that meets it is chosen from an
    #: a-posteriori estimate with two resolutions (``actuator_design.equilibrium.accuracy``)
    accuracy: Optional[Q("dimensionless", gt=0, lt=1)] = None
    #: issue 10: the state reached from rest or the straight rod; the Euler–Lagrange residual asked
    #: for; mesh chosen from the scene; whether a self-intersecting shape is accepted
    start: Literal["rest", "straight"] = _DEFAULTS.start
    residual_tol: Q("dimensionless", gt=0, lt=1) = _DEFAULTS.residual_tol
    adapt: StrictBool = _DEFAULTS.adapt
    keep_self_intersecting: StrictBool = _DEFAULTS.keep_self_intersecting
    #: issue 20: a shape that would cross itself (or enter its own thickness) is solved with
    #: self-contact; false: refused as before
    self_contact: StrictBool = _DEFAULTS.self_contact

    @model_validator(mode="after")
    def _check_mesh(self):
        problem = mesh_problem(self.transcription, self.elements, self.degree, tol=self.tol)
        if problem is not None:
            raise error(problem.removeprefix("elements "), "elements")
        return self

    def to_options(self) -> SolverOptions:
        return SolverOptions(**self.model_dump())


def _dense_terms(scene) -> bool:
    """A term of the scene's ``terms:`` makes the Hessian dense (``EnergyTerm.dense_hessian``, asked
    of the scene itself); a term whose own answer fails is reported as a configuration error."""
    if not getattr(scene, "terms", None):
        return False

    try:
        with warnings.catch_warnings():  # the scene is built again (and warns) when it is loaded
            warnings.simplefilter("ignore")
            return _is_dense(scene.to_scene())
    except ValueError:
        raise
    except Exception as err:  # a user term's dense_hessian that raised: one line, not a traceback
        raise ValueError(f"terms: a term could not say whether it couples every point: "
                         f"{type(err).__name__}: {err}") from None


class Config(StrictModel):
    """A validated configuration. Build with :func:`load_config`.

    Attributes
    ----------
    scene : DimensionlessScene or PhysicalScene
    solver : SolverSpec
    name, description : str or None
    raw : dict
        The configuration as given (a deep copy), to embed in outputs.
    """

    scene: SceneSpec
    solver: SolverSpec = SolverSpec()
    name: Optional[StrictStr] = None
    description: Optional[StrictStr] = None
    #: An analysis or study section (``type:`` names it); validated by the analysis that runs it
    #: (``actuator_design.analysis.registry``), not here.
    study: Optional[Dict[str, Any]] = None
    _raw: dict = PrivateAttr(default_factory=dict)

    @model_validator(mode="after")
    def _check_scene_on_mesh(self):
        """The mesh within the dense-Hessian budget in a non-uniform field or with a term that
        couples every point; expression profiles finite where this transcription evaluates them."""
        s = self.solver
        if s.accuracy is None and (is_non_uniform(self.scene.field) or _dense_terms(self.scene)):
            problem = mesh_problem(s.transcription, s.elements, s.degree, dense=True)
            if problem is not None:
                raise error(problem.removeprefix("elements "), "solver.elements")
        scene = self.scene
        stiffness = scene.rod.stiffness_profile if isinstance(scene, PhysicalScene) else scene.stiffness
        profiles = {
            "scene.fibres.expression": (None if scene.fibres is None else scene.fibres.to_profile(), False),
            **{f"scene.{name}.expression": (profile, False)  # the profiles the terms' keys carry (β(s))
               for name, profile in scene.magnetic_profiles().items()},
            ("scene.rod.stiffness_profile.expression" if isinstance(scene, PhysicalScene)
             else "scene.stiffness.expression"): (None if stiffness is None else stiffness.to_profile(), True),
        }
        try:
            check_profiles_at(profiles, self.solver_options())
        except ConfigError as err:
            raise error(err.detail, err.field) from None
        return self

    @property
    def raw(self) -> dict:
        return self._raw

    def to_scene(self) -> Scene:
        """The dimensionless :class:`Scene` (physical scenes carry their :class:`Scales`).

        A user expression field is checked here to be divergence- and curl-free over the disc the
        rod can reach (THEORY §3), so no caller can solve with a field that is not a field.
        """
        scene = self.scene.to_scene(self.name)
        if isinstance(scene.field, ExpressionField):
            model = field_model(scene.field)
            try:
                check_current_free(model, model.parameter_values(scene.field), name="scene.field")
            except FieldCheckError as err:
                raise ConfigError("scene.field", str(err).split(": ", 1)[-1]) from None
        return scene

    def solver_options(self) -> SolverOptions:
        return self.solver.to_options()


def _files_beside(data, folder: Path) -> None:
    """A relative ``scene.field.file`` (a coil map) is read beside the YAML file: made absolute."""
    scene = data.get("scene") if isinstance(data, dict) else None
    field = scene.get("field") if isinstance(scene, dict) else None
    if isinstance(field, dict) and isinstance(field.get("file"), str) and field["file"]:
        if not Path(field["file"]).is_absolute():
            field["file"] = str((folder / field["file"]).absolute())


def load_config(source: Union[str, Path, dict]) -> Config:
    """Read and validate a configuration.

    Parameters
    ----------
    source : str, Path or dict
        A YAML file path (at most 1 MiB of UTF-8, bounded nesting and aliases, no duplicate keys:
        :mod:`actuator_design.config.yaml_source`), or the configuration as a dict. A file the
        YAML names (``scene.field.file``) is read beside the YAML file; from a dict, beside the
        working directory.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        One line, starting with the dotted path of the first invalid field.
    """
    if isinstance(source, dict):
        check_structure(source)
        data = copy.deepcopy(source)
    else:
        data = read_yaml(Path(source))
        _files_beside(data, Path(source).parent)
    if not isinstance(data, dict):
        raise ConfigError("config", f"expected a mapping with a 'scene' key, got {type(data).__name__}")
    bad = first_non_finite(data)
    if bad is not None:
        raise ConfigError(dotted(bad), "must be a finite number, got NaN, infinity or a number beyond the "
                                       "float range (about ±1.8e308)")
    try:
        config = Config.model_validate(data)
    except ValidationError as err:
        raise translate(err) from None
    config._raw = data  # a private copy already (copied from the dict given, or parsed here)
    return config


def validate_config(data: dict) -> Config:
    """Validate a configuration dict in place, without copying it: for callers that only ask
    whether it is valid (a study checks every grid point before any work) and whose dict is made
    of values :func:`load_config` has read already (bounded structure, finite numbers).

    Raises
    ------
    ConfigError
        As :func:`load_config`.
    """
    try:
        return Config.model_validate(data)
    except ValidationError as err:
        raise translate(err) from None


def load_scene(source: Union[str, Path, dict]) -> Tuple[Scene, SolverOptions, dict]:
    """``(scene, solver_options, raw_dict)`` from a configuration file or dict."""
    config = load_config(source)
    return config.to_scene(), config.solver_options(), config.raw
