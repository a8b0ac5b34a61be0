"""A lab's tolerance box around a design: what a real actuator's field and material may be.

Coils are accurate to a few per cent and aligned to a degree or two; χ̄ and E scatter from batch to
batch. A :class:`Tolerances` box holds the half-widths, :meth:`Tolerances.corners` lists the box's
corners as signed offsets, and :func:`perturb` turns a nominal scene and one offset into the scene
the lab may really have. How each tolerance enters the dimensionless groups (THEORY §5):

* field magnitude H → h ∝ H (and h_pos ∝ H), h_r ∝ H;
* susceptibility χ̄ → h ∝ √χ̄;
* Young's modulus E (B = E I) → h ∝ E^(-1/2), h_r ∝ 1/E, and every dead load p, f, m, q ∝ 1/E;
* field angle φ, fibre angle α(s) and clamp angle θ0 → additive offsets.

The field-magnitude tolerance also stands for the scatter of χ̄/E when the others are not given
(h² ∝ χ̄ H² / E), which is why the default box has only the field and its angle.
"""
from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, replace
from typing import Dict, List, Mapping, Optional, Tuple

from actuator_design.model.profiles import (Profile, constant_profile, expression_profile, legendre_profile,
                                            table_profile)
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import registered_terms, term_class, write_keeps_terms

__all__ = ["Tolerances", "perturb", "apply_deltas", "parse_tolerances", "scaled_slots", "scale_factor", "bending_scale",
           "axis_examples", "axis_label", "DEFAULT_AXES"]

#: the magnetic material's scatter axes, as the terms' physical parameters declare them (χ̄)
_MATERIAL = tuple(p for p in lens.physical_parameters().values() if p.tolerance)
#: name in the CLI/YAML → (attribute, kind): kind "rel" takes a percentage or fraction, "angle" takes
#: degrees ("2deg") or radians (a plain number)
_SPEC = {
    "field": ("field_rel", "rel"),
    "angle": ("angle", "angle"),
    "youngs_modulus": ("youngs_rel", "rel"),
    **{p.name: (p.tolerance, "rel") for p in _MATERIAL},
    "fibre_angle": ("fibre_angle", "angle"),
    "clamp_angle": ("clamp_angle", "angle"),
}
_ALIASES = {"E": "youngs_modulus", "youngs": "youngs_modulus", **{a: p.name for p in _MATERIAL for a in p.aliases},
            "fibre": "fibre_angle", "fiber": "fibre_angle", "fiber_angle": "fibre_angle", "clamp": "clamp_angle",
            "phi": "angle", "h": "field"}
#: the box every design holds over unless told otherwise (``--tolerance`` not given)
DEFAULT_AXES = ("field", "angle")


def axis_examples() -> str:
    """The tolerance axes besides the default box, each with an example half-width
    (``youngs_modulus=10%, ...``): what ``--tolerance`` also takes."""
    example = {"rel": "10%", "angle": "1deg"}
    return ", ".join(f"{name}={example[kind]}" for name, (_, kind) in _SPEC.items() if name not in DEFAULT_AXES)


#: how a message names an axis of the box where not by its name (``E`` for Young's modulus)
_LABELS = {"youngs_rel": "E", "fibre_angle": "fibre angle", "clamp_angle": "clamp angle"}


def _axis_name(attribute: str) -> str:
    """The name (``--tolerance NAME=...``) of the box's axis of :class:`Tolerances` ``attribute``."""
    return next(n for n, (a, _) in _SPEC.items() if a == attribute)


def axis_label(attribute: str) -> Tuple[str, bool]:
    """How a message names the box's axis of :class:`Tolerances` ``attribute`` (``"field_rel"``), and
    whether its half-width is relative (a percentage) rather than an angle."""
    return _LABELS.get(attribute, _axis_name(attribute)), _SPEC[_axis_name(attribute)][1] == "rel"


#: the largest half-widths accepted (a box beyond them is not a tolerance but another design)
_LIMITS = {"rel": 0.5, "angle": math.radians(45.0)}


