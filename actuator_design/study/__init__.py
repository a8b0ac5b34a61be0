"""Studies: sweeps of a scene run through registered analyses, in parallel, resumable.

``plan_study`` (in :mod:`actuator_design.study.plan`) checks a study before any work and
``run_study`` (in :mod:`actuator_design.study.runner`) runs it; ``read_manifest`` reads a study
folder's manifest truthfully (:mod:`~actuator_design.study.manifest`). The sweep specification
lives in :mod:`actuator_design.config.studies.sweep`, the grid in :mod:`~actuator_design.study.grid`, the
per-point work in :mod:`~actuator_design.study.worker`, where it runs in
:mod:`~actuator_design.study.backends`, the folder's lock in :mod:`~actuator_design.study.lock`,
the journal in :mod:`~actuator_design.study.journal` and the outputs in
:mod:`~actuator_design.study.outputs` (the table) and :mod:`~actuator_design.study.dataset`
(``results.nc``, the table on the grid); the figures (pure drawing) are :mod:`actuator_design.viz.study`'s.
Imports are lazy so that importing
this package is cheap and never needs Dask.
"""

__all__ = ["run_study", "plan_study", "read_manifest", "StudyReport", "StudyError",
           "StudyInterrupted", "StudyWarning"]


def __getattr__(name):
    if name in __all__:
        from actuator_design.study import runner
        return getattr(runner, name)
    raise AttributeError(name)
