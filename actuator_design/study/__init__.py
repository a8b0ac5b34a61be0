"""Studies: sweeps of a scene run through registered analyses, in parallel, resumable.

``run_study`` (in :mod:`actuator_design.study.runner`) is the entry point; the sweep specification
lives in :mod:`actuator_design.study.spec`, the grid in :mod:`~actuator_design.study.grid`, the
per-point work in :mod:`~actuator_design.study.worker`, the journal in
:mod:`~actuator_design.study.journal` and the outputs in :mod:`~actuator_design.study.outputs`; the
figures (pure drawing) are :mod:`actuator_design.viz.study`'s. Imports are lazy so that importing
this package is cheap and never needs Dask.
"""

__all__ = ["run_study", "StudyReport"]


def __getattr__(name):
    if name in __all__:
        from . import runner
        return getattr(runner, name)
    raise AttributeError(name)
