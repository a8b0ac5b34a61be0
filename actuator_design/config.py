"""Configuration files → validated models → the dimensionless :class:`~actuator_design.scene.Scene`.

A configuration is YAML (or the equivalent dict) with the top-level keys ``scene`` (required),
``solver``, ``name`` and ``description``. Every mapping is validated by a pydantic model that rejects
unknown keys; ``type:`` tags pick variants (discriminated unions). Any failure becomes a one-line
:class:`ConfigError` whose message starts with the dotted path of the offending field, e.g.
``scene.rod.length: must be > 0, got -1 mm``.

Values with units are read by :func:`actuator_design.units.parse_quantity`: write ``"27.5 mm"``,
``"2.25 MPa"``, ``"5 kA/m"`` or ``"10 mT"`` (H = B/μ0), ``"30 deg"``. A plain number is in SI base
units, except angles: a plain number is radians and must lie in [-2π, 2π].

Scenes
------
``type: dimensionless`` gives the groups of THEORY §5 directly: ``h``, ``phi`` (or ``field``),
``p`` (or ``tip_force``), ``tip_moment``, ``distributed_load``, ``h_pos``, ``fibres``,
``stiffness``, ``clamp_angle``. Lengths (positions) are in units of the rod length ℓ.

``type: physical`` gives SI quantities (``rod``, ``magnetics``, ``field``, ``loads``, ``fibres``,
``clamp``) and is non-dimensionalised (THEORY §5) with ℓ, B0 = E I (or the given bending
stiffness) and a field scale H0:

* h² = μ0 χ̄ H0² A ℓ² / (2 B0),  h_pos² = μ0 χ̂ H0² A ℓ² / (2 B0);
* tip force F ℓ²/B0, tip moment M ℓ/B0, distributed load q ℓ³/B0 (weight: q = ρ g A along gravity);
* uniform field: H0 = magnitude; dipole of moment m: H0 = m/(4π ℓ³), positions /ℓ; expression
  field: H0 = ``scale`` and ``hx``, ``hy`` are expressions in x, y measured in units of ℓ.

Profiles (``fibres``: fibre angle α(s) in rad; ``stiffness``/``stiffness_profile``: relative bending
stiffness b(s) > 0) are ``{type: constant, value}``, ``{type: table, s, values}`` (linear
interpolation, s from 0 to 1 strictly increasing; fibre tables may give ``values_deg``) or
``{type: expression, expression: "0.3*sin(pi*s)"}``; a bare value means constant.
"""
from __future__ import annotations

import copy
import difflib
import math
from pathlib import Path
from typing import Annotated, Any, ClassVar, Dict, List, Literal, Optional, Tuple, Union

import numpy as np
import yaml
from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, PrivateAttr, StrictBool,
                      StrictInt, StrictStr, ValidationError, ValidationInfo, field_validator,
                      model_validator)
from pydantic_core import PydanticCustomError

from .expressions import Expression, ExpressionError
from .options import SolverOptions
from .profiles import Profile, constant_profile, expression_profile, table_profile
from .scene import DipoleField, ExpressionField, Scales, Scene, UniformField
from .units import DIMENSIONS, MU0, QuantityError, parse_quantity

__all__ = ["ConfigError", "Config", "load_config", "load_scene", "magnetic_group"]

_HALF_PI = 0.5 * math.pi
_GRID = np.linspace(0.0, 1.0, 201)  # arc lengths at which expression profiles are checked


class ConfigError(ValueError):
    """An invalid configuration: ``"<dotted.field.path>: <what is wrong>"`` on one line.

    Attributes
    ----------
    field : str
        Dotted path of the offending field (``"config"`` for the file as a whole).
    detail : str
        What is wrong and what is allowed.
    """

    def __init__(self, field: str, detail: str):
        self.field = field
        self.detail = " ".join(str(detail).split())
        super().__init__(f"{field}: {self.detail}")


def _error(detail: str, field: Optional[str] = None) -> PydanticCustomError:
    """A validation error; ``field`` names a sub-field of the model raising it."""
    return PydanticCustomError("config", "{detail}", {"detail": detail, "field": field or ""})


# -- quantities ---------------------------------------------------------------------------------
def _shown(value, dimension: str) -> str:
    unit = DIMENSIONS[dimension].unit
    if isinstance(value, str) or not unit:
        return str(value)
    return f"{value} {unit}"