@dataclass(frozen=True)
class Tolerances:
    """Half-widths of the tolerance box around a design (all ≥ 0).

    Attributes
    ----------
    field_rel : float
        Relative error of the field magnitude H (0.05 = ±5 %); also stands for χ̄/E scatter.
    angle : float
        Error of the field angle φ, rad (uniform fields only).
    youngs_rel, chi_rel : float
        Relative scatter of Young's modulus E and of the susceptibility χ̄.
    fibre_angle, clamp_angle : float
        Offsets of the fibre layout α(s) and of the clamp angle θ0, rad.
    """

    field_rel: float = 0.05
    angle: float = math.radians(2.0)
    youngs_rel: float = 0.0
    chi_rel: float = 0.0
    fibre_angle: float = 0.0
    clamp_angle: float = 0.0

    def __post_init__(self):
        for name, (attr, kind) in _SPEC.items():
            v = getattr(self, attr)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0.0 <= v <= _LIMITS[kind]):
                if kind == "rel":
                    raise ValueError(f"tolerance {name}: must be a number in [0, {_LIMITS[kind]:g}], got {v!r}")
                got = f"{math.degrees(v):.6g} deg" if isinstance(v, (int, float)) and math.isfinite(v) else repr(v)
                raise ValueError(f"tolerance {name}: must be an angle in [0, {math.degrees(_LIMITS[kind]):g} deg], "
                                 f"got {got}")  # echoed in degrees, the unit of the range

    @property
    def active(self) -> Tuple[str, ...]:
        """Attribute names with a nonzero half-width, in a fixed order."""
        return tuple(attr for attr, _ in _SPEC.values() if getattr(self, attr) > 0.0)

    def scaled(self, factor: float) -> "Tolerances":
        """The box with every half-width multiplied by ``factor`` (≥ 0)."""
        return Tolerances(**{attr: getattr(self, attr) * factor for attr, _ in _SPEC.values()})

    def corners(self) -> List[Dict[str, float]]:
        """The 2^k corners of the box as signed unit offsets {attribute: ±1} over the active axes."""
        act = self.active
        if not act:
            return []
        return [dict(zip(act, signs)) for signs in itertools.product((-1.0, 1.0), repeat=len(act))]

    def to_dict(self) -> Dict[str, float]:
        """The JSON contract: relative tolerances as fractions, angles in degrees."""
        return {"h_rel": self.field_rel, "phi_deg": math.degrees(self.angle),
                "youngs_rel": self.youngs_rel, "chi_rel": self.chi_rel,
                "fibre_deg": math.degrees(self.fibre_angle), "clamp_deg": math.degrees(self.clamp_angle)}

    def describe(self) -> str:
        parts = []
        for name, (attr, kind) in _SPEC.items():
            v = getattr(self, attr)
            if v > 0:
                parts.append(f"{name} ±{100 * v:g} %" if kind == "rel" else f"{name} ±{math.degrees(v):g} deg")
        return ", ".join(parts) or "none"


def _parse_value(name: str, kind: str, text: str) -> float:
    t = text.strip().lower().replace(" ", "")
    try:
        if kind == "rel":
            return float(t[:-1]) / 100.0 if t.endswith("%") else float(t)
        m = re.fullmatch(r"([-+0-9.eE]+)(deg|°|rad)?", t)
        if not m:
            raise ValueError
        v = float(m.group(1))
        return math.radians(v) if m.group(2) in ("deg", "°") else v
    except ValueError:
        unit = "a percentage such as 5% or a fraction such as 0.05" if kind == "rel" else \
            "an angle such as 2deg (a plain number is radians)"
        raise ValueError(f"tolerance {name}: cannot read {text!r}; expected {unit}") from None


