"""Where energy-term classes are registered: the store, and nothing that loads or queries it.

A leaf: a term module (the built-in :mod:`~actuator_design.physics.terms`, the shipped
:mod:`~actuator_design.physics.extra_terms`) registers itself here on import, and
:mod:`~actuator_design.physics.registry` (which imports the term modules) answers every question
about the registered terms. Users register through ``ad.register_term`` (the registry re-exports
:func:`register_term`).
"""
from __future__ import annotations

from typing import Dict, Optional

__all__ = ["register_term", "unregister_term"]

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
