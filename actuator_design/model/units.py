"""Physical quantities from configuration files: ``"27.5 mm"``, ``"5 kA/m"``, ``"10 mT"``, ``"30 deg"``.

:func:`parse_quantity` turns a number or a string with a unit into a float in SI base units, checking
that the unit has the expected dimension. Conventions:

* A **plain number** (``27.5`` or ``"27.5"``) is taken in SI base units (m, Pa, N, A/m, ...), except
  for angles, see below. Write the unit whenever the value is not in SI base units.
* An **angle** given as a plain number is in radians and must lie within [-2π, 2π]; a larger value
  such as ``90`` is rejected because it almost certainly means degrees (write ``"90 deg"``). An
  angle with a unit must lie within ±:data:`MAX_ANGLE_DEG` degrees; a rejected angle is reported
  in the unit it was given in (:func:`angle_range_problem`, also used by the command line).
* A **magnetic field** may be given as a field strength H (``"5 kA/m"``) or as a flux density B in
  tesla (``"10 mT"``); the latter is converted as H = B/μ0 with μ0 = 4π·10⁻⁷ H/m (the field in
  vacuum/air, which is how a magnet or coil field is usually quoted).

The pint unit registry is created on first use (:func:`registry`, also reachable as ``ureg``):
importing pint and building the registry costs ~0.5 s, and the common units of configuration
files (``deg``, ``mm``, ``mT``, ``kA/m``, ``MPa``, … :data:`COMMON_UNITS`) are read without it,
with the factors pint gives (checked against pint in the tests).
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass

__all__ = ["ureg", "registry", "MU0", "DIMENSIONS", "QuantityError", "parse_quantity",
           "COMMON_UNITS", "MAX_ANGLE_DEG", "angle_range_problem"]

_REGISTRY = None


def registry():
    """The pint ``UnitRegistry`` (created on first use)."""
    global _REGISTRY
    if _REGISTRY is None:
        import pint
        _REGISTRY = pint.UnitRegistry()
    return _REGISTRY


def __getattr__(name):  # ``units.ureg``: the registry, created when first asked for
    if name == "ureg":
        return registry()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


MU0 = 4.0e-7 * math.pi
"""Vacuum permeability μ0 = 4π·10⁻⁷ H/m (THEORY §1)."""

_TWO_PI = 2.0 * math.pi

#: Largest |angle| accepted anywhere (configuration values with a unit, ``--*-deg`` flags, angle
#: values of ``--from``/``--to``/``--window``/``--schedule``), degrees: beyond it an angle is a
#: typo (1e30 deg), and its reduction modulo 360° has lost every digit of the angle.
MAX_ANGLE_DEG = 1e6
_MAX_ANGLE_RAD = math.radians(MAX_ANGLE_DEG)
_RAD_PER = {"rad": 1.0, "radian": 1.0, "radians": 1.0, "deg": math.pi / 180.0,
            "degree": math.pi / 180.0, "degrees": math.pi / 180.0, "°": math.pi / 180.0}


def angle_range_problem(value: float, unit: str = "deg", rad_per_unit=None):
    """What is wrong with the angle ``value`` given in ``unit``, in that unit; None when accepted.

    One helper for every angle check, so that a rejected angle is echoed, with its allowed range,
    in the unit the user wrote (an angle given in degrees is never reported in radians).

    Parameters
    ----------
    value : float
        The angle as given, in ``unit``.
    unit : str
        The unit it was given in (``"deg"``, ``"rad"``, ``"°"``, or any pint angle unit together
        with ``rad_per_unit``).
    rad_per_unit : float, optional
        Radians per ``unit`` (default: known for deg and rad).

    Returns
    -------
    str or None
        ``"must be a finite angle in [-1e+06, 1e+06] deg, got 1e+07 deg"``, or None.
    """
    per = rad_per_unit if rad_per_unit is not None else _RAD_PER.get(unit, 1.0)
    v = float(value)
    if math.isfinite(v) and abs(v * per) <= _MAX_ANGLE_RAD * (1.0 + 1e-15):
        return None
    bound = _MAX_ANGLE_RAD / abs(per) if per else math.inf
    shown = "deg" if unit == "°" else unit
    return (f"must be a finite angle in [-{bound:g}, {bound:g}] {shown}, "
            f"got {v:g} {shown}")


def _check_angle_text(x_rad: float, text: str, field_name: str) -> float:
    """``x_rad`` (the angle of ``text``) within ±MAX_ANGLE_DEG, else a QuantityError in the unit
    written in ``text``."""
    if abs(x_rad) <= _MAX_ANGLE_RAD * (1.0 + 1e-15):
        return x_rad
    m = re.match(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(°|[A-Za-z]+)\s*$", text)
    number = float(m.group(1)) if m else 0.0
    if m and number != 0.0 and math.isfinite(number):
        problem = angle_range_problem(number, m.group(2), x_rad / number)
    else:  # an expression such as '2*1e9 deg': in radians, the unit it was converted to
        problem = angle_range_problem(x_rad, "rad")
    raise QuantityError(field_name, f"{problem} ('{text}')" if not m else problem)
_NON_FINITE = re.compile(r"^\s*[+-]?(nan|inf)", re.IGNORECASE)
_MAX_LENGTH = 200
# powers: a unit exponent is a small number ("mm^2", "m**3"); a tower such as "10**10**10" or
# "(10**9)**9" makes pint compute a huge integer (minutes), so it is refused before pint sees it
_POWER = re.compile(r"(\*\*|\^)\s*\(?\s*([+-]?\d*\.?\d+(?:[eE][+-]?\d+)?)")
_POWER_OF_POWER = re.compile(r"(\*\*|\^)[^a-zA-Z]*?(\*\*|\^)")
_MAX_EXPONENT = 12


@dataclass(frozen=True)
class _Dimension:
    description: str  # "a length"
    example: str  # "27.5 mm"
    unit: str  # SI unit the value is returned in (pint syntax)


DIMENSIONS = {
    "length": _Dimension("a length", "27.5 mm", "m"),
    "area": _Dimension("an area", "21 mm^2", "m^2"),
    "pressure": _Dimension("a pressure or modulus", "2.25 MPa", "Pa"),
    "bending_stiffness": _Dimension("a bending stiffness", "3.5e-5 N m^2", "N m^2"),
    "force": _Dimension("a force", "1 mN", "N"),
    "moment": _Dimension("a moment", "0.1 mN m", "N m"),
    "force_per_length": _Dimension("a force per length", "0.2 N/m", "N/m"),
    "magnetic_field": _Dimension("a magnetic field", "5 kA/m' or '10 mT", "A/m"),
    "magnetic_moment": _Dimension("a magnetic moment", "0.05 A m^2", "A m^2"),
    "current": _Dimension("an electric current", "2.5 A", "A"),
    "resistance": _Dimension("an electrical resistance", "1.5 ohm", "ohm"),
    "power": _Dimension("a power", "50 W", "W"),
    "density": _Dimension("a density", "1100 kg/m^3", "kg/m^3"),
    "acceleration": _Dimension("an acceleration", "9.81 m/s^2", "m/s^2"),
    "angle": _Dimension("an angle", "30 deg", "rad"),
    "field_rate": _Dimension("a rate of change of the field", "5 mT/s' or '4 kA/m/s", "A/m/s"),
    "angular_rate": _Dimension("a rotation rate", "30 deg/s", "rad/s"),
    "current_rate": _Dimension("a rate of change of a current (a driver's slew rate)", "20 A/s", "A/s"),
    "speed": _Dimension("a speed (a stage's)", "10 mm/s", "m/s"),
    "dimensionless": _Dimension("a plain number", "0.25", ""),
}
"""Supported dimensions: name → description, example and the SI unit returned."""


class QuantityError(ValueError):
    """A value could not be read as the expected quantity.

    ``str(err)`` is ``"<field>: <detail>"``; ``err.field`` and ``err.detail`` hold the two parts.
    """

    def __init__(self, field: str, detail: str):
        self.field = field
        self.detail = detail
        super().__init__(f"{field}: {detail}")


def _short(field_name: str) -> str:
    return field_name.rsplit(".", 1)[-1] or "value"


def _plain_number(value):
    """``value`` as a float if it is a plain number (or a string holding only one), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    try:
        return float(str(value).strip())
    except ValueError:
        return None


