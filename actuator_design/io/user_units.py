"""Results in the user's units: the scene's length unit, fields in A/m and mT, stiffness in N/m.

A physical scene (``type: physical``) carries :class:`~actuator_design.model.scene.Scales`; :class:`UserUnits` adds the
length unit the user wrote in the YAML (``rod.length: 27.5 mm`` → ``mm``) and converts both ways:

* lengths: x [unit] = x̂ ℓ / (metres per unit), x̂ in rod lengths;
* the field: h ∝ H (THEORY §5: h² = μ0 χ̄ H² A ℓ² / (2 B0)), so H = h / (dh/dH) with
  dh/dH = ``Scales.h_per_field`` [per A/m], and the flux density quoted for it is B = μ0 H
  (the field in air, :data:`~actuator_design.model.units.MU0`), reported in mT;
* loads: forces in B0/ℓ², moments in B0/ℓ, stiffness and distributed loads in B0/ℓ³.

:func:`parameter_from_text` reads a command-line value of a lens parameter
(:mod:`~actuator_design.physics.parameters`) that may carry a unit (``"2 mT"``, ``"5 kA/m"``, ``"30 deg"``, ``"1 mN"``)
and returns it in the parameter's dimensionless unit; a value with a unit for a parameter without
a physical meaning is one clear error.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Optional, Tuple

from actuator_design.model.units import MU0, angle_range_problem, parse_quantity, registry

__all__ = ["VALUE_KEY_UNITS", "UserUnits", "user_units", "length_unit_of", "parameter_from_text",
           "parameter_physical", "parameter_unit_label", "physical_value_keys", "add_physical_values",
           "pair_from_text"]


@dataclass(frozen=True)
class UserUnits:
    """Conversions between a physical scene's dimensionless results and the user's units.

    Attributes
    ----------
    length_m : float
        Rod length ℓ, m.
    length_unit : str
        The length unit of the user's YAML (``"mm"``, ``"m"``, ``"cm"``, …).
    metres_per_unit : float
        Size of ``length_unit`` in m (1e-3 for mm).
    h_per_field : float
        dh/dH, per A/m (0 when the scene cannot convert a field, e.g. χ̄ = 0).
    stiffness_scale : float
        B0/ℓ³, N/m.
    force_scale : float
        B0/ℓ², N.
    moment_scale : float
        B0/ℓ, N m.
    per_field : tuple of (str, float)
        Every group the applied field drives, per A/m, by lens name (``Scales.per_field``): the
        field of a remanent group (THEORY §9; e.g. a hard-magnetic rod whose soft group has no
        scale, χ̄ = 0) is read through it.
    """

    length_m: float
    length_unit: str
    metres_per_unit: float
    h_per_field: float
    stiffness_scale: float
    force_scale: float
    moment_scale: float
    per_field: Tuple[Tuple[str, float], ...] = ()

    @property
    def has_field(self) -> bool:
        """Whether a field group h converts to A/m (dh/dH > 0)."""
        return self.h_per_field > 0.0

    def length(self, x_rod: float) -> float:
        """A length in rod lengths → the user's length unit."""
        return float(x_rod) * self.length_m / self.metres_per_unit

    def length_to_rod(self, x_user: float) -> float:
        """A length in the user's unit → rod lengths."""
        return float(x_user) * self.metres_per_unit / self.length_m

    def field_A_per_m(self, h: float) -> float:
        """The field strength H (A/m) of the group ``h`` (h ∝ H)."""
        return float(h) / self.h_per_field

    def field_mT(self, h: float) -> float:
        """μ0 H in mT for the group ``h``."""
        return self.field_A_per_m(h) * MU0 * 1e3

    def group_per_field(self, name: str) -> float:
        """d(group)/dH of the lens group ``name``, per A/m (0 when the field does not drive it)."""
        return dict(self.per_field).get(name, 0.0)

    def converts_field_of(self, name: str) -> bool:
        """Whether a value of the field-driven group ``name`` converts to a field (d/dH > 0)."""
        return self.group_per_field(name) > 0.0

    def field_mT_of(self, name: str, group: float) -> float:
        """μ0 H in mT of a value ``group`` of the lens group ``name`` that is ∝ H (THEORY §9)."""
        return float(group) / self.group_per_field(name) * MU0 * 1e3

    def h_from_field(self, H_A_per_m: float) -> float:
        """The group h of a field strength H in A/m."""
        return float(H_A_per_m) * self.h_per_field

    def h_from_mT(self, B_mT: float) -> float:
        """The group h of a flux density μ0 H given in mT."""
        return self.h_from_field(float(B_mT) * 1e-3 / MU0)


