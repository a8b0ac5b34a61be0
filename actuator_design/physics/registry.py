"""The registry of energy-term classes: registering a class is all it takes to add a term.

A registered class (a subclass of :class:`~.terms.EnergyTerm`) says itself whether a scene contains
it (``present``), how to build it (``from_scene``), which NLP slots and per-point fields it reads,
which lens parameters it contributes, and how it enters the residual scale. Everything else —
the NLP layout, the parameter vector, the balance check, the parameter lens — is derived from the
registered classes, in registration order (the built-in terms first).

An optional pydantic model registered with a term (under a ``type:`` tag) lets configuration read
the term's values from YAML.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Type

__all__ = ["register_term", "unregister_term", "registered_terms", "term_class", "config_models",
           "registry_version", "unsupported_terms", "refuse_unsupported", "parse_term_config"]

_TERMS: Dict[str, type] = {}
_CONFIG_MODELS: Dict[str, type] = {}
_VERSION = [0]


def register_term(cls: Optional[type] = None, *, config_model: Optional[type] = None,
                  replace: bool = False):
    """Register an energy-term class (usable as a decorator, with or without arguments).

    Parameters
    ----------
    cls : type
        Subclass of :class:`~.terms.EnergyTerm` with a unique ``name``.
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


def registered_terms() -> List[type]:
    """Every registered term class, in registration order (the built-in terms first)."""
    _load_builtins()
    return list(_TERMS.values())


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
    from . import terms  # noqa: F401  (registers the built-in terms on import)
    from . import hard_magnetic  # noqa: F401  (THEORY §9, after the soft-magnetic terms)


def unsupported_terms(scene, supported) -> List[str]:
    """Names of the terms ``scene`` contains that are not in ``supported``."""
    return [c.name for c in registered_terms() if c.name not in supported and c.present(scene)]


def refuse_unsupported(scene, supported, analysis: str) -> None:
    """Raise ValueError naming the first term of ``scene`` that ``analysis`` does not support.

    An analysis that hand-codes the physics (a closed form, a shooting equation) states the terms
    it knows; it must refuse a scene with any other term rather than silently ignore it.
    """
    extra = unsupported_terms(scene, supported)
    if extra:
        raise ValueError(f"{analysis}: the scene contains the energy term {extra[0]!r}, which this "
                         f"analysis does not support (it supports: {', '.join(supported)})")


def parse_term_config(spec) -> "TermValues":
    """A plug-in term's YAML entry ``{type: <name>, <slot>: <value>, …}`` as scene ``TermValues``.

    The values are validated by the pydantic model registered with the term (unknown keys and bad
    values are errors naming the field); a term registered without a model takes plain numbers.

    Raises
    ------
    ValueError
        No ``type``, an unregistered type, or a value its model rejects (one line naming the field).
    """
    from ..scene import TermValues

    if not isinstance(spec, dict) or "type" not in spec:
        raise ValueError(f"terms: each entry needs a 'type' (one of: {', '.join(_TERMS)}), got {spec!r}")
    name = spec["type"]
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
                raise ValueError(f"terms.{name}.{loc}: {e.get('msg', err)}") from None
            raise ValueError(f"terms.{name}: {err}") from None
    else:
        unknown = [k for k in values if k not in cls.scalar_params]
        if unknown:
            raise ValueError(f"terms.{name}.{unknown[0]}: unknown key (allowed: {', '.join(cls.scalar_params)})")
    out = []
    for k, v in values.items():
        try:
            out.append((k, float(v)))
        except (TypeError, ValueError):
            raise ValueError(f"terms.{name}.{k}: must be a number, got {v!r}") from None
    return TermValues(name, tuple(sorted(out)))
