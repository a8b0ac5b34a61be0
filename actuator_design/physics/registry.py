"""The registry of energy-term classes: registering a class is all it takes to add a term.

A registered class (a subclass of :class:`~.terms.EnergyTerm`) says itself whether a scene contains
it (``present``), how to build it (``from_scene``), which NLP slots and per-point fields it reads,
which lens parameters it contributes, and how it enters the residual scale. Everything else —
the NLP layout, the parameter vector, the balance check, the parameter lens — is derived from the
registered classes, in registration order (the built-in terms first).

An optional pydantic model registered with a term (under a ``type:`` tag) lets configuration read
the term's values from YAML. Terms shipped with the package beyond the paper's are one module each
in :mod:`.extra_terms`, imported (and so registered) after the built-in ones.
"""
from __future__ import annotations

import importlib
import pkgutil
from typing import TYPE_CHECKING, Dict, List, Tuple

from actuator_design.model.scene import TermValues
# the built-in terms register on import; registered_terms() orders them (_rank) whichever came first
from actuator_design.physics import extra_terms, hard_magnetic, terms  # noqa: F401
from actuator_design.physics.registration import (_CONFIG_MODELS, _TERMS, _VERSION, register_term,
                                                  unregister_term)
from actuator_design.physics.term_protocol import EnergyTerm

if TYPE_CHECKING:
    from actuator_design.model.scene import Scene

__all__ = ["declaring", "present_parts", "register_term", "unregister_term", "registered_terms", "term_class", "config_models",
           "registry_version", "unsupported_terms", "refuse_unsupported", "parse_term_config",
           "TermConfigError", "plugin_names", "present_terms", "write_keeps_terms", "build_terms",
           "scene_wavenumber", "end_force", "end_moment", "signed_end_moment", "dense_hessian", "is_builtin"]

def registered_terms() -> List[type]:
    """Every registered term class: the built-in terms, then the shipped extra terms (by module
    name), then the others in registration order — the same order whichever module was imported
    first (it orders the parameter lens and the NLP's slots)."""
    _load_builtins()
    if _ORDERED[0] != _VERSION[0]:  # sorted once per change of the registry (analyses ask per scene)
        _ORDERED[:] = [_VERSION[0], tuple(sorted(_TERMS.values(), key=_rank))]
    return list(_ORDERED[1])


_ORDERED: list = [None, ()]


_BUILTIN_MODULES = (f"{__package__}.terms", f"{__package__}.hard_magnetic")


def _rank(cls: type):
    module = getattr(cls, "__module__", "")
    if module in _BUILTIN_MODULES:
        return (0, _BUILTIN_MODULES.index(module), "")
    if module.startswith(f"{__package__}.extra_terms."):
        return (1, 0, module)
    return (2, 0, "")


def is_builtin(cls: type) -> bool:
    """Whether ``cls`` is one of the built-in terms (registered whenever the registry is read, so
    what is derived from them does not depend on which module was imported first)."""
    return _rank(cls)[0] == 0


def term_class(name: str) -> type:
    """The class registered as ``name``; ValueError listing the registered names otherwise."""
    _load_builtins()
    try:
        return _TERMS[name]
    except KeyError:
        raise ValueError(f"unknown energy term {name!r} (registered: {', '.join(_TERMS)})") from None


def config_models() -> Dict[str, type]:
    """``type:`` tag -> pydantic model of every term registered with one."""
    _load_builtins()
    return dict(_CONFIG_MODELS)


def registry_version() -> int:
    """Changes whenever a term is (un)registered (for caches derived from the registry)."""
    _load_builtins()
    return _VERSION[0]


def _load_builtins() -> None:
    """Register the shipped extra terms once (the built-in ones registered when this module was imported)."""
    if not _EXTRA_LOADED:
        _EXTRA_LOADED.append(True)  # re-entrant calls (a module importing the registry) pass
        try:
            _load_extra_terms()
        except BaseException:
            _EXTRA_LOADED.clear()  # a failing import is raised again next time, not skipped
            raise


_EXTRA_LOADED: List[bool] = []


def _load_extra_terms() -> None:
    """Import every module of :mod:`.extra_terms` (by name): a term shipped with the package is one
    file there, registered on import, and needs no edit anywhere else."""
    for info in sorted(pkgutil.iter_modules(extra_terms.__path__), key=lambda m: m.name):
        if not info.name.startswith("_"):
            importlib.import_module(f"{extra_terms.__name__}.{info.name}")


