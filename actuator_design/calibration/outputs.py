"""Files of a fit: ``fit.json``, ``fit_points.csv`` and the two figures."""
from __future__ import annotations

from pathlib import Path
from typing import Dict, Optional

from .report import points_csv_text
from .result import FitResult

__all__ = ["write_fit"]


def write_fit(result: FitResult, out_dir, config: Optional[dict] = None) -> Dict[str, Path]:
    """Write ``fit.json``, ``fit_points.csv``, ``fit_data_vs_model.png`` and ``fit_residuals.png``
    into ``out_dir`` (each written to a temporary name, then renamed).

    Everything is composed in memory first (text, then figures from
    :mod:`actuator_design.viz.calibration`), so a failure there writes nothing.

    Returns
    -------
    dict of str → Path
        ``json``, ``csv`` and one entry per figure name.
    """
    from .. import __version__
    from ..io import atomic_write, dumps_json
    from ..viz.calibration import fit_figure_pngs

    payload = {**result.to_dict(), "config": config, "package_version": __version__}
    text = dumps_json(payload, indent=1) + "\n"
    csv_text = points_csv_text(result)
    pngs = fit_figure_pngs(result)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "fit.json", "csv": out / "fit_points.csv"}
    atomic_write(paths["json"], lambda fh: fh.write(text))
    atomic_write(paths["csv"], lambda fh: fh.write(csv_text))
    for name, data in pngs.items():
        paths[name] = atomic_write(out / f"{name}.png", lambda fh, b=data: fh.write(b), binary=True)
    return paths