def Q(dimension: str, *, gt=None, ge=None, lt=None, le=None):
    """A float field read by :func:`parse_quantity` in SI units of ``dimension``, with bounds."""

    def validate(value, info: ValidationInfo):
        try:
            x = parse_quantity(value, dimension, info.field_name or "value")
        except QuantityError as err:
            raise _error(err.detail) from None
        for bound, ok, sym in ((gt, lambda b: x > b, ">"), (ge, lambda b: x >= b, ">="),
                               (lt, lambda b: x < b, "<"), (le, lambda b: x <= b, "<=")):
            if bound is not None and not ok(bound):
                raise _error(f"must be {sym} {bound:g}, got {_shown(value, dimension)}")
        return x

    return Annotated[float, BeforeValidator(validate)]


Angle = Q("angle")
Number = Q("dimensionless")
Positive = Q("dimensionless", gt=0)


# -- base model, tagged unions, error translation ------------------------------------------------
class _Model(BaseModel):
    """Strict base: unknown keys are errors that name the key and list the allowed ones."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _reject_unknown_keys(cls, data):
        if isinstance(data, dict):
            allowed = [f.alias or n for n, f in cls.model_fields.items()]
            for key in data:
                if key not in allowed and key not in cls.model_fields:
                    near = difflib.get_close_matches(str(key), allowed, n=1)
                    hint = f"; did you mean '{near[0]}'?" if near else ""
                    raise PydanticCustomError(
                        "unknown_key", "unknown key (allowed: {allowed}{hint})",
                        {"key": str(key), "allowed": ", ".join(allowed), "hint": hint})
        return data


#: The strict base model (unknown keys are errors naming the key and the allowed ones), for other
#: layers that validate YAML sections (study specifications).
StrictModel = _Model

_UNION_TAGS: dict = {}  # field name of a tagged union → its tags (pydantic puts the tag in loc)


def _tagged(field_names, *models, bare=None):
    """A ``type:``-tagged union of ``models`` used under ``field_names``; ``bare(value)`` may
    rewrite a non-mapping value (e.g. a number meaning a constant profile)."""
    tags = [m.model_fields["type"].annotation.__args__[0] for m in models]
    for name in field_names:
        _UNION_TAGS.setdefault(name, [])
        _UNION_TAGS[name] += [t for t in tags if t not in _UNION_TAGS[name]]
    union = Annotated[Union[models], Field(discriminator="type")]
    if bare is not None:
        union = Annotated[union, BeforeValidator(lambda v: v if isinstance(v, dict) else bare(v))]
    return union


def _dotted(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "config"


def _strip_tags(loc) -> list:
    out = []
    for i, part in enumerate(loc):
        if i and loc[i - 1] in _UNION_TAGS and part in _UNION_TAGS[loc[i - 1]]:
            continue
        out.append(part)
    return out


def _translate(err: ValidationError) -> ConfigError:
    """The first error of ``err`` as a :class:`ConfigError` naming the field by its dotted path."""
    e = err.errors()[0]
    loc, kind, ctx, value = _strip_tags(e["loc"]), e["type"], e.get("ctx") or {}, e.get("input")
    if kind == "config":
        loc += [ctx["field"]] if ctx.get("field") else []
        detail = ctx["detail"]
    elif kind == "unknown_key":
        loc.append(ctx["key"])
        detail = f"unknown key (allowed: {ctx['allowed']}{ctx['hint']})"
    elif kind in ("union_tag_invalid", "union_tag_not_found"):
        tags = ", ".join(_UNION_TAGS.get(loc[-1] if loc else "", []))
        what = f"unknown type '{ctx['tag']}'" if kind == "union_tag_invalid" else "missing"
        loc.append("type")
        detail = f"{what} (allowed: {tags})"
    elif kind == "missing":
        detail = "required (missing)"
    elif kind == "extra_forbidden":
        detail = "unknown key"
    elif kind in ("model_attributes_type", "model_type", "dict_type"):
        detail = f"expected a mapping of keys to values, got {value!r}"
    else:
        msg = e["msg"].removeprefix("Value error, ")
        detail = f"{msg[:1].lower()}{msg[1:]}, got {value!r}"
    return ConfigError(_dotted(loc), detail)


def _first_non_finite(obj, path=()):
    """Path of the first NaN/inf float in nested dicts/lists, or None."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return path
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for key, val in items:
        found = _first_non_finite(val, path + (key,))
        if found is not None:
            return found
    return None


