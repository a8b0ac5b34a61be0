"""One-line configuration errors: ``"<dotted.field.path>: <what is wrong>"``.

Pydantic reports a failure as a location tuple and an error kind; :func:`translate` turns the first
one into a :class:`ConfigError` naming the field by its dotted path, with the ``type:`` tags of
tagged unions removed from the path (``scene.field.magnitude``, not ``scene.field.uniform.magnitude``),
and the members of plain unions and validator wrappers too. It translates the configuration's errors
and those of a ``study:`` section validated on its own (:mod:`actuator_design.config.studies`).
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional

from pydantic import ValidationError
from pydantic_core import PydanticCustomError

from actuator_design.physics.registration import short_repr  # (a hostile value must not flood a message)

__all__ = ["ConfigError", "error", "dotted", "translate", "first_non_finite", "UNION_TAGS"]

#: Field name of a tagged union → its tags (pydantic puts the tag in the error location).
UNION_TAGS: Dict[str, List[str]] = {}


class ConfigError(ValueError):
    """An invalid configuration: ``"<dotted.field.path>: <what is wrong>"`` on one line.

    Attributes
    ----------
    field : str
        Dotted path of the offending field (``"config"`` for the file as a whole).
    detail : str
        What is wrong and what is allowed.
    """

    def __init__(self, field: str, detail: str):
        self.field = field
        self.detail = " ".join(str(detail).split())
        super().__init__(f"{field}: {self.detail}")


def error(detail: str, field: Optional[str] = None) -> PydanticCustomError:
    """A validation error raised inside a model; ``field`` names a sub-field of that model."""
    return PydanticCustomError("config", "{detail}", {"detail": detail, "field": field or ""})


def dotted(loc) -> str:
    """``("scene", "rod", "length")`` → ``"scene.rod.length"``; list indices as ``[i]``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "config"


#: What pydantic puts in an error's location besides field names: validator wrappers, and the member
#: types of plain unions (``list[any]``, ``RangeSpec``, ``str``): dropped from the path.
_MEMBERS = {"RangeSpec", "str", "int", "float", "dict[str,any]"}


def _is_member(part) -> bool:
    return isinstance(part, str) and (part in _MEMBERS or ("[" in part and part.endswith("]")))


def _is_validator(part) -> bool:
    return isinstance(part, str) and part.startswith(("function-after", "function-before"))


def _strip_tags(loc) -> list:
    # a union member's name follows the field it types; a key spelled like one (a sweep key ``str``)
    # is followed by the member name of its own value, so it stays
    loc = [part for part in loc if not _is_validator(part)]
    loc = [part for i, part in enumerate(loc)
           if not (_is_member(part) and (i + 1 == len(loc) or not _is_member(loc[i + 1])))]
    out = []
    for i, part in enumerate(loc):
        owner = next((p for p in reversed(loc[:i]) if isinstance(p, str)), None)  # a list's item: the list
        if owner in UNION_TAGS and part in UNION_TAGS[owner] and (loc[i - 1] == owner or isinstance(loc[i - 1], int)):
            continue
        out.append(part)
    return out


def translate(err: ValidationError, prefix: Optional[str] = None) -> ConfigError:
    """The first error of ``err`` as a :class:`ConfigError` naming the field by its dotted path
    (after ``prefix``, e.g. ``"study"``, for a section validated on its own)."""
    e = err.errors()[0]
    loc, kind, ctx, value = _strip_tags(e["loc"]), e["type"], e.get("ctx") or {}, e.get("input")
    loc = ([prefix] if prefix else []) + loc
    if kind == "config":
        loc += [ctx["field"]] if ctx.get("field") else []
        detail = ctx["detail"]
    elif kind == "unknown_key":
        loc.append(ctx["key"])
        detail = f"unknown key (allowed: {ctx['allowed']}{ctx['hint']})"
    elif kind in ("union_tag_invalid", "union_tag_not_found"):
        named = [part for part in loc if isinstance(part, str)]  # a list's item: its list's name
        tags = ", ".join(UNION_TAGS.get(named[-1] if named else "", []))
        what = f"unknown type '{ctx['tag']}'" if kind == "union_tag_invalid" else "missing"
        loc.append("type")
        detail = f"{what} (allowed: {tags})"
    elif kind == "missing":
        detail = "required (missing)"
    elif kind == "extra_forbidden":
        detail = "unknown key"
    elif kind == "literal_error":
        detail = f"must be one of {ctx.get('expected')}, got {short_repr(value, 80)}"
    elif kind in ("model_attributes_type", "model_type", "dict_type"):
        detail = f"expected a mapping of keys to values, got {short_repr(value, 80)}"
    else:
        msg = e["msg"].removeprefix("Value error, ")
        detail = f"{msg[:1].lower()}{msg[1:]}, got {short_repr(value, 80)}"
    return ConfigError(dotted(loc), detail)


def first_non_finite(obj, path=()):
    """Path (tuple of keys/indices) of the first NaN/inf float, or integer beyond the float range
    (YAML reads 400 digits as an int), in nested dicts/lists, or None."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return path
    if isinstance(obj, int) and not isinstance(obj, bool):
        try:
            float(obj)
        except OverflowError:
            return path
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for key, val in items:
        found = first_non_finite(val, path + (key,))
        if found is not None:
            return found
    return None
