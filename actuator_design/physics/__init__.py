"""The energy terms and what they stand on (kinematics, fields, the parameter lens, the registry).

The built-in term classes are read here by name, lazily (PEP 562), so that the package's face
(``ad.Bending``, ``ad.HardMagnetic``, …) lists them without naming any: :data:`TERM_CLASSES`.
A shipped plug-in term (:mod:`.extra_terms`) or a user's is reached by its registered name,
``ad.term_class(name)``.
"""
from __future__ import annotations

import importlib
from typing import Dict

#: class name -> module of every built-in energy term class
TERM_CLASSES: Dict[str, str] = {
    "Bending": "terms",
    "FieldOrientation": "terms",
    "FieldPosition": "terms",
    "TipForce": "terms",
    "TipMoment": "terms",
    "DistributedLoad": "terms",
    "HardMagnetic": "hard_magnetic",
}

__all__ = ["TERM_CLASSES", *TERM_CLASSES]


def __getattr__(name: str):
    if name not in TERM_CLASSES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{TERM_CLASSES[name]}", __name__), name)
    globals()[name] = value
    return value
