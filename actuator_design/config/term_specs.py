"""The scene's ``terms:``: energy terms beyond the built-in field, loads and bending, either a list
of entries ``{type: <term>, <parameter>: <value>, …}`` or a mapping ``{<term>: {<parameter>: <value>,
…}}``, whose values a sweep study addresses as ``terms.<term>.<parameter>`` (the terms shipped are
listed in docs/guide/units_and_scenes.md; this module names none of them).

A dimensionless scene takes plain numbers (the term's dimensionless parameters, THEORY §5); a
physical scene takes values with units, read by the parameter's dimensionless unit: ``B0/l^4`` is a
stiffness per area (``"2 kPa"``, divided by B0/ℓ⁴), ``B0/l^3`` a force per length (``"0.1 N/m"``),
``B0/l^2`` a force, ``B0/l`` a moment, ``rad`` an angle, ``1`` a plain number. The terms available
are the registered plug-in terms (:func:`actuator_design.physics.registry.plugin_names`).
"""
from __future__ import annotations

from typing import Any, Optional, Tuple

from pydantic import Field

from actuator_design.config.errors import error
from actuator_design.model.units import parse_quantity
from actuator_design.physics.registry import TermConfigError, parse_term_config

__all__ = ["MAX_TERMS", "TermEntries", "terms_field", "terms_of", "check_terms"]

#: at most this many entries (a scene with more is not a rod model but a typo or an attack)
MAX_TERMS = 16
TermEntries = Any  # a list or a mapping, checked by :func:`terms_of` (its messages name the term)


def terms_field():
    return Field(default=None)


#: ``B0/l^n`` → the dimension of its physical value (N m^(2−n))
_B0_DIMENSIONS = {"B0/l": ("moment", 1), "B0/l^2": ("force", 2), "B0/l^3": ("force_per_length", 3),
                  "B0/l^4": ("pressure", 4)}


def _physical_converter(length: float, b0: float):
    """(Parameter, value, key) -> the dimensionless value of a value given with units."""
    def convert(p, value, key):
        if p.unit in _B0_DIMENSIONS:
            dim, n = _B0_DIMENSIONS[p.unit]
            return parse_quantity(value, dim, key) * length ** n / b0
        if p.unit == "rad":
            return parse_quantity(value, "angle", key)
        if p.unit == "1":
            return parse_quantity(value, "dimensionless", key)
        raise ValueError(f"its unit {p.unit} has no physical reading; give the term in a dimensionless scene")
    return convert


def terms_of(entries, length: Optional[float] = None, b0: Optional[float] = None) -> Tuple:
    """The scene's ``extra_terms`` (``TermValues``) from the YAML entries.

    Parameters
    ----------
    entries : list of dict or None
    length, b0 : float, optional
        ℓ (m) and B0 (N m²) of a physical scene: values are then read with units.

    Raises
    ------
    pydantic_core.PydanticCustomError
        Naming ``terms[i].<key>`` (a configuration error).
    """
    if not entries:
        return ()

    if not isinstance(entries, (list, dict)):
        raise error(f"expected a list of {{type: <term>, ...}} entries or a mapping {{<term>: {{...}}}}, "
                    f"got {entries!r:.80}", "terms")
    if len(entries) > MAX_TERMS:
        raise error(f"at most {MAX_TERMS} terms, got {len(entries)}", "terms")
    if isinstance(entries, dict):  # {name: {values}}: each entry named by its term
        for name, values in entries.items():
            if values is not None and not isinstance(values, dict):
                raise error(f"expected a mapping of the term's parameters to values, got {values!r:.80}",
                            f"terms.{name}")
            if values and "type" in values:
                raise error("the mapping form names the term by its key: remove 'type' (or use the list form)",
                            f"terms.{name}.type")
        items = [(f"terms.{name}", {"type": name, **(values or {})}) for name, values in entries.items()]
    else:
        items = [(f"terms[{i}]", entry) for i, entry in enumerate(entries)]
    convert = None if length is None else _physical_converter(length, b0)
    out, seen = [], set()
    for where, entry in items:
        try:
            tv = parse_term_config(entry, convert)
        except TermConfigError as err:
            raise error(err.detail, f"{where}.{err.key}" if where.startswith("terms[") or err.key != "type"
                        else where) from None
        if tv.name in seen:
            raise error(f"the term {tv.name!r} is listed twice", f"{where}.type")
        seen.add(tv.name)
        out.append(tv)
    return tuple(out)


def check_terms(entries, length: Optional[float] = None, b0: Optional[float] = None) -> None:
    """Validate the entries (:func:`terms_of`) inside a model validator."""
    terms_of(entries, length, b0)
