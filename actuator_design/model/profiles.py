"""Functions of arc length s ∈ [0, 1]: fibre angle α(s) and relative bending stiffness b(s).

A profile is evaluated numerically at the transcription's quadrature points and enters the NLP as a
parameter vector, so a new fibre layout is a new parameter value, not a new NLP.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np

from actuator_design.model.expressions import Expression

__all__ = ["Profile", "constant_profile", "table_profile", "expression_profile", "legendre_profile"]


@dataclass(frozen=True)
class Profile:
    """A scalar function of s ∈ [0, 1].

    Attributes
    ----------
    kind : {"constant", "table", "expression", "legendre"}
    value : float
        The constant (``kind == "constant"``).
    s, values : tuple of float
        Table nodes (strictly increasing, covering [0, 1]) and values, linearly interpolated.
        For ``kind == "legendre"``, ``values`` are the coefficients c_k of
        Σ c_k P_k(2s − 1) (a smooth designed layout, evaluated exactly).
    expression : str
        An expression in ``s`` (``kind == "expression"``).
    """

    kind: str = "constant"
    value: float = 0.0
    s: Tuple[float, ...] = ()
    values: Tuple[float, ...] = ()
    expression: str = ""

    def __call__(self, s) -> np.ndarray:
        """Evaluate at arc lengths ``s`` (array, any shape); returns a float array of that shape."""
        s = np.asarray(s, dtype=float)
        if self.kind == "constant":
            return np.full(s.shape, float(self.value))
        if self.kind == "table":
            return np.interp(s, np.asarray(self.s), np.asarray(self.values))
        if self.kind == "legendre":
            return np.polynomial.legendre.legval(2.0 * s - 1.0, np.asarray(self.values, float))
        if self.kind == "expression":
            out = Expression(self.expression, ("s",)).evaluate({"s": s})
            return np.broadcast_to(np.asarray(out, dtype=float), s.shape).copy()
        raise ValueError(f"unknown profile kind {self.kind!r}")

    @property
    def is_constant(self) -> bool:
        return self.kind == "constant"

    def as_dict(self) -> dict:
        if self.kind == "constant":
            return {"type": "constant", "value": self.value}
        if self.kind == "table":
            return {"type": "table", "s": list(self.s), "values": list(self.values)}
        if self.kind == "legendre":
            return {"type": "legendre", "coefficients": list(self.values)}
        return {"type": "expression", "expression": self.expression}


def constant_profile(value: float) -> Profile:
    return Profile(kind="constant", value=float(value))


def table_profile(s, values) -> Profile:
    return Profile(kind="table", s=tuple(float(v) for v in s), values=tuple(float(v) for v in values))


def legendre_profile(coefficients) -> Profile:
    """Σ c_k P_k(2s − 1): the smooth few-parameter layouts that design produces."""
    return Profile(kind="legendre", values=tuple(float(c) for c in coefficients))


def expression_profile(text: str) -> Profile:
    Expression(text, ("s",))  # parse now so errors surface at construction
    return Profile(kind="expression", expression=str(text))
