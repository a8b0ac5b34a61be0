"""Files of a fit: ``fit.json``, ``fit_points.csv`` and the two figures."""
from __future__ import annotations

from pathlib import Path
from typing import Dict, Optional

from actuator_design import __version__
from actuator_design.calibration.report import fit_units, points_csv_text, result_dict
from actuator_design.calibration.result import FitResult
from actuator_design.io.save import dumps_json, write_output_set

__all__ = ["write_fit", "fit_files"]


def fit_files(result: FitResult, config: Optional[dict] = None) -> Dict[str, object]:
    """``fit.json``, ``fit_points.csv``, ``fit_data_vs_model.png`` and ``fit_residuals.png``, in memory
    (text, then PNG bytes from :mod:`actuator_design.viz.calibration`). A physical ``config``
    adds the user's units (:func:`~.report.fit_units`): ``physical`` in the JSON, columns in the
    user's units in the CSV, figure axes in them."""
    from actuator_design.viz.calibration import fit_figure_pngs

    units = fit_units(config)
    payload = {**result_dict(result, units), "config": config, "package_version": __version__}
    files: Dict[str, object] = {"fit.json": dumps_json(payload, indent=1) + "\n",
                                "fit_points.csv": points_csv_text(result, units)}
    files.update({f"{name}.png": data for name, data in fit_figure_pngs(result, units=units).items()})
    return files


def write_fit(result: FitResult, out_dir, config: Optional[dict] = None) -> Dict[str, Path]:
    """Write the files of :func:`fit_files` into ``out_dir``, all or nothing
    (:func:`actuator_design.io.save.write_output_set`).

    Returns
    -------
    dict of str → Path
        ``json``, ``csv`` and one entry per figure name.
    """
    files = fit_files(result, config)
    written = {p.name: p for p in write_output_set(out_dir, files)}
    out = {"json": written["fit.json"], "csv": written["fit_points.csv"]}
    out.update({name[:-4]: path for name, path in written.items() if name.endswith(".png")})
    return out
