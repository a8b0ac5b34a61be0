"""Discretisations of θ(s), swappable by name (``SolverOptions.transcription``)."""
from actuator_design.transcription.base import DiscreteEnergy, ParamLayout, Transcription
from actuator_design.transcription.lgl import LGL
from actuator_design.transcription.midpoint import Midpoint

__all__ = ["DiscreteEnergy", "ParamLayout", "Transcription", "LGL", "Midpoint", "make_transcription"]


def make_transcription(options) -> Transcription:
    """The transcription named by a :class:`~actuator_design.equilibrium.options.SolverOptions`."""
    if options.transcription == "lgl":
        return LGL(options.elements, options.degree, getattr(options, "clamp_levels", 0),
                   getattr(options, "tip_levels", 0), getattr(options, "split_at", ()))
    if options.transcription == "midpoint":
        return Midpoint(options.elements)
    raise ValueError(f"unknown transcription {options.transcription!r}")
