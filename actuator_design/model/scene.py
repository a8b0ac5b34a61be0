"""The validated, dimensionless scene: what every solver layer consumes.

A :class:`Scene` is the output of configuration (``actuator_design.config``) and the input of the
physics layer. All values are dimensionless per THEORY §5: lengths in units of the rod length ℓ,
energies in units of B0/ℓ (B0 the bending stiffness at the clamp), fields in units of a field scale
H0 whose strength is folded into the group ``h``. A physical scene carries its :class:`Scales` so
results can be converted back. Which energy terms a scene *contains* is structural: ``field is
None`` builds no magnetic term, a term value None no term
(:data:`actuator_design.physics.registration.SCENE_VALUES`); a term present at zero is still built.
"""
from __future__ import annotations

import functools
import inspect
import math
import typing
from dataclasses import dataclass
from dataclasses import field as dc_field
from dataclasses import fields, replace
from typing import Any, Dict, Optional, Tuple

# the applied fields, kept importable from here (a scene holds one)
from actuator_design.model.applied_fields import (DIPOLE_CLOSE, DipoleField, ExpressionField, Field,  # noqa: F401
                                                 SourceField, UniformField)
from actuator_design.model.profiles import Profile, constant_profile
from actuator_design.physics.registration import PROFILE, SCENE_VALUES, component, real_number, short_repr

__all__ = [
    "UniformField",
    "DipoleField",
    "ExpressionField",
    "SourceField",
    "Field",
    "Scales",
    "Scene",
    "TermValues",
    "default_scene",
    "profile_fields",
]


@dataclass(frozen=True)
class Scales:
    """Physical scales that convert dimensionless results back to SI units.

    Attributes
    ----------
    length : float
        ℓ, m.
    bending_stiffness : float
        B0 = E I at the clamp, N m².
    field : float
        H0, A/m (0 when the scene has no field).
    h_per_field : float
        dh/dH0 = √(μ0 χ̄ A ℓ² / (2 B0)), per A/m: converts a designed h to a field even when the
        scene's own field is zero (0 when unknown).
    mass_per_length : float
        ρA, kg/m (0 when the rod's density is not given): with B0 and ℓ the time scale
        √(ρA ℓ⁴/B0) of its vibrations (:mod:`actuator_design.schedules.dynamics`).
    damping_ratio : float
        The material's modal damping ratio ζ (0 when not given: a default is assumed).
    per_field : tuple of (str, float)
        Each group the applied field drives, per unit field, dg/dH0 per A/m, by its lens name: the
        field is one field (THEORY §5, §9), so these fix every group at any field, zero included
        (:func:`actuator_design.physics.parameters.set_field`). Empty when unknown.
    field_limit : float
        The largest field |H| at a point of the rod (A/m) at which the magnetisation model holds:
        the particles' saturation field, and the field at which the linear magnetisation reaches the
        composite's saturation ν M_s (THEORY §11); inf when unknown.
    """

    length: float
    bending_stiffness: float
    field: float = 0.0
    h_per_field: float = 0.0
    mass_per_length: float = 0.0
    damping_ratio: float = 0.0
    per_field: Tuple[Tuple[str, float], ...] = ()
    field_limit: float = math.inf

    @property
    def force(self) -> float:
        """Force scale B0/ℓ², N."""
        return self.bending_stiffness / self.length**2

    @property
    def moment(self) -> float:
        """Moment and energy scale B0/ℓ, N m (= J)."""
        return self.bending_stiffness / self.length

    @property
    def stiffness(self) -> float:
        """Tip stiffness scale B0/ℓ³, N/m."""
        return self.bending_stiffness / self.length**3

    def as_dict(self) -> dict:
        """The rod's SI scales by key; a result's ``scales`` adds each term's
        (:func:`actuator_design.physics.registration.describe_scales`)."""
        return {
            "length_m": self.length,
            "bending_stiffness_Nm2": self.bending_stiffness,
            "field_A_per_m": self.field,
            "h_per_field_per_A_per_m": self.h_per_field,
            "force_N": self.force,
            "moment_Nm": self.moment,
            "energy_J": self.moment,
            "stiffness_N_per_m": self.stiffness,
        }


