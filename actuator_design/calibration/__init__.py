"""Calibration: fit scene parameters to measured equilibria, with confidence intervals.

Modules, one job each:

* :mod:`.data` — measurement files (CSV, units in the header) → :class:`MeasuredData`;
* :mod:`.parameters` — the fittable parameters (the physical parameters of the lens
  :mod:`actuator_design.physics.parameters`) and the measured outputs;
* :mod:`.limits` — the size limits of a fit and its plausibility bounds (the ``study: {type: fit}``
  section is validated by :mod:`actuator_design.config.studies.fit`);
* :mod:`.problem` — conditions → scenes → stable equilibria → outputs, exact sensitivities
  (:mod:`.branches` picks the measured branch; :mod:`.curves` draws the model along an input);
* :mod:`.solve` — nested least squares (:func:`fit`), with :mod:`.identifiability` and
  :mod:`.intervals`;
* :mod:`.result`, :mod:`.report`, :mod:`.outputs` — the result, its text/JSON/CSV, its files.

Figures are in :mod:`actuator_design.viz.calibration`.
"""
import importlib

#: public name → the module of this package that defines it (imported on first use, PEP 562, so
#: importing one module of the package, e.g. ``calibration.data``, does not import them all)
_HOME = {
    "COLUMNS": "data",
    "INPUTS": "data",
    "OUTPUTS": "data",
    "DataError": "data",
    "MeasuredData": "data",
    "parse_data": "data",
    "read_data": "data",
    "write_fit": "outputs",
    "PARAMETERS": "parameters",
    "FitProblem": "problem",
    "points_csv_text": "report",
    "FitResult": "result",
    "fit": "solve",
    "fit_config": "solve",
    "prepare_fit": "solve",
    "FitSpec": "actuator_design.config.studies.fit",
    "ParameterSpec": "actuator_design.config.studies.fit",
}

__all__ = ["COLUMNS", "INPUTS", "OUTPUTS", "DataError", "MeasuredData", "parse_data", "read_data",
           "PARAMETERS", "FitSpec", "ParameterSpec", "FitProblem", "FitResult", "prepare_fit",
           "fit", "fit_config", "write_fit", "points_csv_text"]


def __getattr__(name):
    if name in _HOME:
        home = _HOME[name] if "." in _HOME[name] else f"actuator_design.calibration.{_HOME[name]}"
        value = getattr(importlib.import_module(home), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_HOME))
