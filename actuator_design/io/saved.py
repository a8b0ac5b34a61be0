"""Reading saved results back: ``result.json`` → the scene it was solved for, and its data.

:func:`~actuator_design.io.save.scene_to_dict` writes every field of a :class:`~actuator_design.model.scene.Scene`
(the field with its fitted sources, profiles, loads, plug-in terms, obstacles, scales);
:func:`scene_from_dict` rebuilds the same scene from that plain data, so a result can be re-solved,
continued or designed on without its config::

    import actuator_design as ad

    saved = ad.read_result("out/result.json")
    again = ad.solve(saved.scene, saved.options)   # the same equilibrium, the same way

    designed = ad.read_result("design-out/design.json").scene   # the designed scene

JSON has no NaN or infinity (:func:`~actuator_design.io.save.jsonable` writes them as null): a null
where a field's default is not finite (a coil's unknown resistance, an unlimited current) reads
back as that default. Units as written: dimensionless (lengths in ℓ, angles in rad), SI in
``scales_fields``.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, Optional

from actuator_design.contact.obstacles import Lumen, Peg, Polygon, Wall
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.physics.harmonic import HarmonicTerm
from actuator_design.physics.registration import PROFILE, SCENE_VALUES, short_repr
from actuator_design.physics.tesseral import TesseralTerm
from actuator_design.model.profiles import (Profile, constant_profile, expression_profile, legendre_profile,
                                            table_profile)
from actuator_design.model.scene import (DipoleField, ExpressionField, Scales, Scene, SourceField, TermValues,
                                         UniformField, profile_fields)
from actuator_design.model.sources import CoilSource, MagnetSource, MappedCoil

__all__ = ["scene_from_dict", "read_result", "SavedResult"]

_FIELDS = {"uniform": UniformField, "dipole": DipoleField, "expression": ExpressionField, "sources": SourceField}
_OBSTACLES = {"wall": Wall, "peg": Peg, "polygon": Polygon, "lumen": Lumen}


def _tuples(value):
    """Lists (of lists ...) as tuples: the frozen dataclasses hold tuples (and hash them)."""
    if isinstance(value, dict):
        raise TypeError("an object where a number, text or list belongs")
    return tuple(_tuples(v) for v in value) if isinstance(value, list) else value


def _build(cls, data: Dict[str, Any], **converted):
    """``cls`` from the plain data of its init fields; ``converted`` given already built. A null in a
    float field (JSON's NaN or ±inf) is the field's default where that is not finite (no limit, an
    unknown resistance), NaN otherwise; a float field holding anything but a number is a TypeError."""
    kwargs = {}
    for f in dataclasses.fields(cls):
        if not f.init or f.name not in data and f.name not in converted:
            continue
        if f.name in converted:
            kwargs[f.name] = converted[f.name]
            continue
        value = data[f.name]
        if value is None and isinstance(f.default, float):  # JSON's null for NaN or ±inf
            value = f.default if not math.isfinite(f.default) else math.nan
        if f.type in ("float", float):
            if not (isinstance(value, (int, float)) and not isinstance(value, bool)):
                raise TypeError(f"{f.name}: a number, got {short_repr(value)}")
            try:
                value = float(value)
            except OverflowError:
                raise TypeError(f"{f.name}: a number, got an integer too large for a float") from None
        kwargs[f.name] = _tuples(value)
    return cls(**kwargs)


def profile_from_dict(data: Optional[Dict[str, Any]]) -> Optional[Profile]:
    """The profile of :meth:`Profile.as_dict`'s data (None stays None)."""
    if data is None:
        return None
    kind = data.get("type")
    if kind == "constant":
        return constant_profile(data["value"])
    if kind == "table":
        return table_profile(data["s"], data["values"])
    if kind == "legendre":
        return legendre_profile(data["coefficients"])
    if kind == "expression":
        return expression_profile(data["expression"])
    raise ValueError(f"scene: unknown profile type {kind!r} (constant, table, legendre or expression)")


def _field_from_dict(data: Optional[Dict[str, Any]]):
    if data is None:
        return None
    kind = data.get("kind") if isinstance(data, dict) else None
    if kind not in _FIELDS:
        raise ValueError(f"scene.field: unknown kind {kind!r} (one of {', '.join(_FIELDS)})")
    if kind != "sources":
        return _build(_FIELDS[kind], data)
    terms = tuple(_build(TesseralTerm if "modes" in t else HarmonicTerm, t) for t in data["terms"])
    sources = tuple(_build(MagnetSource if "shape" in s else MappedCoil if "field_per_amp" in s else CoilSource, s)
                    for s in data["sources"])
    field = _build(SourceField, data, terms=terms, sources=sources)
    if not (len(sources) == len(terms) and len(field.weights) in (0, len(terms))
            and len(field.placements) in (0, len(terms))):
        raise ValueError("scene.field: one term per source, and as many weights and placements (or none)")
    return field


def scene_from_dict(data: Dict[str, Any]) -> Scene:
    """The :class:`Scene` of :func:`~actuator_design.io.save.scene_to_dict`'s data (as read from JSON).

    Raises
    ------
    ValueError
        One line, when the data lacks what a scene needs (a ``result.json`` written before the
        scene was saved whole) or is not what it says (a wrong type, an unknown kind).
    """
    try:
        scene = _scene_from_dict(data)
        hash(scene)  # what the caches key on
    except (KeyError, TypeError, AttributeError, IndexError) as exc:
        what = f"{exc.args[0]!r} missing" if isinstance(exc, KeyError) else str(exc)
        raise ValueError(f"scene: not a saved scene ({what})") from None
    except (ValueError, OverflowError) as exc:  # the scene's own checks ("Scene: h_r must be ..."), prefixed
        if str(exc).startswith("scene"):
            raise
        raise ValueError(f"scene: not a saved scene ({exc})") from None
    return scene


def _scene_from_dict(data: Dict[str, Any]) -> Scene:
    if not isinstance(data, dict):
        raise TypeError("the scene is not an object")
    missing = [k for k in ("scales_fields", "extra_terms", "obstacles") if k not in data]
    if missing:
        raise ValueError(f"scene: {', '.join(missing)} missing (written by an older version, which did not save "
                         "the scene whole; solve its config again)")
    obstacles = []
    for ob in data["obstacles"]:
        if not isinstance(ob, dict) or ob.get("kind") not in _OBSTACLES:
            raise ValueError(f"scene.obstacles: unknown kind {ob.get('kind')!r} (one of {', '.join(_OBSTACLES)})")
        obstacles.append(_build(_OBSTACLES[ob["kind"]], ob))
    converted = {
        "field": _field_from_dict(data["field"]),
        "scales": None if data["scales_fields"] is None else _build(Scales, data["scales_fields"]),
        "extra_terms": tuple(TermValues(t["name"], _tuples(t["values"])) for t in data["extra_terms"]),
        "obstacles": tuple(obstacles),
    }
    profiles = {}
    for name, optional in profile_fields().items():  # every profile, whichever term it belongs to
        if not optional and data[name] is None:
            raise TypeError(f"{name}: a profile, got null")
        profiles[name] = profile_from_dict(data.get(name) if optional else data[name])
    values = {**_term_values(data), **{k: v for k, v in profiles.items() if k in SCENE_VALUES}}
    converted.update((k, v) for k, v in profiles.items() if k not in SCENE_VALUES)
    rod = {k: v for k, v in data.items() if k != "values"}  # the term values are read by their own keys only
    plugins = converted.pop("extra_terms")
    return dataclasses.replace(_build(Scene, rod, **converted), extra_terms=plugins, **values)


def _term_values(data: Dict[str, Any]) -> Dict[str, Any]:
    """The terms' values (:data:`~actuator_design.physics.registration.SCENE_VALUES`) a saved scene
    gives, profiles aside (one it leaves out keeps its default); the scene checks each
    (:meth:`~actuator_design.physics.registration.SceneValue.checked`). A null where None is not
    allowed is JSON's NaN, which it refuses."""
    return {name: math.nan if data[name] is None and not spec.optional else _tuples(data[name])
            for name, spec in SCENE_VALUES.items() if name in data and spec.kind != PROFILE}


@dataclass(frozen=True)
class SavedResult:
    """A ``result.json`` read back.

    Attributes
    ----------
    scene : Scene
        The scene it was solved for, rebuilt (:func:`scene_from_dict`).
    data : dict
        The whole JSON (the result contract: ``tip``, ``theta``, ``status``, ...).
    path : Path
    """

    scene: Scene
    data: Dict[str, Any]
    path: Path

    @property
    def options(self) -> Optional[SolverOptions]:
        """The solver options the result was computed with (``result.json``'s ``solver``), or None
        (a file without them, e.g. ``design.json``). ValueError when they are not options."""
        solver = self.data.get("solver")
        if solver is None:
            return None
        try:
            return _build(SolverOptions, solver)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{self.path}: solver: not solver options ({exc})") from None

    def __repr__(self) -> str:
        tip = self.data.get("tip") or {}
        shown = ", ".join(f"{k}={tip[k]:.6g}" for k in ("x", "y", "angle") if isinstance(tip.get(k), (int, float)))
        return f"SavedResult({str(self.path)!r}, status={self.data.get('status')!r}, tip=({shown}))"


def read_result(path) -> SavedResult:
    """Read a ``result.json`` (written by ``solve``, ``path``, ... or :func:`~actuator_design.io.save.write_result`)
    or a ``design.json`` (its ``scene`` is the designed scene) and rebuild its scene.

    Raises
    ------
    ValueError
        When the file is not a result with a scene (one line naming what is missing).
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: cannot be read as JSON ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("scene"), dict):
        raise ValueError(f"{path}: not a result.json with a scene (no 'scene' object)")
    try:
        scene = scene_from_dict(data["scene"])
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    return SavedResult(scene, data, path)
