"""One parameter lens: every named scene value an analysis may read, set, continue or design.

A :class:`Parameter` knows its meaning and unit, how to get and set it on a :class:`~actuator_design.model.scene.Scene`
(setting adds the term it needs when absent and checks the range), the NLP slot it occupies and the
transform to that slot (``h2`` → slot ``h`` through √), how it scales with the applied field
magnitude H (THEORY §5: h and h_pos ∝ H, h² ∝ H²) and how it enters the solver's residual scale
(loads linearly, field groups squared).

Terms contribute their own parameters (``EnergyTerm.parameters`` in :mod:`actuator_design.physics.terms`); the
clamp angle ``theta0`` belongs to the transcription. The registry below collects them in the order
the terms are registered, so a plug-in term's parameters are continued, designed and ramped like
the built-in ones. Continuation, loading paths, critical values, maps, design and the CLI all look
names up here: :func:`parameter` is the single source of truth. Entries flagged ``designable`` are
the inverse design's variables (:func:`designable`; the per-point ``alpha`` and ``magnetization``
are designed as profiles α(s), β(s)); angles (unit ``rad``) also answer to ``<name>_deg`` on the CLI
(:func:`degree_aliases`).

The lens also holds the unit-carrying *physical* parameters (:class:`PhysicalParameter`,
:func:`physical_parameters`): material values (χ̄, E, B0, the remanence M_r), the groups themselves seen as
measured quantities (``h``, the clamp angle) and the measurement model of a calibration (a factor
and an offset on the measured field, an offset on its angle). Each knows its dimension (for pint),
its scale (positive values are fitted in log scale), the scene types that have it and how the
dimensionless groups of THEORY §5 and §9 scale with it (h² ∝ χ̄ H²/B, h_r ∝ M_r H/B, loads ∝
1/B). Calibration fits exactly these.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from actuator_design.model.scene import Scene, UniformField
from actuator_design.model.units import DIMENSIONS, MU0
from actuator_design.physics.fields import field_model
from actuator_design.physics.parameter import THETA0, Parameter, plugin_parameter
from actuator_design.physics.registry import registered_terms, registry_version, term_class, write_keeps_terms

__all__ = ["Parameter", "parameter", "parameters", "names", "get_value", "set_value",
           "scene_values", "apply_values", "prepare_scene", "plugin_parameter", "THETA0",
           "designable", "designed_profiles", "remanent_profiles", "degree_aliases", "PhysicalParameter", "physical_parameters",
           "physical_parameter", "entry_names", "tip_loads", "stiffness_groups", "remanent_group",
           "field_groups", "scale_field", "per_field", "set_field", "applied_field", "beyond_model",
           "model_field_bound", "field_shape_max", "remanent_groups", "soft_coupled"]


def _source_weight(k: int) -> Parameter:
    """The weight w_k of source k of a field from magnets and coils (``SourceField.weights``: coil
    k's current over the current its field was fitted at), NLP slot ``source_weight_k``."""
    def has(sc: Scene) -> bool:
        return getattr(sc.field, "kind", "") == "sources" and k < len(sc.field.terms)

    def write(sc: Scene, v: float) -> Scene:
        w = list(sc.field.source_weights())
        w[k] = v
        return replace(sc, field=replace(sc.field, weights=tuple(w)))

    def ensure(sc: Scene) -> Scene:
        if not has(sc):
            raise ValueError(f"source_weight_{k}: the scene's field has no source {k + 1} (a field from magnets "
                             "or coils, `field: {type: coils}`)")
        return sc

    return Parameter(f"source_weight_{k}", f"weight of field source {k + 1} (its current over the current it was "
                     "fitted at)", "1", f"source_weight_{k}", read=lambda sc: sc.field.source_weights()[k] if has(sc)
                     else 0.0, write=write, ensure=ensure)


#: a source's rigid move (``SourceField.placements``): name → (its index in (dx, dy, turn), unit)
_PLACEMENT = {"source_dx": (0, "l"), "source_dy": (1, "l"), "source_turn": (2, "rad")}


def _source_placement(k: int, head: str) -> Parameter:
    """One coordinate of source k's rigid move (``SourceField.placements``: dx, dy in units of ℓ, a
    turn in rad about its fitted centre), NLP slot ``<head>_k`` (a magnet moved by its stage,
    :mod:`actuator_design.schedules.pose_schedule`)."""
    i, unit = _PLACEMENT[head]

    def has(sc: Scene) -> bool:
        return getattr(sc.field, "kind", "") == "sources" and k < len(sc.field.terms)

    def write(sc: Scene, v: float) -> Scene:
        places = [list(p) for p in sc.field.source_placements()]
        places[k][i] = v
        return replace(sc, field=replace(sc.field, placements=tuple(tuple(p) for p in places)))

    def ensure(sc: Scene) -> Scene:
        if not has(sc):
            raise ValueError(f"{head}_{k}: the scene's field has no source {k + 1} (a field from magnets, "
                             "`field: {type: magnet}`)")
        if k > 0 and hasattr(sc.field.sources[k], "field_per_amp"):
            raise ValueError(f"{head}_{k}: the coils of a calibration map move as one rig; move it by {head}_0")
        return sc

    what = {"source_dx": "move along c1", "source_dy": "move along c2", "source_turn": "turn"}[head]
    return Parameter(f"{head}_{k}", f"field source {k + 1}'s {what} from where it was fitted", unit, f"{head}_{k}",
                     read=lambda sc: sc.field.source_placements()[k][i] if has(sc) else 0.0, write=write,
                     ensure=ensure)


def _source_weight_entry(name: str) -> Optional[Parameter]:
    """``source_weight_k`` and ``source_dx_k``, ``source_dy_k``, ``source_turn_k`` for any k: lens
    entries that :func:`parameter` finds (loading paths over coil currents or a magnet's pose,
    :mod:`actuator_design.schedules.current_schedule`, :mod:`actuator_design.schedules.pose_schedule`) but that are not listed among
    the scene parameters a user names (their number depends on the scene)."""
    head, _, k = name.rpartition("_")
    if not k.isdigit():
        return None
    if head == "source_weight":
        return _source_weight(int(k))
    return _source_placement(int(k), head) if head in _PLACEMENT else None


# -- the registry --------------------------------------------------------------------------------
_CACHE: Dict[str, object] = {"version": None, "registry": {}}


def parameters() -> Dict[str, Parameter]:
    """Every parameter, name -> :class:`Parameter`, in term registration order, ``theta0`` last."""
    if _CACHE["version"] != registry_version():
        reg: Dict[str, Parameter] = {}
        for cls in registered_terms():
            for p in cls.parameters:
                reg.setdefault(p.name, p)
        reg.setdefault(THETA0.name, THETA0)
        _CACHE["registry"], _CACHE["version"] = reg, registry_version()
    return _CACHE["registry"]  # type: ignore[return-value]


def names() -> List[str]:
    """Names of every registered parameter."""
    return list(parameters())


def parameter(name: str, what: str = "parameter") -> Parameter:
    """The parameter called ``name``; ValueError ``unknown <what> 'name' (allowed: …)`` otherwise."""
    reg = parameters()
    p = reg.get(name) or _source_weight_entry(name)
    if p is None:
        raise ValueError(f"unknown {what} {name!r} (allowed: {', '.join(reg)})")
    return p


def tip_loads() -> Tuple[str, ...]:
    """The dead end loads work-conjugate to the free end's x, y and angle, in that order
    (``Parameter.conjugate``; those declared)."""
    by = {p.conjugate: name for name, p in parameters().items() if p.conjugate}
    return tuple(by[q] for q in ("x", "y", "angle") if q in by)


def designable() -> Dict[str, Parameter]:
    """The inverse design's variables, name -> :class:`Parameter`, in registration order
    (a ``per_point`` entry such as ``alpha`` or ``magnetization`` is designed as a profile)."""
    return {n: p for n, p in parameters().items() if p.designable}


def designed_profiles() -> Dict[str, Parameter]:
    """The profiles a design can vary (``per_point`` designables: the fibre angle α(s), a
    magnetisation angle β(s)), name -> :class:`Parameter`, each with its ``design_bound``."""
    return {n: p for n, p in designable().items() if p.per_point}


def remanent_profiles(scene: Scene) -> Tuple[str, ...]:
    """The designable profiles of the terms through which the field drives ``scene``'s remanence
    (:func:`remanent_groups`: the magnetisation angle β(s) of a hard-magnetic rod, THEORY §9)."""
    terms = {p.term for p in remanent_groups(scene)}
    return tuple(n for n, p in designed_profiles().items() if p.term in terms)


def degree_aliases() -> Dict[str, str]:
    """``<name>_deg`` -> ``<name>`` for every angle (unit ``rad``): the CLI's names in degrees."""
    return {f"{n}_deg": n for n, p in parameters().items() if p.unit == "rad"}


def get_value(scene: Scene, name: str, what: str = "parameter") -> float:
    """The value of parameter ``name`` in ``scene`` (0 for an absent term)."""
    return parameter(name, what).get(scene)


def set_value(scene: Scene, name: str, value, what: str = "parameter") -> Scene:
    """A copy of ``scene`` with parameter ``name`` set (its term added if absent, range checked)."""
    return parameter(name, what).set(scene, value)


def scene_values(scene: Scene, names_: Sequence[str], what: str = "parameter") -> Dict[str, float]:
    """The current values of the named parameters in ``scene``."""
    return {n: parameter(n, what).get(scene) for n in names_}


def prepare_scene(scene: Scene, names_: Sequence[str], what: str = "parameter") -> Scene:
    """``scene`` with every term the named parameters need present (added at value zero), so that
    a whole path or design shares one NLP structure."""
    for n in names_:
        scene = parameter(n, what).require(scene)
    return scene


def _present(scene: Scene, term: Optional[str]) -> bool:
    return term is None or term_class(term).present(scene)


def remanent_group(scene: Scene, stored: bool = False) -> float:
    """The largest remanent-magnetisation group of the terms ``scene`` contains in an applied field
    (it may not have one yet), in magnitude (``Parameter.remanent_field``: h_r, THEORY §9); 0 for a
    rod without remanence. With ``stored``, the value stored in the scene even where its term is
    absent (h_r without a magnetisation)."""
    in_field = scene if scene.field is not None else replace(scene, field=UniformField())
    return max([0.0] + [abs(p.get(scene)) for p in parameters().values()
                        if p.remanent_field and (stored or _present(in_field, p.term))])


def field_groups(magnitude: bool = True) -> List[Tuple[Parameter, int]]:
    """(parameter, f) of every scalar group ∝ H^f that the applied field drives (h, h_pos, h_r:
    f = 1; THEORY §5, §9), one per NLP slot, in registration order; without ``magnitude`` the field
    magnitude's own group (h) is left out."""
    out: Dict[str, Parameter] = {}
    for p in parameters().values():
        if p.field_power and not p.per_point and (magnitude or not p.field_magnitude) and p.slot not in out:
            out[p.slot] = p
    return [(p, p.field_power) for p in out.values()]


def per_field(scene: Scene) -> Dict[str, float]:
    """Each group the field drives per unit applied field (dg/dH0 per A/m), by lens name, from the
    scene's physical scales (``Scales.per_field``); empty for a dimensionless scene."""
    return dict(getattr(scene.scales, "per_field", ()) or ())


def remanent_groups(scene: Scene) -> List[Parameter]:
    """The remanent-magnetisation groups of the rod (``Parameter.remanent_field``: h_r, THEORY §9),
    those stored nonzero or nonzero per unit field (a physical scene at zero field has them too)."""
    table = per_field(scene)
    return [p for p in parameters().values()
            if p.remanent_field and not p.per_point and (p.get(scene) > 0 or table.get(p.name, 0.0) > 0)]


def soft_coupled(scene: Scene) -> bool:
    """Whether the rod couples to the field through its susceptibility (h > 0, or h > 0 per unit
    field on a physical scene at zero field)."""
    return scene.h > 0 or per_field(scene).get("h", 0.0) > 0


def set_field(scene: Scene, H: float) -> Scene:
    """``scene`` in the applied field H (A/m, the scale H0 of its field): every group the field
    drives set to its value per field times H (:func:`per_field`), zero field included: a group whose
    term is present after the write (the χ̂ term of a non-uniform field is added by it, the χ̂ group
    of a uniform field is left out), a present one that would be 0 keeping the smallest normal float
    (the NLP structure stays). ValueError for a scene without the table."""
    table = per_field(scene)
    if not table:
        raise ValueError("this scene has no physical field scale (a dimensionless scene): give the "
                         "groups themselves")
    for p, f in field_groups():
        if p.name in table:
            value = table[p.name] * float(H) ** f
            if value == 0.0 and not p.field_magnitude and table[p.name] != 0.0:
                value = np.finfo(float).tiny
            written = p.write(scene, value)
            if p.field_magnitude or _present(written, p.term):
                scene = written
    return scene


def applied_field(scene: Scene) -> Optional[float]:
    """The applied field H (A/m, the scale H0 of the scene's field) its groups stand for: from the
    first group the field drives with a known value per field (h, else a remanent h_r), else the
    scale the scene was built with; None for a dimensionless scene."""
    if scene.scales is None:
        return None
    table = per_field(scene)
    for p, _ in field_groups():
        if table.get(p.name, 0.0) > 0.0 and (p.field_magnitude or _present(scene, p.term)):
            return p.get(scene) / table[p.name]
    return float(scene.scales.field)


def model_field_bound(scene: Scene) -> Optional[Tuple[float, str]]:
    """(h_bound, why): the largest field group h of the field the scene's magnetisation model holds
    to (``Scales.field_limit``), with the reason in words; None when no limit is known."""
    limit, h_per = getattr(scene.scales, "field_limit", math.inf), per_field(scene).get("h", 0.0)
    shape = field_shape_max(scene)  # on the undeformed rod: the design's solved shape is checked too
    if not (math.isfinite(limit) and h_per > 0.0 and shape > 0.0):
        return None
    return h_per * limit / shape, (f"{limit:.4g} A/m on the rod, the field up to which the particles' linear "
                                   "magnetisation holds (their saturation, THEORY §11)")


def field_shape_max(scene: Scene, x=None, y=None) -> float:
    """max |ĥ| of the scene's field shape (|H| / H0) over the points (x, y) (units of ℓ; default:
    the undeformed rod, x = s, y = 0); 0 without a field."""
    if scene.field is None:
        return 0.0
    if x is None:
        x, y = np.linspace(0.0, 1.0, 201), np.zeros(201)
    model = field_model(scene.field)
    with np.errstate(all="ignore"):
        hx, hy = model.evaluate(np.asarray(x, float), np.asarray(y, float), model.parameter_values(scene.field))
    return float(np.nanmax(np.hypot(hx, hy)))


def beyond_model(scene: Scene, x=None, y=None) -> Optional[str]:
    """Why the field on the rod (the undeformed one, or the points (x, y) of a solved shape) lies
    beyond the field its magnetisation model holds to (``Scales.field_limit``: the particles'
    saturation, THEORY §11), or None."""
    H = applied_field(scene)
    limit = getattr(scene.scales, "field_limit", math.inf)
    local = None if H is None else H * field_shape_max(scene, x, y)
    if local is None or not local > limit * (1.0 + 1e-12):
        return None
    return (f"the field on the rod reaches {local:.4g} A/m (mu0 H = {MU0 * local * 1e3:.4g} mT), beyond {limit:.4g} "
            "A/m, the field up to which the particles' linear magnetisation holds (their saturation, THEORY §11): "
            "the magnetic coupling is overestimated there")


def scale_field(scene: Scene, k: float, source: Optional[Scene] = None, magnitude: bool = True) -> Scene:
    """``scene`` with every group the field drives set to its value in ``source`` (default: ``scene``)
    times k^f: the same rod in the applied field scaled by k (:func:`field_groups`). A group of a term
    the scene lacks is written only where that does not add the term."""
    source = scene if source is None else source
    for p, f in field_groups(magnitude):
        value = p.get(source) * k ** f
        if p.term is None or term_class(p.term).present(scene) or write_keeps_terms(p, scene, value):
            scene = p.write(scene, value)
    return scene


def apply_values(scene: Scene, values: Mapping[str, float], what: str = "parameter") -> Scene:
    """A copy of ``scene`` with the named parameters set, the field-scaling rule applied.

    Setting the field magnitude (``h`` or ``h2``) scales every other field-dependent value whose
    term is present and that is not given too (THEORY §5: h_pos ∝ H like h); from a scene at zero
    field, where no ratio is known, a physical scene's groups per field set them
    (:func:`set_field`; a dimensionless one's stay). A present term whose value would round to 0 keeps the smallest normal float
    instead, so the NLP structure does not change along a ramp (its square is 0.0).

    Raises
    ------
    ValueError
        Unknown name, a value out of range, two names for one slot (``h`` and ``h2``).
    """
    params = [parameter(n, what) for n in values]
    vals = {p.name: p.validate(values[p.name]) for p in params}
    by_slot: Dict[str, str] = {}
    for p in params:
        if p.slot in by_slot and not p.per_point:
            raise ValueError(f"give either {by_slot[p.slot]} or {p.name}, not both")
        by_slot[p.slot] = p.name
    order = sorted(params, key=lambda p: not p.field_magnitude)  # the magnitude first
    for p in order:
        table = per_field(scene)
        if p.field_magnitude and not p.get(scene) > 0 and table.get("h", 0.0) > 0 and scene.field is not None:
            # from zero field no ratio is known: the physical scene's groups per field fix them all
            # (the magnitude is set first; a value given too is set below, as given)
            scene = set_field(scene, vals[p.name] ** (1.0 / p.field_power) / table["h"])
        elif p.field_magnitude:
            old = p.get(scene)
            if old > 0 and scene.field is not None:
                ratio = (vals[p.name] / old) ** (1.0 / p.field_power)  # H_new / H_old
                for q in parameters().values():
                    if (q.field_power and not q.field_magnitude and q.slot not in by_slot
                            and _present(scene, q.term)):
                        before = q.get(scene)
                        after = before * ratio ** q.field_power
                        if before != 0 and abs(after) < np.finfo(float).tiny:
                            after = math.copysign(np.finfo(float).tiny, before)
                        scene = q.write(scene, after)
        scene = p.set(scene, vals[p.name])
    return scene


# -- physical, unit-carrying parameters -------------------------------------------------------------
@dataclass(frozen=True)
class PhysicalParameter:
    """A unit-carrying parameter of a scene's physical description (or of a measurement model).

    Attributes
    ----------
    name : str
        Name used by configs (``study.parameters.<name>`` of a fit) and JSON.
    description : str
        Meaning, one line (written into a fit's JSON).
    dimension : str
        A key of :data:`actuator_design.model.units.DIMENSIONS` (how pint reads a value with units).
    log : bool
        The value is positive and is fitted in log scale.
    scenes : tuple of {"physical", "dimensionless"}
        The scene types that have it.
    groups : tuple of (str, float)
        (NLP slot, exponent e): with every other input fixed, the dimensionless group in that slot
        is ∝ value^e (THEORY §5: h ∝ χ̄^½ H; §9: h_r ∝ M_r H).
    through_field : bool
        It acts on the applied field H (a measurement-model parameter), not on the rod.
    shifts : str or None
        The input it is added to: ``"field"`` (the field magnitude H) or a lens name (``"phi"``).
    same_as : str or None
        The lens parameter whose value it is (``h``; ``clamp_angle`` is ``theta0``).
    term : str or None
        The energy term it needs (the field term for χ̄, h and the field's measurement model; the
        hard-magnetic term for M_r).
    stiffness : bool
        It sets B0 = E I (Young's modulus, the bending stiffness): its groups are every lens slot
        ∝ B0^e (:func:`stiffness_groups`; THEORY §5: h ∝ B^-½, loads and h_r ∝ 1/B).
    material : bool
        It is a number of the rod's magnetic material of the same name
        (:class:`~actuator_design.physics.magnetics_block.MagneticSummary`: χ̄, M_r), from which the
        groups the field drives follow (``MagneticSummary.field_groups``).
    symbol : str
        How a report writes it in a formula (``M_r`` in "mu0 M_r = 100 mT"; ``x`` for a plain value).
    tolerance, aliases : str or None, tuple of str
        The tolerance box's axis of its relative scatter (:class:`~actuator_design.robust.tolerances.Tolerances`
        attribute), named :attr:`name` or an alias (``--tolerance chi=10%``); None: it has none.
    """

    name: str
    description: str
    dimension: str
    log: bool
    scenes: Tuple[str, ...]
    groups: Tuple[Tuple[str, float], ...] = ()
    through_field: bool = False
    shifts: Optional[str] = None
    same_as: Optional[str] = None
    term: Optional[str] = None

    @property
    def unit(self) -> str:
        """SI unit symbol of the value (``""`` when dimensionless)."""
        return DIMENSIONS[self.dimension].unit

    stiffness: bool = False
    material: bool = False
    symbol: str = "x"
    tolerance: Optional[str] = None
    aliases: Tuple[str, ...] = ()

    def exponent(self, slot: str) -> float:
        """e in group(slot) ∝ value^e (0 when the group does not depend on it)."""
        return dict(self.all_groups()).get(slot, 0.0)

    def all_groups(self) -> Tuple[Tuple[str, float], ...]:
        """:attr:`groups`, and for a stiffness (E, B0) every lens slot ∝ B0^e (:func:`stiffness_groups`)."""
        return stiffness_groups() if self.stiffness else self.groups


def stiffness_groups() -> Tuple[Tuple[str, float], ...]:
    """(NLP slot, e) for every slot of the lens whose value is ∝ B0^e (B0 = E I, THEORY §5, §9):
    the field groups (h, h_pos: e = −½), the loads and h_r (−1), and every plug-in term's slots
    scaled by B0 (:attr:`Parameter.stiffness_power`), one entry per slot in registration order."""
    out: Dict[str, float] = {}
    for p in parameters().values():
        if p.stiffness_power and not p.per_point and p.slot not in out:
            out[p.slot] = p.stiffness_power * (0.5 if p.transform == "sqrt" else 1.0)
    return tuple(out.items())


_FIELD = "field_orientation"
_HARD = "hard_magnetic"
_BOTH = ("physical", "dimensionless")
_PHYSICAL = (
    PhysicalParameter("chi_bar", "orientational susceptibility χ̄", "dimensionless", True,
                      ("physical",), groups=(("h", 0.5),), term=_FIELD, material=True, tolerance="chi_rel",
                      aliases=("chi",)),
    PhysicalParameter("youngs_modulus", "Young's modulus E (B0 = E I)", "pressure", True,
                      ("physical",), stiffness=True),
    PhysicalParameter("bending_stiffness", "bending stiffness B0", "bending_stiffness", True,
                      ("physical",), stiffness=True),
    PhysicalParameter("remanence", "remanent magnetisation M_r of the composite", "magnetic_field",
                      True, ("physical",), groups=(("h_r", 1.0),), term=_HARD, material=True, symbol="M_r"),
    PhysicalParameter("h", "field group h (THEORY §5)", "dimensionless", True, ("dimensionless",),
                      groups=(("h", 1.0),), same_as="h", term=_FIELD),
    PhysicalParameter("clamp_angle", "clamp angle θ0", "angle", False, _BOTH, same_as="theta0"),
    PhysicalParameter("field_scale", "factor on the measured field", "dimensionless", True, _BOTH,
                      groups=(("h", 1.0), ("h_pos", 1.0), ("h_r", 1.0)), through_field=True,
                      term=_FIELD),
    PhysicalParameter("field_offset", "offset added to the measured field", "magnetic_field", False,
                      _BOTH, through_field=True, shifts="field", term=_FIELD),
    PhysicalParameter("field_angle_offset", "offset added to the field angle", "angle", False,
                      _BOTH, through_field=True, shifts="phi", term=_FIELD),
)
_PHYSICAL_BY_NAME: Dict[str, PhysicalParameter] = {p.name: p for p in _PHYSICAL}


def physical_parameters() -> Dict[str, PhysicalParameter]:
    """Every physical parameter, name -> :class:`PhysicalParameter` (the fittable ones)."""
    return _PHYSICAL_BY_NAME


def physical_parameter(name: str, what: str = "parameter") -> PhysicalParameter:
    """The physical parameter ``name``; ValueError ``unknown <what> …(allowed: …)`` otherwise."""
    p = _PHYSICAL_BY_NAME.get(name)
    if p is None:
        raise ValueError(f"unknown {what} {name!r} (allowed: {', '.join(_PHYSICAL_BY_NAME)})")
    return p


def entry_names() -> List[str]:
    """Every name the lens knows: scene parameters, their ``_deg`` aliases, physical parameters."""
    out = names() + list(degree_aliases())
    return out + [n for n in physical_parameters() if n not in out]