def _check_finite(x: float, value, field_name: str) -> float:
    if not math.isfinite(x):
        raise QuantityError(field_name, f"must be a finite number, got {value!r}")
    return x


def _undefined_unit():
    import pint
    return pint.UndefinedUnitError


#: unit → (kind, factor to SI): read without pint (the values pint gives; tests check them)
COMMON_UNITS = {
    "rad": ("angle", 1.0), "deg": ("angle", math.pi / 180.0),
    "m": ("length", 1.0), "cm": ("length", 1e-2), "mm": ("length", 1e-3), "um": ("length", 1e-6),
    "µm": ("length", 1e-6),
    "Pa": ("pressure", 1.0), "kPa": ("pressure", 1e3), "MPa": ("pressure", 1e6), "GPa": ("pressure", 1e9),
    "N": ("force", 1.0), "mN": ("force", 1e-3), "uN": ("force", 1e-6), "µN": ("force", 1e-6),
    "A/m": ("magnetic_field", 1.0), "kA/m": ("magnetic_field", 1e3), "MA/m": ("magnetic_field", 1e6),
    "A": ("current", 1.0), "mA": ("current", 1e-3),
    "ohm": ("resistance", 1.0), "W": ("power", 1.0), "kW": ("power", 1e3),
    "T": ("flux_density", 1.0), "mT": ("flux_density", 1e-3), "uT": ("flux_density", 1e-6),
    "µT": ("flux_density", 1e-6),
}
_COMMON = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(°|[A-Za-zµ/]+)\s*$")