def length_unit_of(raw: Optional[dict]) -> tuple:
    """``(unit, metres_per_unit)`` of ``scene.rod.length`` as written in the raw YAML dict.

    A plain number is in m (:mod:`~actuator_design.model.units`); anything unreadable falls back to ``("m", 1.0)``.
    """
    try:
        text = raw["scene"]["rod"]["length"]
    except (KeyError, TypeError):
        return "m", 1.0
    if not isinstance(text, str):
        return "m", 1.0
    try:
        parse_quantity(text, "length", "scene.rod.length")  # the same checks as the config
        ureg = registry()
        q = ureg.Quantity(text)
        unit = ureg.Quantity(1.0, q.units)
        return f"{q.units:~}".replace(" ", ""), float(unit.to("m").magnitude)
    except Exception:  # QuantityError, or pint's own errors: the config reports those itself
        return "m", 1.0


def user_units(scene, raw: Optional[dict] = None) -> Optional[UserUnits]:
    """The conversions of a physical ``scene`` (``None`` for a dimensionless one)."""
    sc = getattr(scene, "scales", None)
    if sc is None:
        return None
    unit, per = length_unit_of(raw)
    return UserUnits(length_m=sc.length, length_unit=unit, metres_per_unit=per,
                     h_per_field=float(sc.h_per_field), stiffness_scale=sc.stiffness,
                     force_scale=sc.force, moment_scale=sc.moment,
                     per_field=tuple((name, float(v)) for name, v in getattr(sc, "per_field", ())))


# -- parameters of the lens with a physical meaning ----------------------------------------------------
def _kind(param) -> Optional[str]:
    """How a lens parameter maps to a physical quantity: "field", "field2", "field_r" (h_r ∝ H),
    "angle", "force", "moment", "force_per_length", "force_per_area" (a stiffness per area, B0/ℓ⁴,
    such as an elastic bed's) or None (no physical meaning here)."""
    if param.remanent_field:
        return "field_r"
    if param.field_magnitude:
        return "field2" if param.transform == "sqrt" else "field"
    return {"rad": "angle", "B0/l^2": "force", "B0/l": "moment", "B0/l^3": "force_per_length",
            "B0/l^4": "force_per_area"}.get(param.unit)


def parameter_unit_label(param, units: Optional[UserUnits]) -> Optional[str]:
    """The physical unit a parameter's values are reported in (``"mT"``, ``"N"``, …), or None."""
    kind = _kind(param)
    if units is None or kind is None or kind == "angle":
        return None
    if kind in ("field", "field2"):
        return "mT" if units.has_field else None
    if kind == "field_r":
        return "mT" if units.converts_field_of(param.name) else None
    return {"force": "N", "moment": "N m", "force_per_length": "N/m", "force_per_area": "Pa"}[kind]


def parameter_physical(param, value: float, units: Optional[UserUnits]) -> Optional[float]:
    """A dimensionless parameter value in :func:`parameter_unit_label`'s unit (``h2``: the field of
    √h2 in mT), or None when it has no physical counterpart."""
    label = parameter_unit_label(param, units)
    if label is None:
        return None
    kind = _kind(param)
    if kind == "field":
        return units.field_mT(value)
    if kind == "field2":
        return units.field_mT(math.sqrt(max(float(value), 0.0)))
    if kind == "field_r":
        return units.field_mT_of(param.name, value)
    return float(value) * _scale(kind, units)


