"""Where exactly a design's branch snaps along one tolerance axis (the fold distance of
:mod:`actuator_design.robust.robustness`), to a stated accuracy.

Branch following (:func:`actuator_design.robust.robustness.follow_segment`) stops where warm-started Newton no longer
converges or the state turns unstable; near a quadratic fold Newton's basin shrinks like the
square root of the distance, so that last stable point can lie short of the fold. And the fold of
the design mesh is not the fold of the rod: at the strong fields where designs live, the default
mesh's fold can be off by half a per cent of field (measured: 69.25 % against 69.72 % on a
(0.5, 0.5) design). So the snap is located in two steps:

1. on the design mesh, by Newton on the Moore–Spence system (:func:`actuator_design.reduced.locate_fold`:
   an equilibrium whose reduced Hessian has a zero eigenvalue) from the last stable point;
2. on meshes with 2× and 4× the elements, by the same Newton from the located fold interpolated
   onto them; the 4× value is reported and |2× − 4×| is its error estimate (the spectral elements
   converge much faster than that difference shrinks).

Where the Moore–Spence Newton does not converge (a branch point, where the system is singular, or
a stop that was no fold) the last stable point of the branch following is kept and the result says
it was not refined.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from typing import Callable, List, Optional, Sequence

import numpy as np

from actuator_design.physics import parameters as lens
from actuator_design.continuation.segment import LensSegment, followers
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reduced import locate_fold, reduced_system
from actuator_design.model.scene import Scene
from actuator_design.equilibrium.solver import get_solver
from actuator_design.robust.tolerances import apply_deltas

__all__ = ["SnapPoint", "locate_snap", "snap_builds"]

#: Largest change of θ (rad, any node) between the last stable state and the located fold, and
#: between a mesh's fold and the coarser mesh's fold interpolated: beyond it, another fold.
MAX_FOLD_JUMP = 0.5


@dataclass
class SnapPoint:
    """A snap along one axis, in the fraction t ∈ (0, 1] of the searched segment.

    t : the fold (refined) or the last stable point (not refined).
    error : estimated discretisation error of ``t`` (None when not refined).
    refined : located as a fold and refined on finer meshes.
    t_design_mesh : the fold on the design mesh (the last stable point when not refined).
    """

    t: float
    error: Optional[float]
    refined: bool
    t_design_mesh: float


def _segment(scene: Scene, attr: str, sign: float, rng: float) -> LensSegment:
    """The lens segment from the scene to ``apply_deltas(scene, {attr: sign·rng})``."""
    name = "h" if attr == "field_rel" else "phi"
    par = lens.parameter(name)
    va = np.array([par.get(scene)])
    vb = np.array([par.get(apply_deltas(scene, {attr: sign * rng}))])
    return LensSegment(scene, [name], va, vb, followers(scene, [name], np.array([va, vb])))


#: Stationarity tolerance of a located fold (max |g_i| / m_i): on 4× the design mesh the rounding
#: floor of g / m reaches ~5e-10 (the lumped masses shrink with the element size), above the
#: equilibrium solver's 1e-10; the fold value moves by ~1e-14 between such iterates.
FOLD_TOL = 1e-8


def _fold_on(solver, seg: LensSegment, P: np.ndarray, u: np.ndarray, t: float, v=None):
    system = reduced_system(solver, list(seg.system_names))
    fp = locate_fold(system, P, u, t, v, path=seg.point, tol=FOLD_TOL)
    ok = fp.converged and 0.0 < fp.lam <= 1.0 and np.all(np.isfinite(fp.u))
    return fp if ok else None


def _onto(solver, fine, u: np.ndarray) -> np.ndarray:
    """Free unknowns (or a null vector) of ``solver``'s mesh interpolated onto ``fine``'s."""
    z = np.concatenate(([0.0], u))
    return solver.transcription.theta_dense(z, fine.transcription.nodes)[0][1:]


def locate_snap(scene: Scene, options: SolverOptions, z_end: np.ndarray, t_end: float, attr: str,
                sign: float, rng: float) -> SnapPoint:
    """Locate the snap beyond the last stable point of a fold search.

    Parameters
    ----------
    scene : Scene
        The design scene (t = 0 of the segment).
    options : SolverOptions
        The design mesh (the one ``z_end`` lives on).
    z_end : ndarray, shape (n_nodes,)
        θ at the nodes at ``t_end`` (rad).
    t_end : float
        Last stable point of the branch following, fraction of the segment.
    attr, sign, rng : str, float, float
        The axis: ``apply_deltas(scene, {attr: sign * t * rng})`` is the scene at t.

    Returns
    -------
    SnapPoint
    """
    solver = get_solver(scene, options)
    seg = _segment(scene, attr, sign, rng)
    P = solver.parameter_vector(scene)
    z_end = np.asarray(z_end, float)
    fp = _fold_on(solver, seg, P, z_end[1:], t_end)
    if fp is None or fp.lam < t_end - 1e-9 or np.max(np.abs(fp.u - z_end[1:])) > MAX_FOLD_JUMP:
        return SnapPoint(t_end, None, False, t_end)
    folds, coarse, last = [], solver, fp
    for factor in (2, 4):
        try:
            fine = get_solver(scene, replace(options, elements=factor * options.elements, accuracy=None))
        except ValueError:  # beyond the mesh cap (SolverOptions): keep the design mesh's fold
            return SnapPoint(fp.lam, None, False, fp.lam)
        u0 = _onto(coarse, fine, last.u)
        got = _fold_on(fine, seg, fine.parameter_vector(scene), u0, last.lam, _onto(coarse, fine, last.v))
        if got is None or np.max(np.abs(got.u - u0)) > MAX_FOLD_JUMP:
            return SnapPoint(fp.lam, None, False, fp.lam)
        folds.append(got.lam)
        coarse, last = fine, got
    return SnapPoint(folds[-1], abs(folds[-1] - folds[-2]), True, fp.lam)


def snap_unit(attr: str) -> float:
    """Factor from the axis' own unit to the reported one (fraction of field, or degrees)."""
    return 1.0 if attr == "field_rel" else math.degrees(1.0)


