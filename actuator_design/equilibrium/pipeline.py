"""``solve``: one equilibrium of a scene, with its stability verdict (the public forward API).

One pipeline that only calls down: the mesh chosen for the scene (or for a tolerance,
:func:`solve_to_tolerance`), the state reached from rest, one solve (:mod:`.single`), the
acceptance checks (:mod:`actuator_design.equilibrium.acceptance`); a scene with obstacles, or a rod that meets itself, goes
to the contact solves (:mod:`actuator_design.contact`).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Optional, Tuple, Union

import numpy as np

# contact/'s solves are called through their modules (``contact_equilibrium.solve_contact``): the
# seam where a test puts a stand-in
from actuator_design.contact import equilibrium as contact_equilibrium
from actuator_design.contact import self_solve
from actuator_design.contact.self_contact import REACH, self_penetration
from actuator_design.continuation.from_rest import path_from_rest
from actuator_design.equilibrium.acceptance import check_physical, refined, solve_checked
from actuator_design.equilibrium.accuracy import MAX_ELEMENTS, choose_options, finer_options, tip_difference
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.single import solve_on
from actuator_design.equilibrium.solver import EquilibriumSolver, get_solver
from actuator_design.model.scene import Scene

__all__ = ["solve", "solve_on", "solve_to_tolerance", "solve_from_rest"]


def solve(scene: Scene, options: Optional[SolverOptions] = None,
          initial: Union[None, np.ndarray, EquilibriumResult] = None,
          solver: Optional[EquilibriumSolver] = None) -> EquilibriumResult:
    """Compute an equilibrium of ``scene`` by minimising its discrete energy.

    Without a ``solver`` (and without a node-array ``initial``) ``solve`` chooses the mesh from the
    scene and checks the answer (:mod:`actuator_design.equilibrium.acceptance`): the state reached from rest
    (``options.start``), the mesh graded towards boundary layers and (LGL, up to 4 doublings of its
    elements) refined until the Euler–Lagrange residual meets ``options.residual_tol``; an
    inaccurate or self-intersecting
    result is ``success=False`` with ``status`` ``"inaccurate"`` or ``"self_intersecting"``.
    With a ``solver`` it is one warm-started solve on that solver's mesh (the analyses' path).

    Parameters
    ----------
    scene : Scene
        Dimensionless scene (THEORY §5).
    options : SolverOptions, optional
        Transcription, resolution, method; defaults to ``SolverOptions()``. With
        ``options.accuracy`` set (and no ``solver``), the resolution is chosen for that tip error
        and the result carries ``error_estimate`` (:func:`solve_to_tolerance`).
    initial : ndarray of shape (n_nodes,) or EquilibriumResult, optional
        Warm start (θ at the nodes). Default: the state reached from rest, or with
        ``options.start="straight"`` (or a ``solver`` given) the straight rod at the clamp angle.
    solver : EquilibriumSolver, optional
        A solver built for this scene's structure (default: the cached one).

    Returns
    -------
    EquilibriumResult
        Never raises on non-convergence: ``success``/``status``/``message`` say what happened.
    """
    options = options or SolverOptions()
    warm_self = (isinstance(initial, EquilibriumResult) and options.self_contact
                 and not options.keep_self_intersecting and scene.contact_gap > 0 and _near_itself(initial))
    if scene.obstacles or warm_self:  # unilateral constraints: IPOPT with the contact rows (a start
        result = contact_equilibrium.solve_contact(scene, options,
                                                   initial if isinstance(initial, EquilibriumResult) else None)
        if options.adapt:  # a mesh that misses the residual limit: the contact solve on a finer one
            result = _refined_contact(scene, result, contact_equilibrium.solve_contact)
    elif options.accuracy is not None and solver is None:
        result = check_physical(solve_to_tolerance(scene, options.accuracy,
                                                   options=replace(options, accuracy=None), initial=initial))
    elif solver is None and not isinstance(initial, np.ndarray):
        result = solve_checked(scene, options, initial)
    else:
        return solve_on(scene, options, initial, solver)
    if (options.self_contact and not options.keep_self_intersecting and scene.contact_gap > 0
            and not (result.contact or {}).get("self_contact")):
        # a shape that crosses itself or enters its own thickness: the rod against itself, the
        # contact equilibrium reached from rest (issue 20 item 3)
        # (also a contact result judged inaccurate for entering an obstacle: the rod wound round a
        # peg onto itself enters the peg because it passes through its own turn)
        through = result.status == "self_intersecting" or (
            (result.success or result.status == "inaccurate") and self_penetration(result, scene.contact_gap))
        if through:
            result = self_solve.solve_self_contact(scene, options,
                                                   initial if isinstance(initial, EquilibriumResult) else None)
            if options.adapt and isinstance(result, EquilibriumResult):  # (not a test's stand-in)
                result = _refined_contact(scene, result, self_solve.solve_self_contact)
    return result


def _refined_contact(scene: Scene, result: EquilibriumResult, contact_solve) -> EquilibriumResult:
    """A contact ``result`` refined as any solve's (:func:`~actuator_design.equilibrium.acceptance.refined`),
    each finer mesh by ``contact_solve(scene, options, initial, start=...)`` from the coarser state,
    while the residual is all it misses (:func:`~actuator_design.contact.equilibrium.mesh_limited`)."""
    return refined(scene, result,
                   lambda finer, warm: contact_solve(scene, finer, warm, start="its state on the coarser mesh"),
                   contact_equilibrium.mesh_limited)


def solve_from_rest(scene: Scene, options: SolverOptions) -> Tuple[EquilibriumResult, bool]:
    """The stable state :func:`solve` reaches from rest in ``scene``, and whether it converged — a
    state that misses the accuracy promise on the mesh solve chose included: as the warm start of
    an analysis on its own (finer) mesh, the analysis' own check decides."""
    res = solve(scene, replace(options, ensure_stable=True))
    return res, bool(res.success or res.status == "inaccurate")


