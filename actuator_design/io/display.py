"""Numbers as the text outputs print them: never "-0", and no round-off noise shown as a value.

A quantity that is zero up to round-off (a clamp force of -0.0, a tip angle of 1.2e-17 rad) is
printed as 0: the sign of a zero and digits below the rounding level carry no information for a
user, and they read as a result ("the field is 1.2e-17 deg off the axis").
"""
from __future__ import annotations

import math
import re

__all__ = ["number", "degrees", "critical_value_note", "ANGLE_NOISE_RAD"]

#: Angles below this (rad) are round-off: ~10⁴ ulp of π, far below any angle a lab can set or
#: measure (1.7e-12 rad is 1e-10 deg).
ANGLE_NOISE_RAD = 1e-12

_ZERO_TEXT = re.compile(r"^-(0+\.?0*)(e[+-]?\d+)?$", re.IGNORECASE)


def number(value: float, spec: str = ".6g", noise: float = 0.0) -> str:
    """``value`` formatted with ``spec``; shown as 0 when |value| ≤ ``noise``, and never as "-0"
    (a negative number that rounds to zero in ``spec`` loses its sign: "-0.000" → "0.000").

    Parameters
    ----------
    value : float
    spec : str
        A format spec, e.g. ".6g", ".10f".
    noise : float
        Magnitudes up to this are round-off of a zero (same unit as ``value``); 0: none.
    """
    v = float(value)
    if math.isfinite(v) and abs(v) <= noise:
        v = 0.0
    text = format(v + 0.0 if v == 0.0 else v, spec)
    return text[1:] if _ZERO_TEXT.match(text) else text


def degrees(rad: float, spec: str = ".6g") -> str:
    """An angle given in rad, printed in degrees (round-off below :data:`ANGLE_NOISE_RAD` as 0)."""
    return number(math.degrees(float(rad)), spec, noise=math.degrees(ANGLE_NOISE_RAD))


def critical_value_note(value: float, error, located: bool) -> str:
    """What the text output says about a critical value's accuracy: "" when it was located and its
    estimated error (``value_error``, units of the value; None or nan: not estimated) is below
    1e-9 × max(1, |value|); else ", error ~E" (the estimate), ", not found on a finer mesh" (inf) or
    ", not located: only bracketed on a step"."""
    if not located:
        return ", not located: only bracketed on a step"
    if error is None or math.isnan(error):
        return ""
    if math.isinf(error):
        return ", not found on a finer mesh"
    return f", error ~{error:.1g}" if error > 1e-9 * max(1.0, abs(value)) else ""
