"""The result of a fit: parameters with intervals, residuals, identifiability, fitted model."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List

import numpy as np

from actuator_design.calibration.data import MeasuredData
from actuator_design.calibration.report import result_dict, summary_text

__all__ = ["FitResult"]


@dataclass
class FitResult:
    """Fitted parameters with intervals, residuals, identifiability, and the fitted model.

    Attributes
    ----------
    success : bool
        The optimiser converged, every data point has a converged, stable equilibrium, the fit
        moved from its start (or started at the optimum), the data determine every fitted
        parameter (or a reported combination of held ones), no fitted parameter ends on a bound
        and the residuals pass the χ² test (when the uncertainties are given, :mod:`.goodness`).
    status, message : str
        ``status`` is ``converged``, ``not_converged``, ``not_identifiable``, ``did_not_move``,
        ``at_bound`` or ``poor_fit`` (the first failure in this order); ``message`` says what
        failed, every failure found.
    parameters : dict
        name → {"value", "unit", "std", "ci": [low, high], "initial", "bounds", "fitted",
        "scale", "at_bound", "bound_side"} in SI units (``fitted`` False for a parameter held
        because it was not identifiable; ``bound_side`` "lower", "upper" or None).
    confidence : float
    identifiable : bool
    warnings : list of str
    combinations : list of dict
        Identifiable combinations reported when parameters were held.
    covariance, correlation : ndarray, shape (k, k)
        Of the fitted parameters (natural units), in ``fitted_names`` order.
    singular_values : ndarray
        Of the column-normalised weighted Jacobian, relative to the largest.
    residuals : ndarray, shape (n, n_out)
        Model − data, SI units.
    model : ndarray, shape (n, n_out)
    s2 : float
        Residual variance of the weighted residuals.
    goodness_of_fit : dict
        The χ² test (:func:`.goodness.chi_square_test`): ``tested``, ``passed``, ``chi2``,
        ``dof``, ``chi2_reduced``, ``p_value``, ``min_p_value``, ``threshold``, ``rule``.
    """

    def __repr__(self) -> str:
        """One line: the status and each parameter's value with its interval (SI units)."""
        parts = [f"{n}={p['value']:.6g}" + (f" [{p['ci'][0]:.4g}, {p['ci'][1]:.4g}]" if p.get("ci") else "")
                 + f" {p.get('unit', '')}".rstrip() for n, p in self.parameters.items()]
        return f"FitResult(status={self.status!r}, success={self.success}, {', '.join(parts)})"


    success: bool
    status: str
    message: str
    parameters: Dict[str, dict]
    fitted_names: List[str]
    confidence: float
    identifiable: bool
    warnings: List[str]
    combinations: List[dict]
    derived: Dict[str, dict]
    covariance: np.ndarray
    correlation: np.ndarray
    singular_values: np.ndarray
    model: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    s2: float
    dof: int
    optimizer: Dict[str, Any]
    points: List[dict]
    curves: Dict[str, Any]
    data: MeasuredData
    outputs: List[str]
    name: str = "fit"
    solver: Dict[str, Any] = field(default_factory=dict)
    goodness_of_fit: Dict[str, Any] = field(default_factory=dict)

    @property
    def rms(self) -> Dict[str, float]:
        """RMS residual of each output column, in the unit of the data file."""
        return {o: float(np.sqrt(np.mean(self.data.as_given(o, self.residuals[:, j]) ** 2)))
                for j, o in enumerate(self.outputs)}

    def to_dict(self) -> Dict[str, Any]:
        """The JSON contract of ``actuator-design fit --json`` (see :mod:`.report`)."""
        return result_dict(self)

    def summary(self) -> str:
        """A readable multi-line report (see :mod:`.report`)."""
        return summary_text(self)
