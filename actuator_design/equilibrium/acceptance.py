"""Convergence is a promise: the mesh ``solve`` chooses, and the checks a result must pass.

``solve(scene)`` without a solver goes through :func:`solve_checked`:

1. **Mesh from the scene.** Boundary layers of width ~1/k (THEORY §5; k = √2 h in strong fields,
   √|f| under large loads, :func:`~actuator_design.equilibrium.accuracy.scene_wavenumber`) sit at the clamp
   (and at a loaded tip). The LGL mesh is graded geometrically towards them until the end element
   is ≤ 1/k long (:func:`graded_options`): ~log2(k/E) extra elements instead of ~k/3 uniform ones.
2. **The physical branch.** From no guess, the state reached from rest (:mod:`actuator_design.continuation.from_rest`);
   the straight-rod start is solved too: when it reaches the same state its result is returned
   (bit for bit the answer of earlier releases), otherwise the state from rest is, and another
   stable state from the straight rod is reported (``stats["other_stable_states"]``, ``message``)
   when it passes the accuracy check 3 (an unresolved mesh solution is not a state of the rod).
3. **Accuracy.** The Euler–Lagrange residual (the moment balance of THEORY §4, evaluated on the
   dense solution between the nodes: a strong-form, a-posteriori check of the discretisation) must
   be ≤ ``residual_tol`` × the moment scale max(1, |clamp moment|, |clamp force|, |tip moment|);
   with ``adapt`` a result that misses it is solved again on twice the elements, warm-started, up
   to :data:`REFINE_DOUBLINGS` times; one that still fails is ``success=False``,
   ``status="inaccurate"`` (``options.accuracy``, the two-level estimate of
   :mod:`actuator_design.equilibrium.accuracy`, asks for a tip tolerance instead).
4. **No self-intersection.** A shape crossing itself is not a physical equilibrium:
   ``success=False``, ``status="self_intersecting"``, unless ``options.keep_self_intersecting``;
   :func:`~actuator_design.equilibrium.pipeline.solve` then solves it with self-contact where the scene has a
   thickness (``options.self_contact``, :mod:`actuator_design.contact.self_contact`).
"""
from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Optional

import numpy as np

from actuator_design.continuation.from_rest import path_from_rest
from actuator_design.config.limits import mesh_problem
from actuator_design.equilibrium.accuracy import MAX_ELEMENTS, scene_wavenumber, tip_difference
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.dense_shape import nan_balance
from actuator_design.equilibrium.single import make_result, solve_on
from actuator_design.equilibrium.solver import get_solver
from actuator_design.physics.registry import dense_hessian, end_moment, tip_layer
from actuator_design.reduced.newton import RawSolution
from actuator_design.reduced.stability import StabilityVerdict

__all__ = ["solve_checked", "accept", "refined", "REFINE_DOUBLINGS", "graded_options", "graded_for_scenes",
           "residual_problem", "moment_scale", "check_physical", "warm_values"]

#: tip difference (rod lengths, rad) above which two equilibria count as different states
DISTINCT = 1e-6
#: how often :func:`solve_checked` doubles the elements of a result that misses the residual limit
#: (4 → 64 elements on the default mesh)
REFINE_DOUBLINGS = 4


def graded_options(scene, options: SolverOptions) -> SolverOptions:
    """``options`` with grading levels raised so that the end elements resolve the scene's layers.

    The element next to the clamp gets length 2^-n/E ≤ 1/k (k from
    :func:`~actuator_design.equilibrium.accuracy.scene_wavenumber`), i.e. n = ⌈log2(k / E)⌉, when the uniform
    elements are longer than 3/k (below that, degree-10 elements resolve the layer already);
    the same towards the tip when a term makes a layer there (a tip moment, a fibre angle or a
    magnetisation that varies along the rod, a field that varies in direction, a distributed load:
    :func:`~actuator_design.physics.registry.tip_layer`). Midpoint meshes
    are not graded.
    """
    if options.transcription != "lgl":
        return options
    k = scene_wavenumber(scene)
    E = int(options.elements)
    need = int(math.ceil(math.log2(k / E))) if k > 3.0 * E else 0
    tip_need = need if tip_layer(scene) else 0
    clamp = max(int(options.clamp_levels), need)
    tip = max(int(options.tip_levels), tip_need)
    if (clamp, tip) == (options.clamp_levels, options.tip_levels):
        return options
    return replace(options, clamp_levels=clamp, tip_levels=tip)