def parameter_from_text(text, param, units: Optional[UserUnits], flag: str) -> float:
    """A value of ``param`` from the command line: a plain number (its dimensionless unit) or a
    quantity with a unit, converted through the scene's scales.

    Parameters
    ----------
    text : str or float
        ``"2.5"``, ``"2 mT"``, ``"5 kA/m"``, ``"30 deg"``, ``"1 mN"``, ``"0.1 mN m"``, ``"0.2 N/m"``.
    param : parameters.Parameter
        The lens parameter (``h``: the field strength H → h = H dh/dH; ``h2``: h²).
    units : UserUnits or None
        The scene's conversions (None: a dimensionless scene; only angles may carry units).
    flag : str
        The option name for error messages (``"--window"``).

    Raises
    ------
    ValueError
        One line naming ``flag``: a unit for a parameter without a physical meaning, a unit on a
        dimensionless scene, a unit of the wrong dimension, a non-finite value, an angle beyond
        ±MAX_ANGLE_DEG degrees (reported in the unit it was given in:
        :func:`~actuator_design.model.units.angle_range_problem`).
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
    else:
        s = str(text).strip()
        try:
            value = float(s)
        except ValueError:
            return _with_unit(s, param, units, flag)
    if not math.isfinite(value):
        raise ValueError(f"{flag}: must be a finite number, got {text!r}")
    if _kind(param) == "angle":  # a plain number is in the parameter's unit, rad
        problem = angle_range_problem(value, "rad")
        if problem is not None:
            raise ValueError(f"{flag}: {problem}")
    return value


def _with_unit(text: str, param, units: Optional[UserUnits], flag: str) -> float:
    if not re.match(r"^\s*[+-]?(\d|\.\d)", text):
        raise ValueError(f"{flag}: expected a number or a quantity such as '2 mT', got {text!r}")
    kind = _kind(param)
    if kind is None:
        raise ValueError(f"{flag}: {param.name} is dimensionless ({param.unit}) and has no physical unit; "
                         f"give a plain number, got {text!r}")
    if kind == "angle":
        return parse_quantity(text, "angle", flag)
    if units is None:
        raise ValueError(f"{flag}: {text!r} has a unit, but the scene is dimensionless "
                         f"(give {param.name} as a plain number, or use a `type: physical` CONFIG)")
    if kind in ("field", "field2"):
        if not units.has_field:
            raise ValueError(f"{flag}: this scene cannot convert a field to {param.name} "
                             f"({param.name} per A/m is 0 in this scene's material, e.g. without "
                             "susceptibility)")
        h = units.h_from_field(parse_quantity(text, "magnetic_field", flag))
        return h * h if kind == "field2" else h
    if kind == "field_r":
        if not units.converts_field_of(param.name):
            raise ValueError(f"{flag}: this scene cannot convert a field to {param.name} "
                             f"({param.description}: 0 per A/m in this scene's material)")
        return parse_quantity(text, "magnetic_field", flag) * units.group_per_field(param.name)
    dim = "pressure" if kind == "force_per_area" else kind
    return parse_quantity(text, dim, flag) / _scale(kind, units)


def _scale(kind: str, units: UserUnits) -> float:
    """The SI value of one dimensionless unit of a load-like parameter: B0/ℓⁿ."""
    return {"force": units.force_scale, "moment": units.moment_scale, "force_per_length": units.stiffness_scale,
            "force_per_area": units.stiffness_scale / units.length_m}[kind]


_KEYS = {"force": "value_N", "moment": "value_N_m", "force_per_length": "value_N_per_m",
         "force_per_area": "value_Pa"}
#: The JSON key of a load-like parameter's value in its physical unit → that unit (one table for
#: every command's texts and ``physical.units``).
VALUE_KEY_UNITS = {"value_N": "N", "value_N_m": "N m", "value_N_per_m": "N/m", "value_Pa": "Pa"}


def physical_value_keys(param, value: float, units: Optional[UserUnits]) -> dict:
    """JSON keys to add beside a parameter value: ``field_mT`` and ``field_A_per_m`` for the field
    groups (h: H = h / (dh/dH); h2: of √h2), ``value_N``/``value_N_m``/``value_N_per_m`` for loads,
    ``value_Pa`` for a stiffness per area;
    empty for a dimensionless scene or a parameter without a physical unit."""
    label = parameter_unit_label(param, units)
    if label is None or not math.isfinite(float(value)):
        return {}
    kind = _kind(param)
    if kind in ("field", "field2"):
        h = float(value) if kind == "field" else math.sqrt(max(float(value), 0.0))
        return {"field_mT": units.field_mT(h), "field_A_per_m": units.field_A_per_m(h)}
    if kind == "field_r":
        mT = units.field_mT_of(param.name, value)
        return {"field_mT": mT, "field_A_per_m": mT * 1e-3 / MU0}
    return {_KEYS[kind]: parameter_physical(param, value, units)}


def add_physical_values(items, param, units: Optional[UserUnits], key: str = "value") -> None:
    """Add :func:`physical_value_keys` of ``item[key]`` to every dict in ``items`` (in place; the
    existing keys are kept)."""
    for item in items:
        if isinstance(item, dict) and isinstance(item.get(key), (int, float)):
            item.update(physical_value_keys(param, item[key], units))


def pair_from_text(text: str, param, units: Optional[UserUnits], flag: str) -> tuple:
    """``"A,B"`` (each a number or a quantity, e.g. ``"2 mT,6 mT"``) → (a, b) with a < b, in the
    parameter's dimensionless unit (:func:`parameter_from_text`)."""
    parts = [t for t in str(text).split(",")]
    if len(parts) != 2:
        raise ValueError(f"{flag}: expected A,B (two values, e.g. '0.5,1.5' or '2 mT,6 mT'), got {text!r}")
    a, b = (parameter_from_text(t.strip(), param, units, flag) for t in parts)
    if not a < b:
        raise ValueError(f"{flag}: need A < B, got {text!r}")
    return a, b