# -- profiles -----------------------------------------------------------------------------------
class _TableBase(_Model):
    type: Literal["table"]
    s: List[Number]

    @field_validator("s")
    @classmethod
    def _check_nodes(cls, s):
        if len(s) < 2:
            raise _error(f"needs at least 2 nodes, got {len(s)}")
        if s[0] != 0 or s[-1] != 1:
            raise _error(f"must start at 0 and end at 1 (arc length s in [0, 1]), got {s}")
        if any(b <= a for a, b in zip(s, s[1:])):
            raise _error(f"must be strictly increasing, got {s}")
        return s

    def _check_length(self, name: str, values) -> None:
        if len(values) != len(self.s):
            raise _error(f"must have as many entries as s ({len(self.s)}), got {len(values)}", name)


class _ExpressionBase(_Model):
    type: Literal["expression"]
    expression: StrictStr
    positive_only: ClassVar[bool] = False

    @field_validator("expression")
    @classmethod
    def _parse(cls, text):
        try:
            Expression(text, ("s",))
        except ExpressionError as err:
            raise _error(str(err)) from None
        try:
            with np.errstate(all="ignore"):
                v = Profile(kind="expression", expression=text)(_GRID)
        except Exception as err:  # e.g. "1/0" in plain Python floats
            raise _error(f"cannot evaluate {text!r} on s in [0, 1]: {err}") from None
        bad = ~np.isfinite(v) | ((v <= 0) if cls.positive_only else False)
        if np.any(bad):
            k = int(np.argmax(bad))
            need = "finite and > 0" if cls.positive_only else "finite"
            raise _error(f"{text!r} must be {need} on [0, 1], got {v[k]:g} at s = {_GRID[k]:g}")
        return text

    def to_profile(self) -> Profile:
        return expression_profile(self.expression)


class FibreConstant(_Model):
    """Constant fibre angle α, rad (``"30 deg"`` allowed)."""

    type: Literal["constant"]
    value: Angle = 0.0

    def to_profile(self) -> Profile:
        return constant_profile(self.value)


class FibreTable(_TableBase):
    """Fibre angles at nodes s (rad: numbers or angle strings; or ``values_deg`` in degrees)."""

    values: Optional[List[Angle]] = None
    values_deg: Optional[List[Number]] = None

    @model_validator(mode="after")
    def _check(self):
        if (self.values is None) == (self.values_deg is None):
            raise _error("give exactly one of values (rad) and values_deg", "values")
        self._check_length(*(("values", self.values) if self.values is not None
                             else ("values_deg", self.values_deg)))
        return self

    def to_profile(self) -> Profile:
        vals = self.values if self.values is not None else [math.radians(v) for v in self.values_deg]
        return table_profile(self.s, vals)


class FibreExpression(_ExpressionBase):
    """Fibre angle α(s) in rad as an expression in s."""


class StiffnessConstant(_Model):
    type: Literal["constant"]
    value: Positive = 1.0

    def to_profile(self) -> Profile:
        return constant_profile(self.value)


class StiffnessTable(_TableBase):
    values: List[Positive]

    @model_validator(mode="after")
    def _check(self):
        self._check_length("values", self.values)
        return self

    def to_profile(self) -> Profile:
        return table_profile(self.s, self.values)


class StiffnessExpression(_ExpressionBase):
    positive_only: ClassVar[bool] = True


def _constant(value):
    return {"type": "constant", "value": value}


FibreProfile = _tagged(("fibres",), FibreConstant, FibreTable, FibreExpression, bare=_constant)
StiffnessProfile = _tagged(("stiffness", "stiffness_profile"), StiffnessConstant, StiffnessTable,
                           StiffnessExpression, bare=_constant)


# -- vectors -----------------------------------------------------------------------------------
class NumberXY(_Model):
    """Dimensionless (x, y) components."""

    x: Number = 0.0
    y: Number = 0.0


class LengthXY(_Model):
    """Position (x, y), m; the clamp is at the origin, the rod along +x."""

    x: Q("length") = 0.0
    y: Q("length") = 0.0


class ForceXY(_Model):
    """Force (x, y), N."""

    x: Q("force") = 0.0
    y: Q("force") = 0.0