#: Steps of :func:`snap_builds` are offered on meshes of at most this many nodes: a step takes
#: ≤ 0.15 s there (the default 4 × 10 mesh refined 4×), but 0.35 s at 320 nodes and 5 s at 1600
#: (the Moore–Spence Jacobian is dense), and a wait may overrun by one step.
AHEAD_MAX_NODES = 160


def snap_builds(scene: Scene, options: SolverOptions, attrs: Sequence[str]) -> List[Callable[[], None]]:
    """What :func:`locate_snap` builds along each axis ``attrs`` ("field_rel", "angle"), as steps
    to run ahead of need (e.g. while a forked task computes, :mod:`actuator_design.forked`): the reduced system
    and its Moore–Spence function on the design mesh and on 2× and 4× finer ones, those of at most
    :data:`AHEAD_MAX_NODES` nodes. They only fill the caches of
    :func:`~actuator_design.equilibrium.solver.get_solver` and :func:`~actuator_design.reduced.reduced_system`:
    no result depends on whether they ran."""
    return [partial(_build_fold_system, scene, options, attr, factor) for attr in attrs for factor in (1, 2, 4)
            if factor * options.elements * options.degree <= AHEAD_MAX_NODES]


def _build_fold_system(scene: Scene, options: SolverOptions, attr: str, factor: int) -> None:
    opts = options if factor == 1 else replace(options, elements=factor * options.elements, accuracy=None)
    seg = _segment(scene, attr, 1.0, 0.5)
    reduced_system(get_solver(scene, opts), list(seg.system_names)).f_fold  # noqa: B018 - built on access