def graded_for_scenes(scenes, options: SolverOptions) -> SolverOptions:
    """``options`` graded for the most demanding of ``scenes`` (the most levels towards the clamp
    and the tip any of them asks for, :func:`graded_options`): one mesh for a path or a branch
    through all of them; ``options`` itself with ``adapt`` off."""
    if not options.adapt:
        return options
    graded = [graded_options(sc, options) for sc in scenes]
    return replace(options, clamp_levels=max([options.clamp_levels] + [g.clamp_levels for g in graded]),
                   tip_levels=max([options.tip_levels] + [g.tip_levels for g in graded]))


def moment_scale(result) -> float:
    """max(1, |clamp moment|, |clamp force|, |tip moment|): the size of the terms of the moment
    balance (units of B0/ℓ); the bending moment θ'(s) is largest at the clamp or at a loaded tip."""
    return float(max(1.0, abs(result.clamp_moment), float(np.max(np.abs(result.clamp_force))),
                     end_moment(result.scene)))


def residual_limit(options: SolverOptions) -> float:
    """The accepted relative Euler–Lagrange residual: ``residual_tol`` for LGL; the midpoint rule
    (θ' piecewise constant, first order between the nodes) is held to max(residual_tol, 10/N)."""
    if options.transcription == "midpoint":
        return max(options.residual_tol, 10.0 / options.elements)
    return options.residual_tol


def residual_problem(result) -> Optional[str]:
    """Why ``result`` misses the accuracy asked for, or ``None`` (its Euler–Lagrange residual
    relative to :func:`moment_scale` within :func:`residual_limit`)."""
    if not np.isfinite(result.el_residual):
        return "the Euler–Lagrange residual is not finite"
    scale = moment_scale(result)
    limit = residual_limit(result.options)
    if result.el_residual <= limit * scale:
        return None
    return (f"Euler–Lagrange residual {result.el_residual:.3e} > {limit:.1e} x moment scale "
            f"{scale:.3g} = {limit * scale:.3e} (the mesh does not resolve the solution)")


def check_physical(result):
    """Mark a self-intersecting ``result`` as failed unless its options keep it, and one whose shape
    leaves the region where the field's representation holds (a fitted magnet or coil field,
    :mod:`~actuator_design.model.field_sources`), in place."""
    region = getattr(result.scene.field, "region_problem", None)
    if region is not None and result.status != "outside_field_region":  # also a failed solve: it
        # may have failed because the rod left it
        d = result.evaluate(np.linspace(0.0, 1.0, 401))
        problem = region(d["x"], d["y"]) if np.all(np.isfinite(d["x"])) else None
        if problem is not None:
            result.success = False
            result.status = "outside_field_region"
            result.message += (f"; {problem}: the field there is not known to its stated accuracy (a rod "
                               "pulled onto a magnet leaves the region its field is fitted in)")
            return result
    note = getattr(result.scene.field, "failure_note", None)
    if not result.success and note is not None and not result.scene.obstacles:
        d = result.evaluate(np.linspace(0.0, 1.0, 401))
        text = note(d["x"], d["y"])
        result.message += f"; {text}" if text else ""
    if not result.success or result.options.keep_self_intersecting or not result.self_intersecting:
        return result
    result.success = False
    result.status = "self_intersecting"
    how = ("self_contact is off (--no-self-contact)" if not result.options.self_contact else
           "self-contact needs the rod's half-thickness (contact_gap > 0, set from rod.thickness on a physical scene)")
    result.message += (f"; the shape intersects itself, which is not a physical equilibrium ({how}): "
                       "keep_self_intersecting (--keep-self-intersecting) accepts it as it is")
    return result


