"""Accuracy as an input: pick the resolution for a tolerance, and estimate the error a posteriori.

:func:`choose_options` picks the cheapest LGL settings expected to meet a tip tolerance from the
scene's length scales; :func:`solve_to_tolerance` solves at that resolution and at a finer one
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

import numpy as np

from .options import SolverOptions
from .scene import Scene

__all__ = ["choose_options", "solve_to_tolerance", "scene_wavenumber", "tip_difference",
           "MAX_ELEMENTS"]

#: refinement stops here (≈ 2000 unknowns at degree 10)
MAX_ELEMENTS = 200


def scene_wavenumber(scene: Scene) -> float:
    """k: the inverse of the shortest length on which θ can vary (units of 1/ℓ), ≥ 1.

    Each term states its own (``EnergyTerm.wavenumber``): the field √2 h (the pendulum frequency of
    THEORY §6); loads √|f| (elastica), |m|, |q|^(1/3); non-uniform fields add their own scale
    through h and h_pos (times 1/distance, not known a priori — the a-posteriori estimate catches it).
    """
    from .physics.terms import scene_wavenumber as terms_wavenumber

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


def _finer(opts: SolverOptions) -> SolverOptions:
    return replace(opts, degree=opts.degree + 4)


def solve_to_tolerance(scene: Scene, tol: float, options: Optional[SolverOptions] = None,
                       initial=None, max_refinements: int = 6):
    """Solve ``scene`` with a tip error estimated ≤ ``tol``; the result carries ``error_estimate``.

    Starts at :func:`choose_options`; at each level solves at (E, d) and (E, d + 4), the finer one
    warm-started by interpolating the coarse solution; stops when the tip difference is ≤ tol, else
    doubles E (up to :data:`MAX_ELEMENTS`).

    Parameters
    ----------
    scene : Scene
    tol : float
        Target tip error (units of ℓ, rad).
    options : SolverOptions, optional
        Base options (method, ensure_stable, …); resolution fields are overridden.
    initial : callable, EquilibriumResult or array_like, optional
        Warm start for the first coarse solve: θ(s) as a callable of arc length (array in, array
        out), a result to interpolate, or θ at the coarse nodes. Default: the state reached from
        rest (:mod:`actuator_design.from_rest`; ``options.start="straight"``: the straight rod).
    max_refinements : int

    Returns
    -------
    EquilibriumResult
        The finer solution of the last level, with ``error_estimate`` (float, also in
        ``stats["error_estimate"]``), ``stats["accuracy_levels"]`` (the (elements, degree,
        estimate) tried) and ``success`` false with an explanatory message when the estimate
        did not reach ``tol`` (or a solve failed).
    """
    from .equilibrium import solve
    from .result import EquilibriumResult
    from .solver import get_solver

    opts = choose_options(scene, tol, options)
    levels = []
    guess = initial
    fine = None
    estimate = math.inf
    for _ in range(max_refinements + 1):
        coarse_solver = get_solver(scene, opts)
        if guess is None and not levels and opts.start == "rest":
            # the state reached from rest (loads and field ramped from zero), as plain solve does
            from .from_rest import path_from_rest

            path = path_from_rest(coarse_solver, coarse_solver.parameter_vector(scene),
                                  follow_stable=opts.ensure_stable)
            guess = path.z if path.reached else None
        if isinstance(guess, EquilibriumResult):
            guess = guess.evaluate(coarse_solver.transcription.nodes)["theta"]
        elif callable(guess):
            guess = np.asarray(guess(coarse_solver.transcription.nodes), float)
        coarse = solve(scene, opts, initial=guess, solver=coarse_solver)
        fopts = _finer(opts)
        fine_solver = get_solver(scene, fopts)
        fguess = coarse.evaluate(fine_solver.transcription.nodes)["theta"] if coarse.success else None
        fine = solve(scene, fopts, initial=fguess, solver=fine_solver)
        ok = coarse.success and fine.success and np.isfinite(fine.tip["x"])
        estimate = tip_difference(coarse, fine) if ok else math.inf
        levels.append((opts.elements, opts.degree, estimate))
        if ok and estimate <= tol:
            break
        if opts.elements >= MAX_ELEMENTS:
            break
        guess = fine if fine.success else None
        opts = replace(opts, elements=min(MAX_ELEMENTS, 2 * opts.elements))
    result = fine
    result.error_estimate = float(estimate)
    result.stats["error_estimate"] = float(estimate)
    result.stats["accuracy_tol"] = float(tol)
    result.stats["accuracy_levels"] = [list(v) for v in levels]
    if not (estimate <= tol):
        result.success = False
        result.status = "not_converged" if result.status == "converged" else result.status
        result.message += (f"; accuracy: estimated tip error {estimate:.3g} > tol {tol:.3g} "
                           f"after {len(levels)} level(s)")
    else:
        result.message += f"; accuracy: estimated tip error {estimate:.2g} <= tol {tol:.2g}"
    return result