def parse_tolerances(spec, base: Optional[Tolerances] = None) -> Tolerances:
    """Tolerances from ``"field=5%,angle=2deg"`` or a mapping (YAML ``study.tolerances``).

    Keys not given keep the values of ``base`` (default: the lab defaults, field ±5 %, angle ±2°);
    ``"none"`` gives the empty box. Unknown keys and unreadable values raise ``ValueError`` naming
    the key and what is allowed.
    """
    base = Tolerances() if base is None else base
    if isinstance(spec, str):
        if spec.strip().lower() in ("none", "0", ""):
            return Tolerances(field_rel=0.0, angle=0.0)
        items = []
        for part in spec.split(","):
            if part.strip().lower() in ("none", "0"):  # e.g. '--tolerance none --tolerance field=5%'
                raise ValueError(f"tolerance: {part.strip()!r} empties the box and stands alone; give it "
                                 f"without other tolerances (got {spec!r})")
            if "=" not in part:
                raise ValueError(f"tolerance: {part.strip()!r} is not NAME=VALUE "
                                 f"(names: {', '.join(_SPEC)})")
            k, v = part.split("=", 1)
            items.append((k.strip(), v.strip()))
    elif isinstance(spec, Mapping):
        items = [(str(k), str(v)) for k, v in spec.items()]
    else:
        raise ValueError(f"tolerance: expected 'name=value,...' or a mapping, got {type(spec).__name__}")
    values = {attr: getattr(base, attr) for attr, _ in _SPEC.values()}
    given = {}
    for key, text in items:
        name = _ALIASES.get(key, key)
        if name not in _SPEC:
            raise ValueError(f"tolerance {key!r}: unknown (allowed: {', '.join(_SPEC)})")
        if name in given:  # 'field=5%,field=10%': which one the user meant is not ours to guess
            raise ValueError(f"tolerance {key!r}: given twice ({given[name]!r} and {key + '=' + text!r}); "
                             "give each name once")
        given[name] = f"{key}={text}"
        attr, kind = _SPEC[name]
        values[attr] = _parse_value(name, kind, text)
    return Tolerances(**values)


def _shift_profile(p: Profile, delta: float) -> Profile:
    """α(s) + δ for every profile kind (exact: P_0 = 1 for the Legendre series)."""
    if delta == 0.0:
        return p
    if p.kind == "constant":
        return constant_profile(p.value + delta)
    if p.kind == "legendre":
        c = list(p.values) or [0.0]
        c[0] += delta
        return legendre_profile(c)
    if p.kind == "table":
        return table_profile(p.s, [v + delta for v in p.values])
    return expression_profile(f"({p.expression})+({delta!r})")


def perturb(scene: Scene, tol: Tolerances, offset: Mapping[str, float]) -> Scene:
    """The scene at ``offset`` (signed fractions of the half-widths, keys of :attr:`Tolerances.active`).

    Parameters
    ----------
    scene : Scene
        Nominal (dimensionless) scene.
    tol : Tolerances
    offset : mapping attribute -> value in [-1, 1]

    Returns
    -------
    Scene
        h scaled by (1 + δH)·√(1 + δχ)/√(1 + δE), loads by 1/(1 + δE), angles shifted.
    """
    return apply_deltas(scene, {attr: float(offset.get(attr, 0.0)) * getattr(tol, attr)
                                for attr, _ in _SPEC.values()})


def apply_deltas(scene: Scene, deltas: Mapping[str, float]) -> Scene:
    """The scene with signed changes applied: relative ones (``field_rel``, ``chi_rel``,
    ``youngs_rel``, fractions > −1) and angles (``angle``, ``fibre_angle``, ``clamp_angle``, rad).

    The relative changes scale every lens value of a present term by its power laws
    (:attr:`~actuator_design.physics.parameter.Parameter.field_power`, ``stiffness_power``,
    ``susceptibility_power``): a plug-in term's values follow E like the built-in loads."""
    g = {attr: float(deltas.get(attr, 0.0)) for attr, _ in _SPEC.values()}
    out = scene
    for p, value in _scaled_values(scene, g):
        out = p.write(out, value)
    if g["angle"] != 0.0:
        if not isinstance(scene.field, UniformField):
            raise ValueError("tolerance angle: the field angle can only be perturbed for a uniform field")
        out = out.with_values(phi=scene.phi + g["angle"])
    if g["fibre_angle"] != 0.0:
        out = replace(out, fibres=_shift_profile(scene.fibres, g["fibre_angle"]))
    if g["clamp_angle"] != 0.0:
        out = replace(out, theta0=scene.theta0 + g["clamp_angle"])
    return out