def _common_unit_value(text: str, dimension: str):
    """The SI value of ``"<number> <common unit>"`` in ``dimension``, or None (pint decides)."""
    m = _COMMON.match(text)
    if not m:
        return None
    unit = "deg" if m.group(2) == "°" else m.group(2)
    kind, factor = COMMON_UNITS.get(unit, (None, None))
    if kind is None:
        return None
    value = float(m.group(1)) * factor
    if kind == dimension:
        return value
    if kind == "flux_density" and dimension == "magnetic_field":  # H = B/μ0 (module doc)
        return value / MU0
    return None


def _parse_string(text: str, dim: _Dimension, field_name: str):
    if len(text) > _MAX_LENGTH:
        raise QuantityError(field_name, f"value too long ({len(text)} characters)")
    if _NON_FINITE.match(text):
        raise QuantityError(field_name, f"must be a finite number, got '{text}'")
    if _POWER_OF_POWER.search(text) or any(abs(float(m.group(2))) > _MAX_EXPONENT
                                           for m in _POWER.finditer(text)):
        raise QuantityError(field_name, f"cannot read '{text}' as {dim.description}: powers are "
                                        f"allowed on units only, with exponents up to {_MAX_EXPONENT}")
    if not re.match(r"^\s*[+-]?(\d|\.\d)", text):
        raise QuantityError(
            field_name, f"expected a number with a unit, e.g. '{dim.example}', got '{text}'")
    try:
        q = registry().Quantity(text.replace("°", " deg"))
    except _undefined_unit() as err:
        raise QuantityError(field_name, f"unknown unit in '{text}': {err}") from None
    except Exception as err:  # pint's tokenizer/evaluator: syntax errors, overflow, ...
        raise QuantityError(field_name, f"cannot read '{text}' as {dim.description}: {err}") from None
    try:
        if not isinstance(q, registry().Quantity):  # e.g. a bare number expression
            q = registry().Quantity(float(q))
        magnitude = float(q.magnitude)
    except (OverflowError, TypeError, ValueError) as err:
        raise QuantityError(field_name, f"cannot read '{text}' as {dim.description}: {err}") from None
    _check_finite(magnitude, text, field_name)
    return q


def _wrong_dimension(text: str, q, dim: _Dimension, field_name: str) -> QuantityError:
    base = q.to_base_units().units
    return QuantityError(
        field_name, f"expected {dim.description} (e.g. '{dim.example}'), got '{text}' [{base}]")


def _is_angle_unit(q) -> bool:
    return q.to_base_units().units == registry().radian