@dataclass(frozen=True)
class TermValues:
    """A plug-in energy term present in a scene, with its parameter values.

    Attributes
    ----------
    name : str
        The registered term name (``actuator_design.physics.registry``).
    values : tuple of (str, float)
        Slot name -> value (dimensionless, in the term's units); slots not given are 0.
    """

    name: str
    values: Tuple[Tuple[str, float], ...] = ()

    def as_dict(self) -> Dict[str, float]:
        return {k: float(v) for k, v in self.values}


@dataclass(frozen=True, kw_only=True)
class _SceneFields:
    """The rod's own fields of a :class:`Scene` (its terms' values are ``values``); keywords only, as
    the terms' values are."""

    field: Optional[Field] = dc_field(default_factory=UniformField)
    h: float = 0.0
    fibres: Profile = dc_field(default_factory=lambda: constant_profile(0.0))
    stiffness: Profile = dc_field(default_factory=lambda: constant_profile(1.0))
    theta0: float = 0.0
    scales: Optional[Scales] = None
    name: str = "dimensionless cantilever"
    fibres_given: bool = False
    fibres_physical: bool = True
    obstacles: Tuple[Any, ...] = ()
    contact_gap: float = 0.0
    values: Tuple[Tuple[str, Any], ...] = ()


#: the keywords of the rod (``extra_terms``, the plug-in terms, is kept in ``values`` too)
_ROD = tuple(f.name for f in fields(_SceneFields)) + ("extra_terms",)


def _plugin_entries(plugins) -> Tuple[TermValues, ...]:
    """The plug-in terms given (``extra_terms``) as a tuple of :class:`TermValues`, each term once."""
    plugins = tuple(plugins)
    for t in plugins:
        if not isinstance(t, TermValues):
            raise TypeError(f"Scene: extra_terms must hold TermValues, got {short_repr(t)}")
        if t.name in SCENE_VALUES:
            raise ValueError(f"Scene: extra_terms: {t.name!r} is a built-in term value's name")
    names = [t.name for t in plugins]
    if len(set(names)) != len(names):
        raise ValueError(f"Scene: extra_terms lists a term twice ({', '.join(names)})")
    return plugins


class _Checked(tuple):
    """A scene's ``values``, each checked by its declaration."""