class LineLoadXY(_Model):
    """Force per unit length (x, y), N/m."""

    x: Q("force_per_length") = 0.0
    y: Q("force_per_length") = 0.0


# -- fields ------------------------------------------------------------------------------------
class _ExpressionFieldBase(_Model):
    type: Literal["expression"]
    hx: StrictStr
    hy: StrictStr

    @field_validator("hx", "hy")
    @classmethod
    def _parse(cls, text):
        try:
            Expression(text, ("x", "y"))
        except ExpressionError as err:
            raise _error(str(err)) from None
        return text


def _check_dipole_position(x0: float, y0: float, where: str = "position") -> None:
    if y0 == 0 and 0 <= x0 <= 1:
        raise _error("the dipole lies on the undeformed rod, where its field is singular", where)


class UniformSpec(_Model):
    """Dimensionless uniform field at ``angle`` (strength: the scene's ``h``)."""

    type: Literal["uniform"]
    angle: Angle = 0.0

    def to_field(self) -> UniformField:
        return UniformField(phi=self.angle)


class DipoleSpec(_Model):
    """Dimensionless point dipole at ``position`` (units of ℓ), moment direction ``moment_angle``."""

    type: Literal["dipole"]
    position: NumberXY
    moment_angle: Angle = _HALF_PI

    @model_validator(mode="after")
    def _check(self):
        _check_dipole_position(self.position.x, self.position.y)
        return self

    def to_field(self) -> DipoleField:
        return DipoleField(x0=self.position.x, y0=self.position.y, moment_angle=self.moment_angle)


class ExpressionSpec(_ExpressionFieldBase):
    """Dimensionless field shape (hx, hy) as expressions in x, y (units of ℓ)."""

    def to_field(self) -> ExpressionField:
        return ExpressionField(hx=self.hx, hy=self.hy)


class PhysicalUniform(_Model):
    """Uniform field of strength ``magnitude`` (A/m or T) at ``angle`` to the rod axis."""

    type: Literal["uniform"]
    magnitude: Q("magnetic_field", ge=0)
    angle: Angle = 0.0

    def to_field(self, length: float):
        return UniformField(phi=self.angle), self.magnitude


class PhysicalDipole(_Model):
    """Point dipole (small permanent magnet): moment (A m²), position (m), moment direction."""

    type: Literal["dipole"]
    moment: Q("magnetic_moment", gt=0)
    position: LengthXY
    moment_angle: Angle = _HALF_PI

    def to_field(self, length: float, where: str = "position"):
        x0, y0 = self.position.x / length, self.position.y / length
        _check_dipole_position(x0, y0, where)
        return (DipoleField(x0=x0, y0=y0, moment_angle=self.moment_angle),
                self.moment / (4.0 * math.pi * length**3))


class PhysicalExpression(_ExpressionFieldBase):
    """Field H0 · (hx, hy)(x/ℓ, y/ℓ): expressions in x, y in units of the rod length."""

    scale: Q("magnetic_field", gt=0)

    def to_field(self, length: float):
        return ExpressionField(hx=self.hx, hy=self.hy), self.scale


DimensionlessField = _tagged(("field",), UniformSpec, DipoleSpec, ExpressionSpec)
PhysicalField = _tagged(("field",), PhysicalUniform, PhysicalDipole, PhysicalExpression)


def _max_shape_on_rod(field) -> float:
    """max |ĥ| along the undeformed rod (x = s, y = 0), for the saturation check."""
    x, y = _GRID, np.zeros_like(_GRID)
    if isinstance(field, UniformField):
        return 1.0
    if isinstance(field, DipoleField):
        rx, ry = x - field.x0, y - field.y0
        r = np.hypot(rx, ry)
        mx, my = math.cos(field.moment_angle), math.sin(field.moment_angle)
        md = (mx * rx + my * ry) / r
        hx, hy = (3 * md * rx / r - mx) / r**3, (3 * md * ry / r - my) / r**3
    else:
        with np.errstate(all="ignore"):
            hx, hy = (np.broadcast_to(Expression(t, ("x", "y")).evaluate({"x": x, "y": y}), x.shape)
                      for t in (field.hx, field.hy))
    return float(np.nanmax(np.hypot(hx, hy)))


