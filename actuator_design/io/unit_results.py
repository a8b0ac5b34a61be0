"""The user's units beside the results of ``solve``, ``equilibria``, ``continue``, ``critical``,
``map`` and ``phase`` (a physical scene only; nothing is added for a dimensionless one).

The conversions are :class:`~actuator_design.io.user_units.UserUnits`'s (THEORY §5): lengths x = x̂ ℓ in the unit
``rod.length`` is written in, forces in B0/ℓ² → N, moments and energies in B0/ℓ → N m and J,
curvatures in 1/ℓ → rad per length unit, the first integral H of the phase plane (energy per
length, B0/ℓ²) → J/m, and the field group h → μ0 H in mT (μ0 H = μ0 h / (dh/dH)). A lens
parameter (``--param``) is converted by :func:`~actuator_design.io.user_units.parameter_physical`; one without a
physical unit (an angle, h_r, or a field group on a scene without a field scale) gets a note
instead of a number. Every function here adds keys; none renames or removes one.
"""
from __future__ import annotations

from typing import Dict, Iterable, List, Optional, Tuple

from actuator_design.io.display import number
from actuator_design.io.unit_columns import length_noise
from actuator_design.io.user_units import (VALUE_KEY_UNITS, parameter_physical, parameter_unit_label,
                                           physical_value_keys)
from actuator_design.model.units import MU0
from actuator_design.physics import parameters as lens
from actuator_design.physics.parameters import parameter
from actuator_design.physics.registry import registered_terms, term_class

__all__ = ["units_line", "unit_suffix", "tip_in", "length_text", "parameter_conversion",
           "value_text", "scene_physical", "scene_text", "point_physical", "add_point_units",
           "physical_header", "curvature_per_unit", "state_text", "state_columns", "state_values",
           "state_csv_note", "command_physical", "values_in_unit", "column_note"]

#: Column and key suffix of each unit a parameter is reported in.
_SUFFIX = {"mT": "mT", "N": "N", "N m": "N_m", "N/m": "N_per_m", "Pa": "Pa"}


def units_line(units) -> str:
    """``lengths in mm (as rod.length), fields as mu0 H in mT, forces in N, moments in N m,
    energies in J`` (with the scene's length unit)."""
    return (f"lengths in {units.length_unit} (as rod.length), fields as mu0 H in mT, forces in N, "
            "moments in N m, energies in J")


def unit_suffix(label: str) -> str:
    """The suffix of a key or CSV column in unit ``label``: ``mT``, ``N``, ``N_m``, ``N_per_m``, ``Pa``."""
    return _SUFFIX[label]


def tip_in(tip: Dict[str, float], units) -> Dict[str, float]:
    """``{"x", "y"}`` of a tip in rod lengths → in the scene's length unit."""
    return {"x": units.length(tip["x"]), "y": units.length(tip["y"])}


def length_text(x_user: float, units) -> str:
    """A length already in the user's unit, printed (round-off of zero as 0)."""
    return number(x_user, ".6g", noise=length_noise(units))


def curvature_per_unit(kappa: float, units) -> float:
    """A curvature (rad per rod length, e.g. γ = θ'(0)) in rad per length unit."""
    return float(kappa) / units.length(1.0)


def _param(name):
    return parameter(name) if isinstance(name, str) else name


def parameter_conversion(name, units) -> Tuple[Optional[str], Optional[str]]:
    """``(unit, note)`` of lens parameter ``name`` on a physical scene: the unit its values are
    reported in (``"mT"`` as μ0 H, ``"N"``, ``"N m"``, ``"N/m"``) and None, or None and one sentence
    saying why there is none (an angle; a field group without a field scale; h_r, h_pos)."""
    p = _param(name)
    unit = parameter_unit_label(p, units)
    if unit is not None:
        return unit, None
    if p.field_magnitude or p.remanent_field:
        return None, (f"{p.name} stays dimensionless: this scene has no field scale "
                      f"({p.name} per A/m is 0 in this scene's material)")
    if p.unit == "rad":
        return None, f"{p.name} is an angle: reported in rad, it has no other unit"
    return None, f"{p.name} has no physical unit here: it stays dimensionless ({p.unit})"


def value_text(name, value: float, units) -> Optional[str]:
    """``mu0 H = 25 mT`` (``h``; ``h2``: of √h2), ``p = 7e-05 N``, ``m_tip = 1e-06 N m`` of a
    parameter value; None without a physical unit."""
    p = _param(name)
    unit = parameter_unit_label(p, units)
    if unit is None:
        return None
    v = number(parameter_physical(p, value, units))
    return f"mu0 H = {v} mT" if unit == "mT" else f"{p.name} = {v} {unit}"


