"""Accuracy as an input: pick the resolution for a tolerance, and estimate the error a posteriori.

:func:`choose_options` picks the cheapest LGL settings expected to meet a tip tolerance from the
scene's length scales; :func:`~actuator_design.equilibrium.pipeline.solve_to_tolerance` (the solve
pipeline's accuracy mode, ``SolverOptions(accuracy=...)``) solves at that resolution and at a finer one
(degree + 4 on the same elements, warm-started from the coarse solution by interpolation), takes
the difference of the tips as the error estimate, refines (more elements) until the estimate meets
the tolerance, and returns the finer solution with ``error_estimate`` attached.

Why two resolutions bound the error: for smooth solutions the LGL error falls spectrally with the
degree (THEORY-independent; measured in ``actuator-design bench``), so the finer solution's error
e_f is much smaller than the coarse one's e_c and |tip_c − tip_f| = e_c ± e_f ≥ e_f. The estimate
is therefore conservative for the returned (finer) solution whenever the coarse one is in the
asymptotic regime; ``tests/test_accuracy.py`` checks it against THEORY §6 closed forms.

Length scales (THEORY §5): the Euler–Lagrange equation θ'' = h² sin 2(θ+α−φ) − p cos θ + …
varies on the scale 1/k with k = max(√2 h, √|f|, |m|, |q|^(1/3), |h_pos|·√2): near the clamp a
boundary layer of width ~1/(√2 h) forms in strong fields. Elements are chosen no longer than
≈ 3/k so that every element resolves it.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Optional

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene
from actuator_design.physics.registry import scene_wavenumber as terms_wavenumber

__all__ = ["choose_options", "scene_wavenumber", "tip_difference", "finer_options", "MAX_ELEMENTS"]

#: refinement stops here (≈ 2000 unknowns at degree 10)
MAX_ELEMENTS = 200


def scene_wavenumber(scene: Scene) -> float:
    """k: the inverse of the shortest length on which θ can vary (units of 1/ℓ), ≥ 1.

    Each term states its own (``EnergyTerm.wavenumber``): the field √2 h (the pendulum frequency of
    THEORY §6); loads √|f| (elastica), |m|, |q|^(1/3); non-uniform fields add their own scale
    through h and h_pos (times 1/distance, not known a priori — the a-posteriori estimate catches it).
    """
    return terms_wavenumber(scene)


def choose_options(scene: Scene, tol: float, base: Optional[SolverOptions] = None) -> SolverOptions:
    """Cheapest LGL settings expected to give a tip error ≤ ``tol`` (a priori).

    Degree from the tolerance (spectral convergence: about one digit per degree, as measured by
    ``actuator-design bench``: degree 8 gives ~1e-8…1e-10 on the paper's cases, degree 12
    ~1e-12; degree = digits + 1), elements from the scene's wavenumber k (element length ≤ 3/k).

    Parameters
    ----------
    scene : Scene
    tol : float
        Target tip error (units of ℓ and rad), in (0, 1).
    base : SolverOptions, optional
        Options to start from (method, tolerances); default ``SolverOptions(method="fast")``.

    Returns
    -------
    SolverOptions
        ``transcription="lgl"`` with the chosen ``elements`` and ``degree``; the stationarity
        tolerance is set to min(base.tol, tol/100).
    """
    if not (0.0 < tol < 1.0) or not math.isfinite(tol):
        raise ValueError(f"tol must lie in (0, 1), got {tol!r}")
    base = base or SolverOptions(method="fast")
    digits = -math.log10(tol)
    degree = int(min(16, max(4, math.ceil(digits) + 1)))
    k = scene_wavenumber(scene)
    elements = int(min(MAX_ELEMENTS, max(1, math.ceil(k / 3.0))))
    return replace(base, transcription="lgl", elements=elements, degree=degree,
                   tol=min(base.tol, max(1e-14, tol * 1e-2)))


def tip_difference(a, b) -> float:
    """max(|Δx(1)|, |Δy(1)|, |Δθ(1)|) between two results (units of ℓ, rad)."""
    return float(max(abs(a.tip["x"] - b.tip["x"]), abs(a.tip["y"] - b.tip["y"]),
                     abs(a.tip["angle"] - b.tip["angle"])))


def finer_options(opts: SolverOptions) -> SolverOptions:
    return replace(opts, degree=opts.degree + 4)