def solve_checked(scene, options: SolverOptions, initial=None):
    """:func:`~actuator_design.equilibrium.pipeline.solve` without a solver: mesh, start, checks (module doc).

    Parameters
    ----------
    scene : Scene
    options : SolverOptions
    initial : EquilibriumResult or None
        Warm start, interpolated onto the chosen mesh; ``None``: from rest (``options.start``).

    Returns
    -------
    EquilibriumResult
    """
    opts = graded_options(scene, options) if options.adapt else options
    solver = get_solver(scene, opts)
    if initial is None:
        result = _solve_from_start(scene, opts, solver)
    else:
        result = _solve_warm(scene, opts, solver, initial)
    if options.adapt:
        result = refined(scene, result)
    return accept(result)


def refined(scene, result, resolve=None, refinable=None):
    """``result`` again on meshes of twice as many elements (the grading kept), each warm-started
    from the one before, while it converged but misses the residual limit (check 3): an a-priori
    mesh that a term's own scale does not tell (a magnetisation turning along the rod) is refined
    until the promise holds, at most :data:`REFINE_DOUBLINGS` times and within the memory budget
    (beyond, the result says it is inaccurate); it stops where a doubling no longer halves the
    residual relative to the moment scale (a contact solve levels off near 1e-7: more elements
    only cost time) and returns the most accurate result. LGL only: the midpoint rule's limit
    10/N falls as fast as its residual. The message says so, and why refinement stopped short of
    the limit; the notes of the solve from rest (snaps, branch points, other states) are kept;
    ``stats`` sum the solves' iterations and times.

    Parameters
    ----------
    scene : Scene
    result : EquilibriumResult
        Before the checks (a free solve) or after them (a contact solve, ``"inaccurate"``).
    resolve : callable (options, warm) -> EquilibriumResult, optional
        The solve on the finer ``options`` from the state ``warm`` (default: one solve on that mesh;
        a contact solve passes its own, with its boundary rounds).
    refinable : callable (EquilibriumResult) -> bool, optional
        Whether a result's failure is one a finer mesh mends (a contact solve's: not one cut short
        by its boundary rounds).
    """
    first = result
    if result.options.transcription != "lgl":
        return result
    dense = dense_hessian(scene)  # a non-uniform field's term, or a plug-in's, says so itself

    def ok(r) -> bool:  # a result a finer mesh may mend (or that is mended)
        return (r.success or r.status == "inaccurate") and (refinable is None or refinable(r))

    def relative(r) -> float:  # its residual relative to its own moment scale
        return float(r.el_residual) / moment_scale(r)

    solves, best, stopped = [result], result, None
    for doubling in range(REFINE_DOUBLINGS + 1):
        if not ok(result) or residual_problem(result) is None:
            break
        if doubling == REFINE_DOUBLINGS:
            stopped = f"after {REFINE_DOUBLINGS} doublings"
            break
        if result.self_intersecting and not result.options.keep_self_intersecting:
            stopped = "the shape crosses itself"  # refused whatever its accuracy
            break
        opts = result.options
        elements = 2 * int(opts.elements)
        if elements > MAX_ELEMENTS or mesh_problem(opts.transcription, elements + opts.extra_elements,
                                                   int(opts.degree), dense=dense) is not None:
            stopped = f"{elements} elements would exceed the mesh budget"
            break
        finer = replace(opts, elements=elements)
        nxt = (resolve(finer, result) if resolve is not None
               else _solve_warm(scene, finer, get_solver(scene, finer), result))
        if not ok(nxt):
            stopped = f"the solve on {elements} elements failed ({nxt.status})"
            break
        solves.append(nxt)
        if not relative(nxt) < 0.5 * relative(result):  # no longer converging (a contact's rounding floor)
            stopped = f"on {elements} elements the residual no longer fell ({nxt.el_residual:.3e})"
            best = min((best, nxt), key=relative)
            break
        result = best = nxt
    result = best
    if result is not first:
        # the notes of the solve from rest, not its solver's own
        notes = [n for n in first.message.split("; ")[1:]
                 if n.startswith(("from rest", "the loading path from rest", "another stable state"))]
        note = (f"the mesh refined to {result.options.elements} elements (on {first.options.elements} the "
                f"{residual_problem(first).split(' (')[0]})")
        if stopped is not None and residual_problem(result) is not None:
            note += f"; refinement stopped: {stopped}"
        result.message = _after_solver_clause(result.message, [note] + notes)
        for key in ("from_rest", "other_stable_states"):
            if key in first.stats:
                result.stats[key] = first.stats[key]
        result.stats["refined_from_elements"] = int(first.options.elements)
        for key in ("iterations", "solve_time_s"):
            if all(isinstance(r.stats.get(key), (int, float)) for r in solves):
                result.stats[key] = sum(r.stats[key] for r in solves)
        result.escaped_saddle = first.escaped_saddle or result.escaped_saddle
    elif stopped is not None and stopped != "the shape crosses itself":
        result.message = _after_solver_clause(result.message, [f"the mesh was not refined: {stopped}"])
    return result


