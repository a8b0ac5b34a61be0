"""Calibration: fit scene parameters to measured equilibria, with confidence intervals.

Modules, one job each:

* :mod:`.data` — measurement files (CSV, units in the header) → :class:`MeasuredData`;
* :mod:`.parameters` — the fittable parameters (the physical parameters of the lens
  :mod:`actuator_design.physics.parameters`) and the measured outputs;
* :mod:`.spec` — the ``study: {type: fit}`` section;
* :mod:`.problem` — conditions → scenes → stable equilibria → outputs, exact sensitivities
  (:mod:`.branches` picks the measured branch; :mod:`.curves` draws the model along an input);
* :mod:`.solve` — nested least squares (:func:`fit`), with :mod:`.identifiability` and
  :mod:`.intervals`;
* :mod:`.result`, :mod:`.report`, :mod:`.outputs` — the result, its text/JSON/CSV, its files.

Figures are in :mod:`actuator_design.viz.calibration`.
"""
from actuator_design.calibration.data import (COLUMNS, INPUTS, OUTPUTS, DataError, MeasuredData, parse_data,
                                              read_data)
from actuator_design.calibration.outputs import write_fit
from actuator_design.calibration.parameters import PARAMETERS
from actuator_design.calibration.problem import FitProblem
from actuator_design.calibration.report import points_csv_text
from actuator_design.calibration.result import FitResult
from actuator_design.calibration.solve import fit, fit_config, prepare_fit
from actuator_design.calibration.spec import FitSpec, ParameterSpec

__all__ = ["COLUMNS", "INPUTS", "OUTPUTS", "DataError", "MeasuredData", "parse_data", "read_data",
           "PARAMETERS", "FitSpec", "ParameterSpec", "FitProblem", "FitResult", "prepare_fit",
           "fit", "fit_config", "write_fit", "points_csv_text"]