def parse_quantity(value, dimension: str, field_name: str = "value") -> float:
    """Read a number or a ``"<number> <unit>"`` string as a float in SI base units.

    Parameters
    ----------
    value : float, int or str
        E.g. ``27.5e-3``, ``"27.5 mm"``, ``"5 kA/m"``, ``"10 mT"``, ``"30 deg"``. A plain number is
        taken in SI base units, except an angle, which is in radians and must lie in [-2π, 2π].
    dimension : str
        One of :data:`DIMENSIONS`: ``"length"`` (m), ``"area"`` (m²), ``"pressure"`` (Pa),
        ``"bending_stiffness"`` (N m²), ``"force"`` (N), ``"moment"`` (N m),
        ``"force_per_length"`` (N/m), ``"magnetic_field"`` (A/m; a flux density in tesla is
        converted as H = B/μ0), ``"magnetic_moment"`` (A m²), ``"density"`` (kg/m³),
        ``"acceleration"`` (m/s²), ``"angle"`` (rad), ``"field_rate"`` (A/m/s; T/s converted as
        B/μ0), ``"angular_rate"`` (rad/s), ``"current_rate"`` (A/s), ``"speed"`` (m/s),
        ``"dimensionless"``.
    field_name : str
        Dotted name of the configuration field, used in error messages.

    Returns
    -------
    float
        The value in the SI unit of ``dimension`` (``DIMENSIONS[dimension].unit``).

    Raises
    ------
    QuantityError
        ``"<field_name>: <reason>"`` for a non-finite value, an unknown unit, a unit of the wrong
        dimension, an angle given as a plain number outside [-2π, 2π], or an angle with a unit
        beyond ±:data:`MAX_ANGLE_DEG` degrees (reported in the unit it was given in).
    """
    if dimension not in DIMENSIONS:
        raise KeyError(f"unknown dimension {dimension!r} (known: {', '.join(DIMENSIONS)})")
    dim = DIMENSIONS[dimension]
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise QuantityError(
            field_name, f"expected {dim.description} (e.g. '{dim.example}'), got {value!r}")

    plain = _plain_number(value)
    if plain is not None:
        _check_finite(plain, value, field_name)
        if dimension == "angle" and abs(plain) > _TWO_PI:
            raise QuantityError(
                field_name,
                f"{_short(field_name)} = {value} looks like degrees: write '{value} deg' "
                "or radians within [-2π, 2π]")
        return plain

    return _angle_in_range(_text_to_si(str(value), dimension, field_name), dimension, str(value),
                           field_name)


@functools.lru_cache(maxsize=4096)
def _text_to_si(text: str, dimension: str, field_name: str) -> float:
    """:func:`parse_quantity` of a string (memoised: a study validates the same "30 deg" at every
    point, and pint's parser costs ~0.2 ms; errors are raised, never cached)."""
    dim = DIMENSIONS[dimension]
    if len(text) <= _MAX_LENGTH:
        common = _common_unit_value(text, dimension)
        if common is not None:
            return _check_finite(common, text, field_name)
    q = _parse_string(text, dim, field_name)
    return _check_finite(_to_si(q, text, dimension, dim, field_name), text, field_name)


def _angle_in_range(x: float, dimension: str, text: str, field_name: str) -> float:
    return _check_angle_text(x, text, field_name) if dimension == "angle" else x


def _to_si(q, text: str, dimension: str, dim: _Dimension, field_name: str) -> float:
    """``q`` in the SI unit of ``dimension`` (may overflow to inf: "1e308 km"; checked by the caller)."""
    u = registry()
    if dimension == "magnetic_field" and q.dimensionality == u.tesla.dimensionality:
        return float(q.to(u.tesla).magnitude) / MU0
    if dimension == "field_rate" and q.dimensionality == (u.tesla / u.second).dimensionality:
        return float(q.to(u.tesla / u.second).magnitude) / MU0
    if dimension == "angular_rate":
        if q.to_base_units().units not in (u.radian / u.second, 1 / u.second):
            raise _wrong_dimension(text, q, dim, field_name)
        return float(q.to(u.radian / u.second).magnitude)
    if dimension == "angle":
        if not (q.unitless or _is_angle_unit(q)):
            raise _wrong_dimension(text, q, dim, field_name)
        return float(q.to(u.radian).magnitude)
    if dimension == "dimensionless" and _is_angle_unit(q):
        raise _wrong_dimension(text, q, dim, field_name)
    target = u.Unit(dim.unit) if dim.unit else u.dimensionless
    if q.dimensionality != target.dimensionality:
        raise _wrong_dimension(text, q, dim, field_name)
    return float(q.to(target).magnitude)
