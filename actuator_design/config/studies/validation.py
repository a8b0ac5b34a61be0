"""What every ``study:`` schema shares: the strict base model, and validation whose failure is a
one-line :class:`~actuator_design.config.ConfigError` whose field starts with ``study.`` (e.g.
``study.sweep.field.magnitude.n: must be >= 1, got 0``), translated as the configuration's own
errors are (:func:`actuator_design.config.errors.translate`; ``spec_error`` is its ``error``)."""
from __future__ import annotations

from pydantic import ConfigDict, ValidationError

from actuator_design.config.base import StrictModel as _ConfigStrictModel
from actuator_design.config.errors import ConfigError, translate
from actuator_design.config.errors import error as spec_error

__all__ = ["StrictModel", "spec_error", "translate", "validate_spec"]


class StrictModel(_ConfigStrictModel):
    """Strict base: unknown keys are errors naming the key and the allowed ones (config's rule)."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def validate_spec(model, data, prefix: str = "study"):
    """``model.model_validate(data)`` with errors translated to :class:`ConfigError`."""
    if not isinstance(data, dict):
        raise ConfigError(prefix, f"expected a mapping with a 'type' key, got {data!r}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise translate(err, prefix) from None
