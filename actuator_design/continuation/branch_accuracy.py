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
from actuator_design.equilibrium.single import solve_on
from actuator_design.model.scene import Scene
from actuator_design.physics.parameters import set_value

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
    Each is re-solved by Newton from its node values on the branch's mesh; it must meet the
    Euler–Lagrange residual check (:func:`~actuator_design.equilibrium.acceptance.residual_problem`)
    and stay within 1e-6 rad of the branch's node values (the corrector converged)."""
    for br in branches:
        if len(br) == 0:
            continue
        picks = {int(np.argmin(br.lam)), int(np.argmax(br.lam))}
        if br.gamma is not None and len(br.gamma) == len(br) and np.all(np.isfinite(br.gamma)):
            picks.add(int(np.argmax(np.abs(br.gamma))))
        for k in sorted(picks):
            lam = float(br.lam[k])
            state = solve_on(cont.scene_at(lam), cont.options, br.z[k], cont.solver)
            if not state.success:
                why = f"its state does not converge ({state.message})"
            else:
                moved = float(np.max(np.abs(np.asarray(state.z) - br.z[k])))
                why = residual_problem(state) or (
                    f"the branch's state is {moved:.2g} rad from the equilibrium there" if moved > 1e-6 else None)
            if why is not None:
                return (f"at {cont.name} = {lam:.6g}: {why}; refine the mesh (solver.elements in the config, "
                        "SolverOptions(elements=..., clamp_levels=...)) or narrow the window")
    return None
