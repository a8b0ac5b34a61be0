"""Where energy-term classes are registered, and what the built-in terms keep in a scene: the
stores, and nothing that loads or queries them.

A leaf (it imports only the model's profiles, no CasADi: the scene imports it). A term module (the
built-in :mod:`~actuator_design.physics.terms`, the shipped :mod:`~actuator_design.physics.extra_terms`)
registers itself here on import, and
:mod:`~actuator_design.physics.registry` (which imports the term modules) answers every question
about the registered terms. Users register through ``ad.register_term`` (the registry re-exports
:func:`register_term`).

A :class:`~actuator_design.model.scene.Scene` is the rod (its fibres, stiffness, clamp), the applied
field with its strength ``h``, the obstacles, and the values of its terms, in one store
(``scene.values``): those of :data:`SCENE_VALUES` (read as attributes, ``scene.tip_force``, written
as keywords, ``Scene(tip_force=(0, 1))`` or ``dataclasses.replace``), then each plug-in term present
with its values (``extra_terms``, ``scene.term_values(name)``). The
scene names none of them: a term's values change here and in the term's own module
(:mod:`.terms`, :mod:`.hard_magnetic`), not in the model, io or config. Which terms a scene
*contains* is structural: a value that may be None (``optional``) builds no term when it is None; a
present term with value zero is still built (so it can be continued or designed).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Callable, Dict, Optional, Tuple

import numpy as np

from actuator_design.model.profiles import Profile

__all__ = ["register_term", "unregister_term", "SceneValue", "SCENE_VALUES", "NUMBER", "VECTOR", "PROFILE",
           "without_optional_terms", "real_number", "real_pair", "short_repr", "describe_scales",
           "component", "saved_scales_fields"]

_TERMS: Dict[str, type] = {}
_CONFIG_MODELS: Dict[str, type] = {}
_VERSION = [0]


def register_term(cls: Optional[type] = None, *, config_model: Optional[type] = None,
                  replace: bool = False):
    """Register an energy-term class (usable as a decorator, with or without arguments).

    Parameters
    ----------
    cls : type
        Subclass of :class:`~actuator_design.physics.terms.EnergyTerm` with a unique ``name``.
    config_model : pydantic model class, optional
        Its YAML configuration, selected by ``type: <name>``.
    replace : bool
        Allow re-registering a name (e.g. a test module imported twice).

    Raises
    ------
    ValueError
        A different class is already registered under the same name.
    """
    def do(c):
        name = getattr(c, "name", None)
        if not name or not isinstance(name, str):
            raise ValueError(f"term class {c.__name__}: needs a string attribute 'name'")
        old = _TERMS.get(name)
        if old is not None and old is not c and not replace:
            if old.__qualname__ != c.__qualname__ or old.__module__ != c.__module__:
                raise ValueError(f"term {name!r}: already registered by {old.__module__}.{old.__qualname__}")
        _TERMS[name] = c
        if config_model is not None:
            _CONFIG_MODELS[name] = config_model
        _VERSION[0] += 1
        return c
    return do if cls is None else do(cls)


def unregister_term(name: str) -> None:
    """Remove a registered term (tests that register a toy term clean up with this)."""
    _TERMS.pop(name, None)
    _CONFIG_MODELS.pop(name, None)
    _VERSION[0] += 1


#: the kinds of value: a float, an (x, y) pair of floats, a Profile of s ∈ [0, 1]
NUMBER, VECTOR, PROFILE = "number", "vector", "profile"


@dataclass(frozen=True)
class SceneValue:
    """One value a built-in term keeps in a scene.

    Attributes
    ----------
    name : str
        The attribute and keyword (and the key in a saved scene).
    default : object
        Its value in a scene that does not give it (None: the term is absent).
    kind : str
        :data:`NUMBER`, :data:`VECTOR` or :data:`PROFILE`.
    optional : bool
        Whether None is allowed (and means: no such term).
    doc : str
        What it is, with its units.
    scale : (str, callable) or None
        What a physical result's ``scales`` says of its units (:func:`describe_scales`): a key and
        the SI factor of one unit, from the scene's :class:`~actuator_design.model.scene.Scales`.
    scales_field : str or None
        The name a saved scene's ``scales_fields`` kept :attr:`scale`'s factor under when it was a
        field of :class:`~actuator_design.model.scene.Scales` (still written: a reader of those
        versions finds it; :func:`saved_scales_fields`).
    component : (str, int) or None
        THEORY §5's name of one component of a pair and its index (``("p", 1)``: p is fy), read
        and written as ``scene.p``, ``scene.with_values(p=...)`` (0 and a pair at zero when None).
    """

    name: str
    default: Any
    kind: str
    optional: bool
    doc: str
    scale: Optional[Tuple[str, Callable[[Any], float]]] = None
    scales_field: Optional[str] = None
    component: Optional[Tuple[str, int]] = None

    def checked(self, value):
        """``value`` as a scene keeps it (floats, a tuple for a pair); ValueError naming this value
        and what it must be (a NaN, a wrong length or type) otherwise."""
        if value is None and self.optional:
            return None
        if self.kind == PROFILE:
            if isinstance(value, Profile):
                return value
            what = "a Profile (e.g. constant_profile(0.0))"
        elif self.kind == VECTOR:
            pair = real_pair(value)
            if pair is not None:
                return pair
            what = "an (x, y) pair of finite numbers"
        else:
            number = real_number(value)
            if number is not None:
                return number
            what = "a finite number"
        raise ValueError(f"Scene: {self.name} must be {what}{' or None' * self.optional}, got {short_repr(value)} "
                         f"({self.doc})")


#: name -> declaration, in the order a saved scene lists them
SCENE_VALUES: Dict[str, SceneValue] = {v.name: v for v in (
    SceneValue("h_pos", 0.0, NUMBER, False,
               "positional group, h_pos² = μ0 χ̂ H0² A ℓ² / (2 B0) ≥ 0; its term is built only for "
               "non-uniform fields (in a uniform field it is a constant)"),
    SceneValue("tip_force", (0.0, 0.0), VECTOR, True,
               "dead tip force (fx, fy), units of B0/ℓ²; THEORY §5's p is fy (present by default, at zero)",
               component=("p", 1)),
    SceneValue("tip_moment", None, NUMBER, True, "dead tip moment, units of B0/ℓ, counter-clockwise positive"),
    SceneValue("distributed_load", None, VECTOR, True,
               "dead load per unit length (qx, qy) (e.g. weight), units of B0/ℓ³",
               scale=("distributed_load_N_per_m", lambda scales: scales.bending_stiffness / scales.length**3)),
    SceneValue("h_r", 0.0, NUMBER, False,
               "hard-magnetic group h_r = μ0 M_r H0 A ℓ² / B0 ≥ 0 (THEORY §9); linear in the field",
               # dh_r/dH0 = μ0 M_r A ℓ² / B0 per A/m (0 when the rod has no remanent magnetisation)
               scale=("h_r_per_field_per_A_per_m", lambda scales: dict(scales.per_field).get("h_r", 0.0)),
               scales_field="h_r_per_field"),
    SceneValue("magnetization", None, PROFILE, True,
               "angle β(s) of the remanent magnetisation to the tangent, rad; None builds no hard-magnetic "
               "term (a present term with h_r = 0 is still built)"),
)}


def real_number(value) -> Optional[float]:
    """``value`` as a finite float when it is one real number (numpy's and CasADi's scalars
    included; not a truth value or text), else None."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        return None
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return number if math.isfinite(number) else None