def _after_solver_clause(message: str, clauses) -> str:
    """``message`` with ``clauses`` right after its first clause (the solver's own): an accuracy
    note the checks add (or added) follows them."""
    head, _, tail = message.partition("; ")
    return "; ".join([head, *clauses] + ([tail] if tail else []))


def accept(result):
    """Checks 3 and 4 of the module doc on a solved ``result`` (in place): a self-intersecting
    shape is ``"self_intersecting"``, one whose residual misses the limit ``"inaccurate"``."""
    problem = residual_problem(result) if result.success else None
    check_physical(result)  # not a physical state: said first, whatever its accuracy
    if problem is not None and result.success:
        result.success = False
        result.status = "inaccurate"
        # a contact solve does not apply the accuracy option (its mesh follows its contact points)
        advice = ("more elements (solver.elements) refine it" if result.contact is not None else
                  "solve --accuracy TOL (SolverOptions.accuracy) refines until a tip tolerance is met")
        result.message += f"; accuracy: {problem}; {advice}"
    return result


def warm_values(guess, nodes: np.ndarray):
    """θ at ``nodes`` (shape (n,), units of ℓ) from a warm start: node values as given, a result's
    own node values when its nodes are these, else its solution interpolated onto them."""
    if not hasattr(guess, "evaluate"):
        return guess
    same = guess.z is not None and guess.s.shape == nodes.shape and np.array_equal(guess.s, nodes)
    return guess.z if same else guess.evaluate(nodes)["theta"]


def _solve_warm(scene, opts, solver, guess):
    return solve_on(scene, opts, warm_values(guess, solver.transcription.nodes), solver, strict=True)


def _region_problem(scene, solver, z: np.ndarray) -> Optional[str]:
    """Why the state ``z`` (θ at the solver's nodes) lies where the field's fit does not hold, or None."""
    region = getattr(scene.field, "region_problem", None)
    if region is None or not np.all(np.isfinite(z)):
        return None
    tr = solver.transcription
    x, y = (np.asarray(v, float).ravel() for v in tr.point_positions(tr.point_values(z)[0]))
    return region(x, y)


def _admissible(scene, solver):
    """``z -> bool``: the rod inside the region where the scene's fitted field holds; None for a
    field that holds everywhere."""
    if getattr(scene.field, "region_problem", None) is None:
        return None

    def admissible(z):
        problem = _region_problem(scene, solver, z)
        if problem is not None:
            admissible.last = problem  # why the last state refused was
        return problem is None

    admissible.last = None
    return admissible


def _unknown_field_text(scene, solver, path, admissible):
    """(state, why) when the path from rest stopped where the field is not known to its accuracy —
    its last state there (the rod at rest, when it stopped at once), or the escape from it that
    could only go on outside the field's region — or None. (A path that reached the full load is
    judged by its end: at rest the field is off, and a rod at rest inside a fit's excluded sphere
    may well end outside it.)"""
    if path.reached:
        return None
    stopped = f"the loading path from rest stopped at {path.lam:.3g} of the load"
    where = _region_problem(scene, solver, path.z)
    if where is not None:
        return path.z, (f"at rest, {where}" if path.lam == 0.0 else f"{stopped}; there, {where}")
    if path.stop is not None and path.stop.status == "inadmissible":
        return path.z, (f"{stopped}, where the rod, leaving that state, is drawn to where the field's "
                        "representation does not hold (a rod pulled onto a magnet): its energy falls only by "
                        f"steps that leave the region, where {admissible.last}")
    return None