# -- scenes ------------------------------------------------------------------------------------
def _profile(spec, default: float) -> Profile:
    return constant_profile(default) if spec is None else spec.to_profile()


def _xy(vec, factor: float = 1.0):
    return None if vec is None else (vec.x * factor, vec.y * factor)


class DimensionlessScene(_Model):
    """The groups of THEORY §5 given directly (see the module docstring)."""

    type: Literal["dimensionless"]
    h: Optional[Q("dimensionless", ge=0)] = None
    h_pos: Q("dimensionless", ge=0) = 0.0
    phi: Optional[Angle] = None
    field: Optional[DimensionlessField] = None
    p: Optional[Number] = None
    tip_force: Optional[NumberXY] = None
    tip_moment: Optional[Number] = None
    distributed_load: Optional[NumberXY] = None
    fibres: Optional[FibreProfile] = None
    stiffness: Optional[StiffnessProfile] = None
    clamp_angle: Angle = 0.0

    @model_validator(mode="after")
    def _check(self):
        if self.phi is not None and self.field is not None:
            raise _error("give either phi (uniform field) or field, not both", "phi")
        if self.p is not None and self.tip_force is not None:
            raise _error("give either p or tip_force, not both", "p")
        return self

    def to_scene(self, name: Optional[str] = None) -> Scene:
        if self.field is not None:
            field = self.field.to_field()
        elif self.h is not None or self.phi is not None:
            field = UniformField(phi=self.phi or 0.0)
        else:
            field = None
        tip = (0.0, self.p) if self.p is not None else _xy(self.tip_force)
        return Scene(field=field, h=self.h or 0.0, h_pos=self.h_pos,
                     fibres=_profile(self.fibres, 0.0), stiffness=_profile(self.stiffness, 1.0),
                     tip_force=tip, tip_moment=self.tip_moment,
                     distributed_load=_xy(self.distributed_load), theta0=self.clamp_angle,
                     scales=None, name=name or "dimensionless cantilever")


class Rod(_Model):
    """Rod geometry and stiffness: A = w t, I = w t³/12, B0 = E I (or ``bending_stiffness``)."""

    length: Q("length", gt=0)
    width: Optional[Q("length", gt=0)] = None
    thickness: Optional[Q("length", gt=0)] = None
    youngs_modulus: Optional[Q("pressure", gt=0)] = None
    bending_stiffness: Optional[Q("bending_stiffness", gt=0)] = None
    area: Optional[Q("area", gt=0)] = None
    stiffness_profile: Optional[StiffnessProfile] = None

    @model_validator(mode="after")
    def _check(self):
        has_wt = self.width is not None and self.thickness is not None
        if (self.width is None) != (self.thickness is None):
            missing = "width" if self.width is None else "thickness"
            raise _error("required together with " + ("thickness" if missing == "width" else "width"),
                         missing)
        if self.youngs_modulus is None and self.bending_stiffness is None:
            raise _error("required (or give bending_stiffness)", "youngs_modulus")
        if self.youngs_modulus is not None and self.bending_stiffness is not None:
            raise _error("give either youngs_modulus or bending_stiffness, not both",
                         "bending_stiffness")
        if self.youngs_modulus is not None and not has_wt:
            raise _error("required with youngs_modulus (I = w t³/12)", "width")
        if self.area is not None and (has_wt or self.youngs_modulus is not None):
            raise _error("give either area (with bending_stiffness) or width and thickness", "area")
        if self.area is None and not has_wt:
            raise _error("required with bending_stiffness when width and thickness are not given",
                         "area")
        if self.stiffness_profile is not None:
            b0 = float(self.stiffness_profile.to_profile()(0.0))
            if abs(b0 - 1.0) > 1e-12:
                raise _error(f"must equal 1 at s = 0 (B0 is the clamp stiffness), got {b0:g}",
                             "stiffness_profile")
        return self

    @property
    def cross_section_area(self) -> float:
        """A, m²."""
        return self.area if self.area is not None else self.width * self.thickness

    @property
    def clamp_stiffness(self) -> float:
        """B0, N m²."""
        if self.bending_stiffness is not None:
            return self.bending_stiffness
        return self.youngs_modulus * self.width * self.thickness**3 / 12.0


class Particles(_Model):
    """Spheroidal particles (THEORY §2); fields in A/m (or T)."""

    axis_ratio: Q("dimensionless", ge=1)
    chi_par: Positive
    chi_perp: Positive
    volume_fraction: Q("dimensionless", gt=0, lt=1)
    saturation_field: Optional[Q("magnetic_field", gt=0)] = None