def real_pair(value) -> Optional[Tuple[float, float]]:
    """``value`` as an (x, y) tuple of finite floats when it is two real numbers, else None."""
    if hasattr(value, "full"):  # a CasADi DM: its numbers (numpy functions on it warn)
        value = value.full()
    if isinstance(value, (str, bytes)) or np.size(value) != 2:
        return None
    try:
        x, y = (real_number(v) for v in np.ravel(np.asarray(value, dtype=object)))
    except (TypeError, ValueError):
        return None
    return None if x is None or y is None else (x, y)


def short_repr(value, limit: int = 60) -> str:
    """``repr(value)`` on one line, at most ``limit`` characters (an error message quotes it)."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def component(name: str) -> Tuple[SceneValue, int]:
    """The value one of whose components THEORY §5 calls ``name`` (:attr:`SceneValue.component`),
    and the component's index."""
    for value in SCENE_VALUES.values():
        if value.component is not None and value.component[0] == name:
            return value, value.component[1]
    raise KeyError(f"no scene value has a component named {name!r}")


def describe_scales(scales) -> Optional[dict]:
    """A result's ``scales`` (None for a dimensionless scene): the rod's SI scales
    (:meth:`~actuator_design.model.scene.Scales.as_dict`) and those of the terms' values
    (:attr:`SceneValue.scale`)."""
    if scales is None:
        return None
    return {**scales.as_dict(), **{key: float(factor(scales)) for key, factor in
                                   (v.scale for v in SCENE_VALUES.values() if v.scale is not None)}}


def saved_scales_fields(scales) -> Optional[dict]:
    """A saved scene's ``scales_fields``: the fields of ``scales`` (None for a dimensionless scene),
    and each factor a term's value once kept there (:attr:`SceneValue.scales_field`)."""
    if scales is None:
        return None
    return {**{f.name: getattr(scales, f.name) for f in fields(scales)},
            **{v.scales_field: float(v.scale[1](scales)) for v in SCENE_VALUES.values() if v.scales_field}}


def without_optional_terms() -> Dict[str, Any]:
    """Every optional value as None, as keywords of a Scene: a scene that holds only the terms it is
    then given (a Scene's defaults hold some: the tip-force term, at zero), as a config builds it."""
    return {name: None for name, value in SCENE_VALUES.items() if value.optional}
