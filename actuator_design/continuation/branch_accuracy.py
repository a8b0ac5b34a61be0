"""What a branch is followed on and what it promises: the mesh of a branch through a parameter
window, the accuracy check of its most demanding states (THEORY §5's clamp layers, whose width
~1/k changes along the branch), and the estimated discretisation error of its critical values.

A branch is followed on one mesh (:mod:`actuator_design.continuation.follow`): it must resolve the
layers at the window's most demanding end, its states are held to the Euler–Lagrange residual
check of a solve (:mod:`actuator_design.equilibrium.acceptance`), and each located fold and branch
point is relocated on a finer mesh (a bifurcating mode of many half-waves is not resolved by a mesh
that resolves the states: the 18th pitchfork of a transverse field on the default mesh).
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

from actuator_design.continuation.branch import Branch
from actuator_design.equilibrium.acceptance import graded_for_scenes, residual_problem
from actuator_design.equilibrium.accuracy import finer_options
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.single import make_result
from actuator_design.model.scene import Scene
from actuator_design.physics.parameters import set_value
from actuator_design.reduced.fold import locate_fold
from actuator_design.reduced.linalg import null_vector
from actuator_design.reduced.newton import RawSolution

__all__ = ["branch_options", "branch_accuracy", "critical_value_error", "critical_accuracy", "unlocated_note",
           "CRITICAL_RTOL"]

#: relative accuracy a critical value (a buckling field, a snap load) is held to: its estimated
#: discretisation error (:func:`critical_value_error`) ≤ CRITICAL_RTOL × max(1, |λ*|)
CRITICAL_RTOL = 1e-6


def branch_options(scene: Scene, param: str, values: Sequence[float],
                   options: Optional[SolverOptions] = None) -> SolverOptions:
    """The options of a branch through ``param`` = each of ``values``: ``options`` (default
    ``SolverOptions()``) with the mesh graded for the most demanding of those scenes
    (:func:`~actuator_design.equilibrium.acceptance.graded_for_scenes`; values outside the parameter's
    range, e.g. an infinite window's end, are left out)."""
    scenes = []
    for v in values:
        try:
            scenes.append(set_value(scene, param, float(v)))
        except ValueError:  # outside the parameter's range: not a scene of the branch
            continue
    return graded_for_scenes(scenes, options or SolverOptions())


def branch_accuracy(cont, branches: Sequence[Branch]) -> Optional[str]:
    """Why a branch's most demanding states miss the accuracy promise of ``solve``, or None
    (``cont``: the :class:`~actuator_design.continuation.follow.Continuation` that followed them).

    Checked on each branch: the states at its least and greatest parameter value (a layer is
    narrowest at one end of a field's or a load's range) and the one with the largest clamp
    curvature |θ'(0)| (the sharpest clamp layer, also inside the range: a field angle, a fold).
    Each state, as the corrector converged it (a fold included, where no solve could confirm it
    by a Newton step), must meet the Euler–Lagrange residual check
    (:func:`~actuator_design.equilibrium.acceptance.residual_problem`)."""
    solver = cont.solver
    for br in branches:
        if len(br) == 0:
            continue
        picks = {int(np.argmin(br.lam)), int(np.argmax(br.lam))}
        if br.gamma is not None and len(br.gamma) == len(br) and np.all(np.isfinite(br.gamma)):
            picks.add(int(np.argmax(np.abs(br.gamma))))
        for k in sorted(picks):
            lam, z = float(br.lam[k]), np.asarray(br.z[k], float)
            scene = cont.scene_at(lam)
            params = solver.parameter_vector(scene)
            raw = RawSolution(z, True, "converged", "a state of the branch", 0, solver.stationarity(z, params))
            why = residual_problem(make_result(scene, cont.options, solver, params, raw, None, False, [], 0.0))
            if why is not None:
                return (f"at {cont.name} = {lam:.6g}: {why}; refine the mesh (solver.elements in the config, "
                        "SolverOptions(elements=..., clamp_levels=...)) or narrow the window")
    return None


def critical_value_error(cont, cp) -> float:
    """An estimate of the discretisation error of the critical value of ``cp`` (a fold or a branch
    point of ``cont``'s parameter, units of the parameter): the same critical point on the mesh of
    degree + 4 (:func:`~actuator_design.equilibrium.accuracy.finer_options`), from ``cp``'s state
    interpolated onto it. A fold is located there by Moore–Spence; a branch point's value moves by
    −μ/(dμ/dλ), μ the eigenvalue of the finer Hessian nearest zero at λ* (a bifurcating mode the
    mesh does not resolve, e.g. the 18th pitchfork of a transverse field on 4 elements of degree
    10, is 4e-3 off). inf when the finer mesh finds no such point nearby."""
    lam = float(cp.value)
    fine = type(cont)(cont.scene_at(lam), cont.name, finer_options(cont.options))  # (a Continuation)
    z = cont.solver.transcription.theta_dense(np.asarray(cp.z, float), fine.solver.transcription.nodes)[0]
    if cp.kind == "fold" or cp.morse_before == cp.morse_after:  # (a fold the engine saw as a branch point)
        fp = locate_fold(fine.system, fine.P, z[1:], lam, tol=max(fine.tol, 1e-11))
        return abs(fp.lam - lam) if fp.converged else math.inf
    u, ok, _ = fine.correct_fixed(z[1:], lam, max_iter=30)
    if not ok:
        return math.inf
    v = null_vector(np.array(fine.ev(u, lam)[1]), fine.mass)
    for step in (1e-6 * max(1.0, abs(lam)), -1e-6 * max(1.0, abs(lam))):  # (the branch may end on one side)
        u2, ok2, _ = fine.correct_fixed(u, lam + step, max_iter=30)
        if ok2:
            mu, mu2 = (float(v @ np.asarray(fine.ev(w, l)[1]) @ v) for w, l in ((u, lam), (u2, lam + step)))
            rate = (mu2 - mu) / step
            return abs(mu / rate) if rate != 0.0 else math.inf
    return math.inf


def critical_accuracy(cont, points: Sequence, rtol: float = CRITICAL_RTOL) -> Optional[str]:
    """Why the critical values of ``points`` miss ``rtol`` × max(1, |λ*|) by
    :func:`critical_value_error`, or None; each located point gets ``value_error`` (a point only
    bracketed by the engine, not located, is not a question of the mesh: :func:`unlocated_note`)."""
    worst = None
    for cp in points:
        if not cp.located:
            continue
        cp.value_error = critical_value_error(cont, cp)
        limit = rtol * max(1.0, abs(cp.value))
        if not cp.value_error <= limit and (worst is None or cp.value_error > worst[0]):
            worst = (cp.value_error, cp, limit)
    if worst is None:
        return None
    err, cp, limit = worst
    what = "a fold" if cp.kind == "fold" else "a branch point"
    moved = f"moves by {err:.2g} (> {limit:.2g})" if math.isfinite(err) else "is not found"
    return (f"{what} at {cont.name} = {cp.value:.10g} {moved} on a finer mesh (degree + 4): its mode is not "
            "resolved; refine the mesh (solver.elements, solver.degree)")


def unlocated_note(name: str, points: Sequence) -> Optional[str]:
    """A line on the critical points of ``points`` the engine only bracketed (``located`` False: the
    value is interpolated on its step, e.g. where a step jumped between the branches of an imperfect
    pitchfork), or None."""
    loose = [cp for cp in points if not cp.located]
    if not loose:
        return None
    where = ", ".join(f"{cp.kind.replace('_', ' ')} near {name} = {cp.value:.6g}"
                      + (f" (in [{cp.interval[0]:.6g}, {cp.interval[1]:.6g}])" if cp.interval else "")
                      for cp in loose)
    return (f"not located, only bracketed on a step: {where}; a smaller largest step (ds_max) may locate it, "
            "or show it is none")