def scene_physical(scene, units) -> Dict[str, object]:
    """The scene's field and loads in the user's units: ``field_mT`` and ``field_A_per_m`` (of h,
    when the scene converts a field), ``tip_force_N`` [fx, fy], ``tip_moment_N_m``,
    ``distributed_load_N_per_m`` [qx, qy] (those the scene has)."""
    out: Dict[str, object] = {}
    if getattr(scene, "field", None) is not None:
        if units.has_field:
            out["field_mT"] = units.field_mT(scene.h)
        else:  # a hard-magnetic rod: the field of its remanent group (THEORY §9)
            for p in lens.parameters().values():
                if p.remanent_field and _present(scene, p) and p.get(scene) and units.converts_field_of(p.name):
                    out["field_mT"] = parameter_physical(p, p.get(scene), units)
                    break
        if "field_mT" in out:
            out["field_A_per_m"] = out["field_mT"] * 1e-3 / MU0
    for cls in registered_terms():  # the loads, each in N, N m, N/m (or Pa): tip_force_N, ...
        load = _load_values(cls, scene, units)
        if load is not None:
            out[load[0]] = load[1]
    return out


def load_units(units) -> Dict[str, str]:
    """The unit of every load key :func:`scene_physical` can write (``tip_force_N``: N), one per
    registered term whose values are all loads of one unit."""
    keys = (_load_key(cls, units) for cls in registered_terms())
    return {key[0]: key[1] for key in keys if key is not None}


#: the suffix of a load's key in :func:`scene_physical` by its physical unit
_LOAD_SUFFIX = {"N": "N", "N m": "N_m", "N/m": "N_per_m", "Pa": "Pa"}


def _present(scene, p) -> bool:
    return p.term is None or term_class(p.term).present(scene)


def _load_key(cls, units):
    """``(<term>_<unit suffix>, unit, parameters)`` of a term whose values (``scalar_params``) are
    all loads of one unit: a force, a moment, a force per length or per area; None otherwise."""
    by_slot: Dict[str, object] = {}
    for p in cls.parameters:
        by_slot.setdefault(p.slot, p)
    params = [by_slot.get(slot) for slot in cls.scalar_params]
    if not params or None in params:
        return None
    labels = {parameter_unit_label(p, units) for p in params}
    label = labels.pop() if len(labels) == 1 else None
    if label not in _LOAD_SUFFIX:
        return None
    return f"{cls.name}_{_LOAD_SUFFIX[label]}", label, params


def _load_values(cls, scene, units):
    """``(key, value or [values])`` of the load a term of ``scene`` applies, in the user's units
    (:func:`_load_key`); None when the scene lacks the term or its single value is zero."""
    key = _load_key(cls, units)
    if key is None or not cls.present(scene):
        return None
    values = [parameter_physical(p, p.get(scene), units) for p in key[2]]
    if len(values) == 1 and values[0] == 0.0:
        return None
    return key[0], values if len(values) > 1 else values[0]


def scene_text(scene, units) -> str:
    """``mu0 H = 25 mT, tip force (0, 7e-05) N`` (what :func:`scene_physical` has), or the note
    that the field has no scale."""
    d = scene_physical(scene, units)
    parts = []
    if "field_mT" in d:
        parts.append(f"mu0 H = {number(d['field_mT'])} mT")
    elif getattr(scene, "field", None) is not None:
        parts.append("h stays dimensionless (this scene has no field scale)")
    for cls in registered_terms():  # the loads: "tip force (0, 7e-05) N", "tip moment 1e-06 N m"
        key = _load_key(cls, units)
        if key is not None and key[0] in d:
            v = d[key[0]]
            text = "(" + ", ".join(number(x) for x in v) + ")" if isinstance(v, list) else number(v)
            parts.append(f"{cls.load_name or cls.name.replace('_', ' ')} {text} {key[1]}")
    return ", ".join(parts)


def point_physical(tip: Dict[str, float], energy: float, units,
                   gamma: Optional[float] = None) -> Dict[str, object]:
    """``{"tip": {x, y}, "energy_J"[, "gamma_rad_per_<unit>"]}`` of one state."""
    out: Dict[str, object] = {"tip": tip_in(tip, units), "energy_J": float(energy) * units.moment_scale}
    if gamma is not None:
        out[f"gamma_rad_per_{units.length_unit}"] = curvature_per_unit(gamma, units)
    return out