def present_terms(scene) -> tuple:
    """Names of the registered terms ``scene`` contains, in order."""
    return tuple(c.name for c in registered_terms() if c.present(scene))


def write_keeps_terms(p, scene, value) -> bool:
    """Whether writing lens parameter ``p`` at ``value`` into ``scene`` leaves the set of terms it
    contains as it is (a value stored for an absent term, e.g. h_r without a magnetisation, may be
    rescaled; one whose write would add its term may not)."""
    return present_terms(p.write(scene, value)) == present_terms(scene)


def unsupported_terms(scene, supported) -> List[str]:
    """Names of the terms ``scene`` contains that are not in ``supported``."""
    return [c.name for c in registered_terms() if c.name not in supported and c.present(scene)]


def declaring(method: str) -> List[str]:
    """Names of the registered terms that declare the :class:`EnergyTerm` classmethod ``method``
    (override it), in registration order."""
    base = getattr(EnergyTerm, method).__func__
    return [c.name for c in registered_terms() if getattr(c, method).__func__ is not base]


def present_parts(scene, method: str, analysis: str) -> List[Tuple[type, object]]:
    """(term class, ``cls.<method>(scene)``) for every term ``scene`` contains, in registration
    order: what an analysis that asks each term for its part (a first integral, a shooting
    equation) sums. ValueError naming ``analysis`` and the first term whose part is None (it has
    none, so the analysis cannot honour it), or the term's own ValueError."""
    out = []
    for cls in registered_terms():
        if cls.present(scene):
            part = getattr(cls, method)(scene)
            if part is None:
                raise ValueError(f"{analysis}: the scene contains the energy term {cls.name!r}, which this "
                                 f"analysis does not support (it supports: {', '.join(declaring(method))})")
            out.append((cls, part))
    return out


def refuse_unsupported(scene, supported, analysis: str) -> None:
    """Raise ValueError naming the first term of ``scene`` that ``analysis`` does not support.

    An analysis that hand-codes the physics (a closed form, a shooting equation) states the terms
    it knows; it must refuse a scene with any other term rather than silently ignore it.
    """
    extra = unsupported_terms(scene, supported)
    if extra:
        raise ValueError(f"{analysis}: the scene contains the energy term {extra[0]!r}, which this "
                         f"analysis does not support (it supports: {', '.join(supported)})")


class TermConfigError(ValueError):
    """A plug-in term's YAML entry is wrong: ``terms.<name>.<key>: <detail>``.

    Attributes
    ----------
    key : str
        The entry's key at fault (``"type"`` when the type is missing or unknown).
    detail : str
        What is wrong and what is allowed.
    """

    def __init__(self, name: str, key: str, detail: str):
        self.key, self.detail = key, detail
        super().__init__(f"terms.{name}.{key}: {detail}" if name else f"terms: {detail}")


def parse_term_config(spec, convert=None) -> "TermValues":
    """A plug-in term's YAML entry ``{type: <name>, <slot>: <value>, …}`` as scene ``TermValues``.

    The values are validated by the pydantic model registered with the term (unknown keys and bad
    values are errors naming the field); a term registered without a model takes numbers for its
    lens parameters, range-checked by them.

    Parameters
    ----------
    spec : dict
        The entry.
    convert : callable (Parameter, value, key) -> float, optional
        Reads a value given with units (a physical scene: ``"2 kPa"`` for a stiffness per area) as
        the parameter's dimensionless value; without it values are plain numbers.

    Raises
    ------
    TermConfigError
        No ``type``, an unregistered type, or a value its model rejects (one line naming the field).
    """
    if not isinstance(spec, dict) or "type" not in spec:
        raise TermConfigError("", "type", f"each entry needs a 'type' (one of: {', '.join(plugin_names())}), "
                                          f"got {spec!r:.80}")
    name = spec["type"]
    if name not in plugin_names():
        raise TermConfigError("", "type", f"unknown term {name!r} (allowed: {', '.join(plugin_names())})")
    cls = term_class(name)
    values = {k: v for k, v in spec.items() if k != "type"}
    model = _CONFIG_MODELS.get(name)
    if model is not None:
        try:
            values = model(**values).model_dump()
        except Exception as err:  # pydantic.ValidationError: report its first error in one line
            errors = getattr(err, "errors", None)
            if callable(errors) and errors():
                e = errors()[0]
                loc = ".".join(str(p) for p in e.get("loc", ()))
                raise TermConfigError(name, loc, e.get("msg", str(err))) from None
            raise TermConfigError(name, "type", f"{type(err).__name__}: {err}"[:200]) from None
    by_slot = {p.slot: p for p in cls.parameters if not p.per_point}
    out = []
    for k, v in values.items():
        if k not in cls.scalar_params:
            raise TermConfigError(name, k, f"unknown key (allowed: {', '.join(cls.scalar_params)})")
        p = by_slot.get(k)
        if isinstance(v, bool):  # YAML's true/false is not a number
            raise TermConfigError(name, k, f"must be a number, got {v!r}")
        try:
            v = convert(p, v, k) if (convert is not None and p is not None) else float(v)
        except OverflowError:
            raise TermConfigError(name, k, f"must be a finite number, got {v!r:.80}") from None
        except (TypeError, ValueError) as err:
            detail = getattr(err, "detail", None) or (f"must be a number, got {v!r:.80}"
                                                      if isinstance(err, TypeError) or "float" in str(err)
                                                      else str(err))
            raise TermConfigError(name, k, detail) from None
        if p is not None:
            try:
                v = p.validate(v)
            except ValueError as err:
                raise TermConfigError(name, k, str(err).removeprefix(f"{p.name}: ")) from None
        elif v != v or v in (float("inf"), float("-inf")):
            raise TermConfigError(name, k, f"must be finite, got {v!r}")
        out.append((k, float(v)))
    return TermValues(name, tuple(sorted(out)))