def _near_itself(state: EquilibriumResult) -> bool:
    """Whether a warm start presses on itself, or comes within reach of it
    (:data:`~actuator_design.contact.self_contact.REACH`): a step from it keeps the self-contact rows, which
    keep the rod on its side of itself (a free step could pass through the rod's thickness)."""
    if (state.contact or {}).get("self_contact"):
        return True
    gap = state.scene.contact_gap
    return bool(state.success and gap > 0 and self_penetration(state, gap, n=401, tol=-REACH) is not None)


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
        rest (:mod:`actuator_design.continuation.from_rest`; ``options.start="straight"``: the straight rod).
    max_refinements : int

    Returns
    -------
    EquilibriumResult
        The finer solution of the last level, with ``error_estimate`` (float, also in
        ``stats["error_estimate"]``), ``stats["accuracy_levels"]`` (the (elements, degree,
        estimate) tried) and ``success`` false with an explanatory message when the estimate
        did not reach ``tol`` (or a solve failed).
    """

    opts = choose_options(scene, tol, options)
    levels = []
    guess = initial
    fine = None
    estimate = math.inf
    for _ in range(max_refinements + 1):
        coarse_solver = get_solver(scene, opts)
        if guess is None and not levels and opts.start == "rest":
            # the state reached from rest (loads and field ramped from zero), as plain solve does
            path = path_from_rest(coarse_solver, coarse_solver.parameter_vector(scene),
                                  follow_stable=opts.ensure_stable)
            guess = path.z if path.reached else None
        if isinstance(guess, EquilibriumResult):
            guess = guess.evaluate(coarse_solver.transcription.nodes)["theta"]
        elif callable(guess):
            guess = np.asarray(guess(coarse_solver.transcription.nodes), float)
        coarse = solve(scene, opts, initial=guess, solver=coarse_solver)
        fopts = finer_options(opts)
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
