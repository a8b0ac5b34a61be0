"""
Calibration against measurements, with confidence intervals
===========================================================

``configs/fit_transverse_buckling.yaml`` with the synthetic data of
``problems/data/synthetic_transverse_buckling.csv``: a 20 × 5 × 0.5 mm strip in a field across it,
its tip angle measured at several fields (above the buckling field it buckles down, the branch the
data are on). The fit takes each row's field from the CSV and fits the orientational susceptibility
χ̄ and the clamp angle, with 95 % confidence intervals from the linearised model and the stated
measurement uncertainty (0.5° per tip angle).
"""
from pathlib import Path

import actuator_design as ad
from actuator_design.calibration.report import summary_text
from actuator_design.viz.calibration import fit_figures

ROOT = Path(ad.__file__).resolve().parents[1]
problem = ad.prepare_fit(ROOT / "configs" / "fit_transverse_buckling.yaml",
                         ROOT / "problems" / "data" / "synthetic_transverse_buckling.csv")
result = ad.fit(problem, interruptible=False)
print(summary_text(result))

# %%
# Data against the fitted model, and the residuals.
figures = fit_figures(result)