def add_point_units(items: Iterable[dict], param, units) -> None:
    """Add the user's units to every point of a branch or critical point (dicts of
    ``Branch.to_dict``/``CriticalPoint.to_dict``), in place: ``field_mT`` and ``field_A_per_m``
    (or ``value_N``, ...) beside ``value`` (:func:`~actuator_design.io.user_units.physical_value_keys`) and
    ``physical`` {tip {x, y} in the length unit, energy_J}."""
    p = _param(param)
    for item in items:
        if not isinstance(item, dict):
            continue
        if isinstance(item.get("value"), (int, float)):
            item.update(physical_value_keys(p, item["value"], units))
        tip = item.get("tip") if isinstance(item.get("tip"), dict) else (
            {"x": item["tip_x"], "y": item["tip_y"]} if "tip_x" in item else None)
        if tip is not None and "energy" in item:
            item["physical"] = point_physical(tip, item["energy"], units)


def physical_header(units, params: Iterable = (), extra: Optional[Dict[str, str]] = None) -> Dict[str, object]:
    """The top-level ``physical`` of a command's JSON: ``length_unit``, ``units`` (what each key
    in the user's units is in), ``parameters`` {name: unit} of ``params`` with a physical unit and
    ``notes`` for those without one."""
    u = units.length_unit
    names: Dict[str, Optional[str]] = {}
    notes: List[str] = []
    for name in params:
        unit, note = parameter_conversion(name, units)
        names[_param(name).name] = unit
        if note is not None:
            notes.append(note)
    described = {"tip": u, "energy_J": "J", "field_mT": "mT (mu0 H)", "field_A_per_m": "A/m",
                 **VALUE_KEY_UNITS, f"gamma_rad_per_{u}": f"rad/{u}", **load_units(units), **(extra or {})}
    return {"length_unit": u, "units": described,
            "parameters": {n: (unit + " (mu0 H)" if unit == "mT" else unit) for n, unit in names.items()
                           if unit is not None},
            "notes": notes}


def state_text(tip: Dict[str, float], energy: float, units, gamma: Optional[float] = None) -> str:
    """``tip = (29.6292, 4.28502) mm, energy = -3.83e-06 J[, gamma = 0.0141 rad/mm]`` of one state
    (round-off of zero printed as 0)."""
    u = units.length_unit
    text = (f"tip = ({length_text(units.length(tip['x']), units)}, "
            f"{length_text(units.length(tip['y']), units)}) {u}, energy = "
            f"{number(float(energy) * units.moment_scale, '.6g', 1e-12 * units.moment_scale)} J")
    if gamma is not None:
        text += f", gamma = {number(curvature_per_unit(gamma, units), '.6g', 1e-12 / units.length(1.0))} rad/{u}"
    return text


def state_columns(units) -> List[str]:
    """CSV columns of one state in the user's units: ``tip_x_<unit>, tip_y_<unit>, energy_J,
    gamma_rad_per_<unit>`` (see :func:`state_values`)."""
    u = units.length_unit
    return [f"tip_x_{u}", f"tip_y_{u}", "energy_J", f"gamma_rad_per_{u}"]


def state_values(tip: Dict[str, float], energy: float, gamma: float, units) -> List[float]:
    """The values of :func:`state_columns` of one state."""
    return [units.length(tip["x"]), units.length(tip["y"]), float(energy) * units.moment_scale,
            curvature_per_unit(gamma, units)]


def state_csv_note(units) -> str:
    """The CSV comment's part on :func:`state_columns`."""
    u = units.length_unit
    return (f"tip_x_{u}, tip_y_{u} in {u} (the unit of rod.length); energy_J in J; "
            f"gamma_rad_per_{u} in rad/{u}")


def command_physical(scene, units, params: Iterable = ()) -> Dict[str, object]:
    """The top-level ``physical`` of a command on one scene: :func:`physical_header` and the scene's
    field and loads (:func:`scene_physical`)."""
    return {**physical_header(units, params), **scene_physical(scene, units)}


def values_in_unit(name, values: Iterable[float], units) -> Optional[Tuple[str, List[float]]]:
    """``(key suffix, values)`` of lens parameter ``name``'s ``values`` in its physical unit
    (``"mT"``: μ0 H, of √h2 for h2; ``"N"``, ``"N_m"``, ``"N_per_m"``), or None without one."""
    unit = parameter_conversion(name, units)[0]
    if unit is None:
        return None
    p = _param(name)
    return unit_suffix(unit), [parameter_physical(p, float(v), units) for v in values]


def column_note(name, units) -> str:
    """The CSV comment on the column of ``name`` in its unit: ``h2_mT: mu0 H of sqrt(h2) in mT``,
    ``p_N: p in N``; empty without a unit."""
    unit = parameter_conversion(name, units)[0]
    if unit is None:
        return ""
    p = _param(name)
    col = f"{p.name}_{unit_suffix(unit)}"
    if unit == "mT":
        return f"{col}: mu0 H{' of sqrt(' + p.name + ')' if p.transform == 'sqrt' else ''} in mT"
    return f"{col}: {p.name} in {unit}"
