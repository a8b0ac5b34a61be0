"""Named analyses that a study can run at every point of a sweep.

Each entry maps a name (the ``type:`` of a YAML study section, the word a study's ``analyses:`` list
uses) to a function ``f(scene, options, **settings) -> dict`` whose result is JSON-serialisable and
flat enough to become rows of a table. Analyses register themselves here with :func:`register`;
the study layer looks them up with :func:`get`.
"""
from __future__ import annotations

from typing import Callable, Dict

__all__ = ["register", "get", "names"]

_ANALYSES: Dict[str, Callable[..., dict]] = {}


def register(name: str):
    """Decorator: register ``f(scene, options, **settings) -> dict`` under ``name``."""
    def wrap(fn):
        _ANALYSES[name] = fn
        return fn
    return wrap


def _load_builtin():
    # Importing the analysis modules registers them; a module that is not there yet is skipped.
    import importlib

    for mod in ("solve", "equilibria", "continuation", "critical", "multiplicity", "loading",
                "stiffness", "design"):
        try:
            importlib.import_module(f"{__package__}.{mod}")
        except ModuleNotFoundError as err:
            if err.name != f"{__package__}.{mod}":
                raise


def get(name: str) -> Callable[..., dict]:
    _load_builtin()
    if name not in _ANALYSES:
        raise ValueError(f"unknown analysis {name!r} (allowed: {', '.join(sorted(_ANALYSES))})")
    return _ANALYSES[name]


def names():
    _load_builtin()
    return sorted(_ANALYSES)
