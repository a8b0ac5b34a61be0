"""Where the named analyses register themselves (:func:`register`): the store, and nothing that
loads it. A leaf: the analysis modules import it, and :mod:`actuator_design.analysis.registry`
(which imports them when a study names one) looks them up.
"""
from __future__ import annotations

from typing import Callable, Dict

__all__ = ["register"]

_ANALYSES: Dict[str, Callable[..., dict]] = {}


def register(name: str):
    """Decorator: register ``f(scene, options, **settings) -> dict`` under ``name``."""
    def wrap(fn):
        _ANALYSES[name] = fn
        return fn
    return wrap