class Scene(_SceneFields):
    """A dimensionless magneto-elastic cantilever (THEORY §4–5): the rod, the applied field, the
    obstacles, and the values of its energy terms.

    Attributes
    ----------
    field : Field or None
        Applied field shape; ``None`` builds no magnetic term.
    h : float
        Orientational group, h² = μ0 χ̄ H0² A ℓ² / (2 B0) ≥ 0 (THEORY §5): the field's strength.
    fibres : Profile
        Fibre angle α(s), rad, s ∈ [0, 1].
    stiffness : Profile
        Relative bending stiffness b(s) = B(s)/B0 > 0, b(0) = 1 for physical scenes.
    theta0 : float
        Clamp angle, rad.
    scales : Scales or None
        Present for physical scenes.
    name : str
        Free text for reports.
    extra_terms : tuple of TermValues
        Plug-in energy terms present in the scene, with their values (the extension point: which
        terms are listed is structural, their values are not); kept in ``values``, after the
        built-in terms' values, each under its term's name.
    fibres_given : bool
        The fibre layout was given by the user (a config's ``fibres``): it is fabricated, so inverse
        design keeps it unless asked to vary it (``--vary ...,alpha``).
    fibres_physical : bool
        The fibre layout is a property of the actuator that changes its response (True), or not
        (False: isotropic particles, whose easy axis is set by the body, the rod's tangent, THEORY
        §10): inverse design then never designs α(s).
    obstacles : tuple of Wall or Peg
        Rigid frictionless obstacles (:mod:`actuator_design.contact.obstacles`); ``solve`` then finds a
        contact equilibrium (:mod:`actuator_design.contact.equilibrium`).
    contact_gap : float
        The rod's half-thickness, units of ℓ (set from ``rod.thickness`` for a physical scene): the
        distance its centre line keeps from an obstacle, and half the distance it keeps from itself
        (self-contact, :mod:`actuator_design.contact.self_contact`); 0: no self-contact.
    values : tuple of (str, object)
        The one store of the terms' values: every value the built-in terms declare
        (:data:`actuator_design.physics.registration.SCENE_VALUES`: what each is, its units, default and
        kind), by name, given and read by name, checked: ``Scene(tip_force=(0.0, 1.0))``,
        ``scene.tip_force``, ``dataclasses.replace(scene, h_r=2.0)``; then each plug-in term present,
        its name with its :class:`TermValues` (``extra_terms``, ``term_values(name)``). A ``values``
        given by hand is the whole store: a value it leaves out takes its default, and a plug-in
        term it leaves out is absent (``extra_terms=`` may not be given with plug-in entries there).
    """

    def __init__(self, **kwargs):
        given = {k: kwargs.pop(k) for k in [k for k in kwargs if k in SCENE_VALUES]}
        plugins = kwargs.pop("extra_terms", None)
        stored = kwargs.pop("values", ())
        old = tuple((k, v) for k, v in stored if not isinstance(v, TermValues))
        unknown = sorted(set(kwargs) - set(_ROD)) + [repr(k) for k, _ in old if k not in SCENE_VALUES]
        if unknown:
            raise TypeError(f"Scene: unknown keyword(s) {', '.join(map(str, unknown))} (the rod's: "
                            f"{', '.join(_ROD)}; the terms': {', '.join(SCENE_VALUES)})")
        in_store = tuple(v for _, v in stored if isinstance(v, TermValues))
        if plugins is None:
            plugins = in_store
        elif in_store and not isinstance(stored, _Checked):
            raise ValueError("Scene: give the plug-in terms in extra_terms or in values, not in both")
        plugins = _plugin_entries(plugins)
        super().__init__(**kwargs)
        if isinstance(stored, _Checked):  # a scene's own (a replace passes them on): checked when it was built
            merged = {**dict(old), **{k: SCENE_VALUES[k].checked(v) for k, v in given.items()}}
        else:
            merged = {**{k: v.default for k, v in SCENE_VALUES.items()}, **dict(old), **given}
            merged = {k: spec.checked(merged[k]) for k, spec in SCENE_VALUES.items()}
        for name in ("h", "theta0", "contact_gap"):
            value = real_number(getattr(self, name))
            if value is None or (name == "contact_gap" and value < 0):
                raise ValueError(f"Scene: {name} must be a finite number{' >= 0' * (name == 'contact_gap')}, "
                                 f"got {short_repr(getattr(self, name))}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "values", _Checked([*((k, merged[k]) for k in SCENE_VALUES),
                                                     *((t.name, t) for t in plugins)]))
        object.__setattr__(self, "_by_name", merged)  # (not a field: equality and hash use ``values``)

    @property
    def extra_terms(self) -> Tuple[TermValues, ...]:
        """The plug-in energy terms present, with their values (kept in ``values``, after the built-in ones)."""
        return tuple(v for _, v in self.values[len(SCENE_VALUES):])

    # -- plug-in terms ---------------------------------------------------------------------------
    def term_values(self, name: str) -> Optional[Dict[str, float]]:
        """Values of the plug-in term ``name``, or ``None`` when the scene does not contain it."""
        for t in self.extra_terms:
            if t.name == name:
                return t.as_dict()
        return None

    def extra_term_names(self) -> Tuple[str, ...]:
        return tuple(t.name for t in self.extra_terms)

    def with_term(self, name: str, **values: float) -> "Scene":
        """A copy containing plug-in term ``name`` with ``values`` updated (added if absent)."""
        old = self.term_values(name)
        merged = {**(old or {}), **{k: float(v) for k, v in values.items()}}
        entry = TermValues(name, tuple(sorted(merged.items())))
        if old is None:
            return replace(self, extra_terms=self.extra_terms + (entry,))
        return replace(self, extra_terms=tuple(entry if t.name == name else t for t in self.extra_terms))

    def without_term(self, name: str) -> "Scene":
        """A copy without plug-in term ``name``."""
        return replace(self, extra_terms=tuple(t for t in self.extra_terms if t.name != name))

    # -- convenience -------------------------------------------------------------------------
    @property
    def phi(self) -> float:
        """Uniform field angle (rad); 0 for other fields."""
        return self.field.phi if isinstance(self.field, UniformField) else 0.0

    @property
    def p(self) -> float:
        """Vertical tip load p = fy (THEORY §5); 0 when the scene has no tip force."""
        value, i = component("p")
        pair = self._by_name[value.name]
        return 0.0 if pair is None else float(pair[i])

    def with_values(self, *, h=None, phi=None, p=None, alpha=None) -> "Scene":
        """Return a copy with the dimensionless values of THEORY §5 overridden.

        ``phi`` requires a uniform field (or none: one is added); ``h`` adds a uniform field if the
        scene has none; ``p`` adds a tip force if it has none (x component 0); ``alpha`` (rad) sets
        a constant fibre angle. The lens' writes (``physics.parameters``) without its range checks.
        """
        scene = self
        if h is not None:
            scene = replace(scene, h=float(h), field=scene.field or UniformField())
        if phi is not None:
            if scene.field is not None and not isinstance(scene.field, UniformField):
                raise ValueError(f"phi can only be set for a uniform field; this scene has a {scene.field.kind} field")
            scene = replace(scene, field=UniformField(phi=float(phi)))
        if p is not None:
            value, i = component("p")
            pair = list(scene._by_name[value.name] or (0.0, 0.0))
            pair[i] = float(p)
            scene = replace(scene, **{value.name: tuple(pair)})
        if alpha is not None:
            scene = replace(scene, fibres=constant_profile(float(alpha)))
        return scene