def plugin_names() -> List[str]:
    """Names of the registered terms a scene lists in ``extra_terms`` (YAML ``terms:``): the ones
    whose presence is the listing itself (not the built-in field, load and bending terms)."""
    return [c.name for c in registered_terms() if c.present.__func__ is EnergyTerm.present.__func__]


# -- derived from the registered terms ------------------------------------------------------------
def build_terms(scene: "Scene") -> List["EnergyTerm"]:
    """The terms this scene contains, and no others (a term absent from the scene is not built).

    Raises
    ------
    ValueError
        The scene lists a plug-in term that is not registered.
    """
    classes = registered_terms()
    known = {c.name for c in classes}
    for name in scene.extra_term_names():
        if name not in known:
            raise ValueError(f"extra_terms: {name!r} is not a registered energy term "
                             f"(registered: {', '.join(sorted(known))})")
    return [cls.from_scene(scene) for cls in classes if cls.present(scene)]


def scene_wavenumber(scene: "Scene") -> float:
    """max(1, the wavenumbers of the terms ``scene`` contains) (units of 1/ℓ)."""
    return max([1.0] + [cls.wavenumber(scene) for cls in registered_terms() if cls.present(scene)])


def end_force(scene: "Scene"):
    """The dead force (fx, fy) the terms of ``scene`` apply at the free end, summed (B0/ℓ²), or None
    when none applies one."""
    forces = [f for cls in registered_terms() if cls.present(scene) for f in [cls.end_force(scene)] if f is not None]
    return None if not forces else (sum(f[0] for f in forces), sum(f[1] for f in forces))


def signed_end_moment(scene: "Scene") -> float:
    """The dead moment at the free end, the sum over the terms ``scene`` contains (units of B0/ℓ): the
    end condition b θ'(1) = m."""
    return sum(cls.end_moment(scene) for cls in registered_terms() if cls.present(scene)) + 0.0


def end_moment(scene: "Scene") -> float:
    """The largest dead moment a term of ``scene`` applies at the free end, in magnitude (B0/ℓ)."""
    return max([0.0] + [abs(cls.end_moment(scene)) for cls in registered_terms() if cls.present(scene)])


def tip_layer(scene: "Scene") -> bool:
    """Whether a term of ``scene`` makes a boundary layer at the free end (a dead tip moment, or
    :meth:`EnergyTerm.tip_layer`)."""
    return end_moment(scene) != 0 or any(cls.present(scene) and cls.tip_layer(scene) for cls in registered_terms())


def dense_hessian(scene: "Scene") -> bool:
    """Whether a term of ``scene`` makes the energy's Hessian dense."""
    return any(cls.present(scene) and cls.dense_hessian(scene) for cls in registered_terms())


def describe_groups(scene: "Scene") -> dict:
    """The dimensionless groups of ``scene`` as a plain dict (a result's ``groups``): the clamp angle,
    what every registered term says of itself (:meth:`EnergyTerm.result_groups`), and the values of
    a plug-in term the scene lists that is not registered (its name: its values)."""
    out = {"theta0": scene.theta0}
    for cls in registered_terms():
        out.update(cls.result_groups(scene))
    for t in scene.extra_terms:
        out.setdefault(t.name, t.as_dict())
    return out