class Magnetics(_Model):
    """Effective susceptibilities χ̄, χ̂ (dimensionless), given or computed from ``particles``."""

    chi_bar: Optional[Q("dimensionless", ge=0)] = None
    chi_hat: Optional[Q("dimensionless", ge=0)] = None
    particles: Optional[Particles] = None

    @model_validator(mode="after")
    def _check(self):
        if self.particles is not None and (self.chi_bar is not None or self.chi_hat is not None):
            raise _error("give either chi_bar/chi_hat or particles, not both", "particles")
        if self.particles is None and self.chi_bar is None:
            raise _error("required (or give particles)", "chi_bar")
        return self

    def susceptibilities(self) -> Tuple[float, float]:
        """(χ̄, χ̂), dimensionless."""
        if self.particles is None:
            return self.chi_bar, self.chi_hat or 0.0
        from .magnetics import effective_susceptibilities

        p = self.particles
        chi_bar, chi_hat = effective_susceptibilities(p.chi_par, p.chi_perp, p.axis_ratio,
                                                      p.volume_fraction)
        return float(chi_bar), float(chi_hat)


class Weight(_Model):
    """Self-weight q = ρ g A per unit length along the gravity direction ``gravity_angle``."""

    density: Q("density", gt=0)
    gravity_angle: Angle = -_HALF_PI
    g: Q("acceleration", gt=0) = 9.81


class Loads(_Model):
    """Dead loads: tip force (N), tip moment (N m), distributed load (N/m) or weight."""

    tip_force: Optional[ForceXY] = None
    tip_moment: Optional[Q("moment")] = None
    distributed: Optional[LineLoadXY] = None
    weight: Optional[Weight] = None

    @model_validator(mode="after")
    def _check(self):
        if self.distributed is not None and self.weight is not None:
            raise _error("give either distributed or weight, not both", "weight")
        return self

    def line_load(self, area: float):
        """Distributed load (qx, qy) in N/m, or None."""
        if self.weight is None:
            return _xy(self.distributed)
        w = self.weight
        q = w.density * w.g * area
        # round-off of cos(-π/2) etc. to an exact zero, so "down" is exactly (0, -q)
        cx, cy = (0.0 if abs(c) < 1e-15 else c for c in (math.cos(w.gravity_angle),
                                                           math.sin(w.gravity_angle)))
        return (q * cx, q * cy)


class Clamp(_Model):
    angle: Angle = 0.0


def magnetic_group(chi: float, field: float, area: float, length: float, stiffness: float) -> float:
    """√(μ0 χ H0² A ℓ² / (2 B0)) (THEORY §5): h for χ = χ̄, h_pos for χ = χ̂. SI inputs."""
    return math.sqrt(MU0 * chi * field**2 * area * length**2 / (2.0 * stiffness))


class PhysicalScene(_Model):
    """SI description, non-dimensionalised by ℓ, B0 and H0 (THEORY §5)."""

    type: Literal["physical"]
    rod: Rod
    magnetics: Optional[Magnetics] = None
    field: Optional[PhysicalField] = None
    loads: Optional[Loads] = None
    fibres: Optional[FibreProfile] = None
    clamp: Optional[Clamp] = None

    @model_validator(mode="after")
    def _check(self):
        if self.field is not None and self.magnetics is None:
            raise _error("required when a field is given", "magnetics")
        if isinstance(self.field, PhysicalDipole):  # the position check needs ℓ
            self.field.to_field(self.rod.length, where="field.position")
        return self

    def to_scene(self, name: Optional[str] = None) -> Scene:
        length, area, b0 = self.rod.length, self.rod.cross_section_area, self.rod.clamp_stiffness
        field, h0, h, h_pos, h_per_field = None, 0.0, 0.0, 0.0, 0.0
        if self.field is not None:
            field, h0 = self.field.to_field(length)
            chi_bar, chi_hat = self.magnetics.susceptibilities()
            h = magnetic_group(chi_bar, h0, area, length, b0)
            h_pos = magnetic_group(chi_hat, h0, area, length, b0)
            h_per_field = magnetic_group(chi_bar, 1.0, area, length, b0)  # h is proportional to H0
        self._check_assumptions(field, h0)
        loads = self.loads or Loads()
        force, line = length**2 / b0, length**3 / b0
        q = loads.line_load(area)
        return Scene(
            field=field, h=h, h_pos=h_pos,
            fibres=_profile(self.fibres, 0.0), stiffness=_profile(self.rod.stiffness_profile, 1.0),
            tip_force=_xy(loads.tip_force, force),
            tip_moment=None if loads.tip_moment is None else loads.tip_moment * length / b0,
            distributed_load=None if q is None else (q[0] * line, q[1] * line),
            theta0=self.clamp.angle if self.clamp else 0.0,
            scales=Scales(length=length, bending_stiffness=b0, field=h0, h_per_field=h_per_field),
            name=name or "physical cantilever")

    def _check_assumptions(self, field, h0: float) -> None:
        """Warn (ModelAssumptionWarning) about dense particles or a field above saturation."""
        p = self.magnetics.particles if self.magnetics else None
        if p is None:
            return
        from .magnetics import check_assumptions

        h_max = None if field is None else h0 * _max_shape_on_rod(field)
        check_assumptions(volume_fraction=p.volume_fraction, field=h_max,
                          saturation_field=p.saturation_field)


