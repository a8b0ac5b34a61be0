"""What a branch is followed on and what it promises: the mesh of a branch through a parameter
window, and the accuracy check of its most demanding states (THEORY §5's clamp layers, whose width
~1/k changes along the branch).

A branch is followed on one mesh (:mod:`actuator_design.continuation.follow`): it must resolve the
layers at the window's most demanding end, and its states are held to the Euler–Lagrange residual
check of a solve (:mod:`actuator_design.equilibrium.acceptance`).
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from actuator_design.continuation.branch import Branch
from actuator_design.equilibrium.acceptance import graded_for_scenes, residual_problem
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.single import make_result
from actuator_design.model.scene import Scene
from actuator_design.physics.parameters import set_value
from actuator_design.reduced.newton import RawSolution

__all__ = ["branch_options", "branch_accuracy"]


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