def bending_scale(deltas: Mapping[str, float]) -> float:
    """B'/B0 of a scene moved by ``deltas`` (:func:`apply_deltas`): a Young's modulus changed by δE
    changes the bending stiffness, the unit of the moved scene's energies, loads and stiffnesses
    (its groups are rescaled with b = 1 kept). A stiffness dp/dv1 computed on the moved scene is in
    units of B'/ℓ³; times this, in the nominal B0/ℓ³."""
    return 1.0 + float(deltas.get("youngs_rel", 0.0))


def scaled_slots() -> Tuple[lens.Parameter, ...]:
    """The lens parameters (one per NLP slot) whose values scale with the field, E or χ̄ by their
    power laws (f, e, c): what a relative tolerance moves, in lens order."""
    out, seen = [], set()
    for p in lens.parameters().values():
        if p.per_point or p.slot in seen:
            continue
        seen.add(p.slot)
        if p.field_power or p.stiffness_power or p.susceptibility_power:
            out.append(p)
    return tuple(out)


def scale_factor(p: lens.Parameter, deltas: Mapping[str, float]) -> float:
    """The factor (1 + δH)^f ((1 + δχ)^c / (1 + δE)^−e) on the value of ``p`` at the relative changes
    ``deltas`` (``field_rel``, ``chi_rel``, ``youngs_rel``), evaluated as :func:`apply_deltas` does
    (one square root of the whole ratio for a half power), for NLPs that scale a slot by it."""
    g = {attr: float(deltas.get(attr, 0.0)) for attr in ("field_rel", "chi_rel", "youngs_rel")}
    f, e, c = p.field_power, p.stiffness_power, p.susceptibility_power
    num, den = (1.0 + g["chi_rel"]) ** c, (1.0 + g["youngs_rel"]) ** (-e)
    if (2 * e) % 2 or (2 * c) % 2:
        ratio = (1.0 + g["chi_rel"]) ** (2 * c) / (1.0 + g["youngs_rel"]) ** (-2 * e)
        return (1.0 + g["field_rel"]) ** f * math.sqrt(ratio)
    if f:
        return (1.0 + g["field_rel"]) ** f * num / den
    return num / den


def _scaled_values(scene: Scene, g: Mapping[str, float]):
    """(lens parameter, new value) for every slot of a term ``scene`` has whose value scales with the
    field, E or χ̄ by its power laws (f, e, c): v (1 + δH)^f ((1 + δχ)^c / (1 + δE)^−e), evaluated
    as the tolerance box always has (h: v·((1 + δH)·√((1 + δχ)/(1 + δE))); h_r: v (1 + δH)/(1 + δE);
    a load: (1/(1 + δE))·v), so that a corner scene does not move by round-off. The scenario NLP
    multiplies its slots by :func:`scale_factor`, the same numbers up to one rounding.

    Raises
    ------
    ValueError
        A relative change of E or χ̄ and a term that does not declare how its values scale
        (``EnergyTerm.scaling_declared``): its values would silently stay fixed.
    """
    if g["youngs_rel"] or g["chi_rel"]:
        for cls in registered_terms():
            if not cls.scaling_declared and cls.present(scene):
                what = _axis_name("youngs_rel" if g["youngs_rel"] else "chi_rel")
                raise ValueError(f"tolerance {what}: the scene's energy term {cls.name!r} does not declare how its "
                                 "values scale with the material (EnergyTerm.scaling_declared)")
    for p in scaled_slots():
        v = p.get(scene)
        if v == 0.0 or (p.term is not None and not term_class(p.term).present(scene)
                        and not write_keeps_terms(p, scene, v)):
            continue  # nothing to scale, or a term's value stored while it is absent whose write would add it
        f, e, c = p.field_power, p.stiffness_power, p.susceptibility_power
        num, den = (1.0 + g["chi_rel"]) ** c, (1.0 + g["youngs_rel"]) ** (-e)
        if (2 * e) % 2 or (2 * c) % 2:  # a half power: one square root of the whole ratio
            ratio = (1.0 + g["chi_rel"]) ** (2 * c) / (1.0 + g["youngs_rel"]) ** (-2 * e)
            new = v * ((1.0 + g["field_rel"]) ** f * math.sqrt(ratio))
        elif f:
            new = v * (1.0 + g["field_rel"]) ** f * num / den
        else:
            new = (num / den) * v
        if new != v:
            yield p, new