SceneSpec = _tagged(("scene",), DimensionlessScene, PhysicalScene)


# -- solver and top level ----------------------------------------------------------------------
_DEFAULTS = SolverOptions()


class SolverSpec(_Model):
    """Maps to :class:`~actuator_design.options.SolverOptions`."""

    transcription: Literal["lgl", "midpoint"] = _DEFAULTS.transcription
    elements: Annotated[StrictInt, Field(ge=1)] = _DEFAULTS.elements
    degree: Annotated[StrictInt, Field(ge=2, le=60)] = _DEFAULTS.degree
    method: Literal["ipopt", "newton", "fast"] = _DEFAULTS.method
    tol: Q("dimensionless", gt=0, lt=1) = _DEFAULTS.tol
    max_iter: Annotated[StrictInt, Field(ge=1)] = _DEFAULTS.max_iter
    ensure_stable: StrictBool = _DEFAULTS.ensure_stable
    jit: StrictBool = False
    #: target tip accuracy (rod lengths): the cheapest resolution that meets it is chosen from an
    #: a-posteriori estimate with two resolutions (``actuator_design.accuracy``)
    accuracy: Optional[Q("dimensionless", gt=0, lt=1)] = None

    def to_options(self) -> SolverOptions:
        return SolverOptions(**self.model_dump())


class Config(_Model):
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
            from .physics.fields import FieldCheckError, check_current_free, field_model

            model = field_model(scene.field)
            try:
                check_current_free(model, model.parameter_values(scene.field), name="scene.field")
            except FieldCheckError as err:
                raise ConfigError("scene.field", str(err).split(": ", 1)[-1]) from None
        return scene

    def solver_options(self) -> SolverOptions:
        return self.solver.to_options()


def _read_yaml(path: Path) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("config", f"file not found: {path}") from None
    except OSError as err:
        raise ConfigError("config", f"cannot read {path}: {err.strerror or err}") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(err, "problem", None) or str(err)
        raise ConfigError("config", f"invalid YAML in {path}{where}: {problem}") from None


def load_config(source: Union[str, Path, dict]) -> Config:
    """Read and validate a configuration.

    Parameters
    ----------
    source : str, Path or dict
        A YAML file path, or the configuration as a dict.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        One line, starting with the dotted path of the first invalid field.
    """
    data = copy.deepcopy(source) if isinstance(source, dict) else _read_yaml(Path(source))
    if not isinstance(data, dict):
        raise ConfigError("config", f"expected a mapping with a 'scene' key, got {type(data).__name__}")
    bad = _first_non_finite(data)
    if bad is not None:
        raise ConfigError(_dotted(bad), "must be a finite number, got NaN or infinity")
    try:
        config = Config.model_validate(data)
    except ValidationError as err:
        raise _translate(err) from None
    config._raw = copy.deepcopy(data)
    return config


def load_scene(source: Union[str, Path, dict]) -> Tuple[Scene, SolverOptions, dict]:
    """``(scene, solver_options, raw_dict)`` from a configuration file or dict."""
    config = load_config(source)
    return config.to_scene(), config.solver_options(), config.raw
