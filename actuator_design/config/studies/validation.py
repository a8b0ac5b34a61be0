"""What every ``study:`` schema shares: the strict base model, errors raised inside a model, and the
translation of a validation failure into a one-line :class:`~actuator_design.config.ConfigError` whose
field starts with ``study.`` (e.g. ``study.sweep.field.magnitude.n: must be >= 1, got 0``)."""
from __future__ import annotations

from typing import Optional

from pydantic import ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from actuator_design.config.base import StrictModel as _ConfigStrictModel
from actuator_design.config.errors import ConfigError, dotted

__all__ = ["StrictModel", "spec_error", "translate", "validate_spec"]

#: Names pydantic puts in an error's location for the members of a plain union: dropped from the path.
_UNION_MEMBERS = {"RangeSpec", "str", "int", "float", "dict[str,any]"}


def spec_error(detail: str, field: Optional[str] = None) -> PydanticCustomError:
    """A validation error raised inside a model; ``field`` names a sub-field (dotted)."""
    return PydanticCustomError("spec", "{detail}", {"detail": detail, "field": field or ""})


class StrictModel(_ConfigStrictModel):
    """Strict base: unknown keys are errors naming the key and the allowed ones (config's rule)."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def translate(err: ValidationError, prefix: str = "study") -> ConfigError:
    """The first error of ``err`` as a :class:`ConfigError` whose field is ``prefix.<path>``."""
    e = err.errors()[0]
    loc = [prefix] + [p for p in e["loc"] if p not in ("function-after", "function-before")]
    kind, ctx, value = e["type"], e.get("ctx") or {}, e.get("input")
    # pydantic puts the member type of a union in the location ('list[any]', 'RangeSpec'): drop it
    loc = [p for p in loc if not (isinstance(p, str) and (("[" in p and p.endswith("]"))
                                                          or p in _UNION_MEMBERS))]
    if kind == "spec":
        loc += [ctx["field"]] if ctx.get("field") else []
        detail = ctx["detail"]
    elif kind == "unknown_key":
        loc.append(ctx["key"])
        detail = f"unknown key (allowed: {ctx['allowed']}{ctx['hint']})"
    elif kind == "missing":
        detail = "required (missing)"
    elif kind == "literal_error":
        detail = f"must be one of {ctx.get('expected')}, got {value!r}"
    elif kind in ("model_attributes_type", "model_type", "dict_type"):
        detail = f"expected a mapping of keys to values, got {value!r}"
    else:
        msg = e["msg"].removeprefix("Value error, ")
        detail = f"{msg[:1].lower()}{msg[1:]}, got {value!r}"
    return ConfigError(dotted(loc), detail)


def validate_spec(model, data, prefix: str = "study"):
    """``model.model_validate(data)`` with errors translated to :class:`ConfigError`."""
    if not isinstance(data, dict):
        raise ConfigError(prefix, f"expected a mapping with a 'type' key, got {data!r}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise translate(err, prefix) from None