def _term_value(name: str, doc: str) -> property:
    return property(lambda scene: scene._by_name[name], doc=doc)


for _name, _value in SCENE_VALUES.items():  # scene.<name>: read-only, as every field of the frozen scene
    setattr(Scene, _name, _term_value(_name, _value.doc))
# help(Scene) and IDEs show the term values as keywords, after the rod's fields
Scene.__signature__ = inspect.signature(_SceneFields).replace(parameters=[
    *inspect.signature(_SceneFields).parameters.values(),
    inspect.Parameter("extra_terms", inspect.Parameter.KEYWORD_ONLY, default=()),
    *(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=value.default)
      for name, value in SCENE_VALUES.items())])


def default_scene(h: float = 1.0, phi: float = 0.0, p: float = 0.0, alpha: float = 0.0) -> Scene:
    """THEORY §5's dimensionless cantilever: uniform field (h, φ), vertical tip load p,
    constant fibre angle α, clamp angle 0, nothing else."""
    return Scene(field=UniformField(phi=float(phi)), h=float(h), fibres=constant_profile(float(alpha)),
                 name="default dimensionless cantilever (THEORY §5)").with_values(p=p)


@functools.lru_cache(maxsize=None)
def profile_fields() -> Dict[str, bool]:
    """The :class:`Scene`'s profiles, name -> whether it may be None: the fibres and the stiffness
    every rod has, and those a term brings (a remanent magnetisation β(s), THEORY §9)."""
    rod = {name: type(None) in typing.get_args(hint) for name, hint in typing.get_type_hints(_SceneFields).items()
           if hint is Profile or Profile in typing.get_args(hint)}
    return {**rod, **{name: v.optional for name, v in SCENE_VALUES.items() if v.kind == PROFILE}}