def _solve_from_start(scene, opts, solver):
    """From rest (``opts.start == "rest"``), compared with the straight-rod start; or straight."""
    if opts.start != "rest":
        return solve_on(scene, opts, None, solver, strict=True)
    t0 = time.perf_counter()
    params = solver.parameter_vector(scene)
    admissible = _admissible(scene, solver)
    path = path_from_rest(solver, params, follow_stable=opts.ensure_stable, admissible=admissible)
    path_time = time.perf_counter() - t0
    info = {"reached": path.reached, "steps": path.steps, "newton_solves": path.solves,
            "snaps_at": path.snaps, "branch_points_at": path.branch_points, "time_s": path_time,
            "load_fraction": path.lam}
    unknown = _unknown_field_text(scene, solver, path, admissible)
    if unknown is not None:  # the path's state is the answer's best picture (no solve from the
        # straight rod); it is no equilibrium of the full load: no energy, reactions or stability
        z_out, text = unknown
        raw = RawSolution(z_out, False, "outside_field_region", f"{text}: the field there is not known to "
                          "its stated accuracy (move the source, or turn the clamp)", path.solves, np.nan)
        nothing = StabilityVerdict(eigenvalues=np.full(1, np.nan), eigenvector=np.zeros(np.size(z_out)),
                                   morse_index=-1, stable=False, marginal=False)
        result = make_result(scene, opts, solver, params, raw, nothing, False, [], path_time)
        result.energy, result._balance = np.nan, nan_balance
        result.stats["from_rest"] = {**info, "solved_from": "path"}
        return result
    straight = solve_on(scene, opts, None, solver, strict=True)
    straight.stats["from_rest"] = {**info, "solved_from": "straight rod"}
    if not path.reached:
        straight.message += (f"; the loading path from rest stopped at {path.lam:.3g} of the load, "
                             "so this is the straight-rod start")
        if straight.success and not straight.stable:  # a state no loading history keeps
            straight.success, straight.status = False, "not_reached_from_rest"
            straight.message += "; the straight-rod start's state is not stable, so it is not the answer"
        return straight
    _, th1, x1, y1 = solver.summary(path.z, params)
    if straight.success and max(abs(straight.tip["x"] - x1), abs(straight.tip["y"] - y1),
                                abs(straight.tip["angle"] - th1)) <= DISTINCT:
        return straight  # the straight-rod start reaches the state reached from rest
    result = solve_on(scene, opts, path.z, solver, strict=True)
    result.stats["from_rest"] = {**info, "solved_from": "path"}
    if path.branch_points:  # the path stopped at a state turned unstable and left it along its mode
        result.escaped_saddle = True
        result.message += (f"; from rest the rod left an unstable equilibrium along its unstable mode at "
                           f"{', '.join(f'{v:.4g}' for v in path.branch_points)} of the load")
    if path.snaps:
        result.message += (f"; from rest the rod snaps at {', '.join(f'{v:.4g}' for v in path.snaps)} "
                           "of the load")
    if not result.success:
        return result
    if (straight.success and straight.stable and tip_difference(straight, result) > DISTINCT
            and residual_problem(straight) is None  # an unresolved mesh solution is no state
            and (opts.keep_self_intersecting or not straight.self_intersecting)):
        tip = straight.tip
        result.stats["other_stable_states"] = [{"start": "straight rod", "tip": dict(tip),
                                                "energy": float(straight.energy)}]
        result.message += (f"; another stable state exists at this scene (from the straight rod): tip "
                           f"({tip['x']:.6g}, {tip['y']:.6g}), energy {straight.energy:.6g} "
                           f"({'lower' if straight.energy < result.energy else 'higher'})")
    return result
