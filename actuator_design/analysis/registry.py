"""Named analyses that a study can run at every point of a sweep.

Each entry maps a name (the ``type:`` of a YAML study section, the word a study's ``analyses:`` list
uses) to a function ``f(scene, options, **settings) -> dict`` whose result is JSON-serialisable and
flat enough to become rows of a table. Analyses register themselves here with :func:`register`;
the study layer looks them up with :func:`get`.
"""
from __future__ import annotations

import importlib
from typing import Callable, Dict

from actuator_design.analysis.registration import _ANALYSES, register

__all__ = ["register", "get", "names"]

#: the built-in analyses and the modules that register them (imported only when one is used:
#: a study of ``solve`` does not pay for importing the design stages)
BUILTIN: Dict[str, str] = {"solve": "analysis.solve", "equilibria": "analysis.equilibria",
                           "continuation": "continuation.follow", "critical": "continuation.critical",
                           "map": "analysis.multiplicity", "path": "continuation.loading",
                           "stiffness": "analysis.stiffness", "design": "inverse.design"}


def _load_builtin(name=None):
    for key, mod in BUILTIN.items():
        if name is None or key == name:
            importlib.import_module(f"actuator_design.{mod}")


def get(name: str) -> Callable[..., dict]:
    if name not in _ANALYSES:
        _load_builtin(name)
    if name not in _ANALYSES:
        raise ValueError(f"unknown analysis {name!r} (allowed: {', '.join(names())})")
    return _ANALYSES[name]


def names():
    """Every analysis name: the built-in ones and any registered since."""
    return sorted(set(BUILTIN) | set(_ANALYSES))
