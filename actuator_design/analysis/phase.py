"""Phase portraits (θ, θ') of uniform-field scenes, with the equilibria's trajectories.

For a uniform field, constant bending stiffness b and constant fibre angle α, a dead tip force
(fx, fy) and no distributed load, the Euler–Lagrange equation of THEORY §5,

    b θ'' − h² sin(2(θ + α − φ)) + fy cos θ − fx sin θ = 0,

is autonomous, and

    H(θ, θ') = ½ b θ'² + h² cos²(θ + α − φ) + fy sin θ + fx cos θ

is constant along every solution (differentiate and use the equation). A hard-magnetic rod (THEORY
§9, constant magnetisation angle β) adds −h_r sin(θ + β − φ) to the equation and
h_r cos(θ + β − φ) to H. Its level lines are the
phase portrait; an equilibrium is the piece of a level line that starts on θ = θ0 (the clamp) and
ends on b θ' = m (the free end, m the tip moment; θ' = 0 without one), run for unit arc length
(paper §4, figures "phase diagram"). With p = fy, b = 1, α = 0 this is the brief's
H = ½θ'² + h² cos²(θ − φ) + p sin θ.

:func:`phase_portrait` returns the grid of H, contour levels, and one trajectory per equilibrium
(by default all equilibria of the scene from :func:`actuator_design.analysis.equilibria.find_equilibria`),
each with the spread of H along it (a conservation check of the solution). Drawing is in
:mod:`actuator_design.viz.phase`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.contact.guard import no_contact
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.model.scene import Scene
from actuator_design.physics.registry import describe_groups, present_parts, signed_end_moment

__all__ = ["first_integral", "check_autonomous", "PhaseTrajectory", "PhasePortrait", "phase_portrait"]

#: Points per trajectory.
TRAJECTORY_POINTS = 401


def _potentials(scene: Scene) -> List[Callable[[np.ndarray], np.ndarray]]:
    """Each present term's part V(θ) of the first integral (``EnergyTerm.phase_potential``), in
    registration order; ValueError naming the field that makes the equation depend on s, or
    ``phase:`` and the first term without a first integral."""
    return [part for _, part in present_parts(scene, "phase_potential", "phase")]


def check_autonomous(scene: Scene) -> None:
    """Raise ``ValueError`` naming the field when ``scene``'s Euler–Lagrange equation is not
    autonomous (then it has no phase portrait in (θ, θ'))."""
    _potentials(scene)


def first_integral(scene: Scene) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """H(θ, θ') of ``scene`` (see the module docstring), vectorised over arrays of equal shape: the
    kinetic part ½ b θ'² and every present term's part V(θ) (``EnergyTerm.phase_potential``).

    Parameters
    ----------
    scene : Scene
        Autonomous scene (:func:`check_autonomous`).

    Returns
    -------
    callable
        ``H(theta, dtheta)`` → ndarray of the broadcast shape (units of B0/ℓ per unit length).
    """
    parts = _potentials(scene)
    b = float(scene.stiffness.value)

    def H(theta, dtheta):
        theta, dtheta = np.asarray(theta, float), np.asarray(dtheta, float)
        return 0.5 * b * dtheta ** 2 + sum(part(theta) for part in parts)

    return H


@dataclass
class PhaseTrajectory:
    """The phase-plane curve s ↦ (θ(s), θ'(s)), s ∈ [0, 1], of one equilibrium.

    Attributes
    ----------
    theta, dtheta : ndarray, shape (TRAJECTORY_POINTS,)
        rad, rad per ℓ.
    level : float
        H along it (its mean).
    spread : float
        max H − min H along it: 0 up to the discretisation error for a true solution.
    stable : bool
    morse_index : int
    tip_angle, energy, gamma : float
        θ(1) (rad), Ê (B0/ℓ), θ'(0) (1/ℓ).
    crossings : int
        Interior sign changes of θ' (the paper's branch index m is crossings + 1 for the modes of
        the transverse scene: the number of times the curve meets the θ axis).
    self_intersecting : bool
    """

    theta: np.ndarray
    dtheta: np.ndarray
    level: float
    spread: float
    stable: bool
    morse_index: int
    tip_angle: float
    energy: float
    gamma: float
    crossings: int
    self_intersecting: bool

    def to_dict(self) -> dict:
        return {"theta": self.theta.tolist(), "dtheta": self.dtheta.tolist(), "level": self.level,
                "spread": self.spread, "stable": self.stable, "morse_index": self.morse_index,
                "tip_angle": self.tip_angle, "energy": self.energy, "gamma": self.gamma,
                "crossings": self.crossings, "self_intersecting": self.self_intersecting}


@dataclass
class PhasePortrait:
    """Level lines of H on a (θ, θ') grid and the equilibria's trajectories.

    Attributes
    ----------
    scene : Scene
    theta : ndarray, shape (n_theta,)
    dtheta : ndarray, shape (n_dtheta,)
    H : ndarray, shape (n_dtheta, n_theta)
        First integral on the grid (rows: θ', columns: θ).
    levels : ndarray, shape (n_levels,)
        Background contour levels (sorted).
    trajectories : list of PhaseTrajectory
    theta0 : float
        Start line θ = θ0 (rad).
    end_dtheta : float
        End line θ' = m/b.
    notes : list of str
    """

    scene: Scene
    theta: np.ndarray
    dtheta: np.ndarray
    H: np.ndarray
    levels: np.ndarray
    trajectories: List[PhaseTrajectory]
    theta0: float
    end_dtheta: float
    notes: List[str] = field(default_factory=list)
    #: the equilibria drawn are every equilibrium of the scene (certified by the search, or given)
    complete: bool = True

    def to_dict(self, grid: bool = False) -> dict:
        """Plain data; the H grid only with ``grid=True`` (it is large)."""
        out = {"groups": describe_groups(self.scene), "theta_range": [float(self.theta[0]), float(self.theta[-1])],
               "dtheta_range": [float(self.dtheta[0]), float(self.dtheta[-1])],
               "theta0": self.theta0, "end_dtheta": self.end_dtheta,
               "levels": self.levels.tolist(),
               "trajectories": [t.to_dict() for t in self.trajectories], "notes": list(self.notes),
               "complete": bool(self.complete),
               "units": {"theta": "rad", "dtheta": "rad per l", "H": "B0/l (per unit length)"}}
        if grid:
            out["theta"], out["dtheta"], out["H"] = self.theta.tolist(), self.dtheta.tolist(), self.H.tolist()
        return out


def trajectory(result: EquilibriumResult, H=None, n: int = TRAJECTORY_POINTS) -> PhaseTrajectory:
    """The phase-plane trajectory of one equilibrium (dense interpolant of the transcription)."""
    H = H or first_integral(result.scene)
    d = result.evaluate(np.linspace(0.0, 1.0, n))
    th, dth = np.asarray(d["theta"], float), np.asarray(d["dtheta"], float)
    vals = H(th, dth)
    sgn = np.sign(dth[1:-1])
    sgn = sgn[sgn != 0]
    return PhaseTrajectory(theta=th, dtheta=dth, level=float(np.mean(vals)),
                           spread=float(np.max(vals) - np.min(vals)), stable=bool(result.stable),
                           morse_index=int(result.morse_index), tip_angle=float(result.tip["angle"]),
                           energy=float(result.energy), gamma=float(dth[0]),
                           crossings=int(np.count_nonzero(np.diff(sgn))),
                           self_intersecting=bool(result.self_intersecting))


@no_contact("phase")
def phase_portrait(scene: Scene, equilibria: Optional[Sequence[EquilibriumResult]] = None,
                   options: Optional[SolverOptions] = None, *,
                   theta_range: Optional[Tuple[float, float]] = None,
                   dtheta_range: Optional[Tuple[float, float]] = None,
                   n_grid: int = 401, n_levels: int = 30) -> PhasePortrait:
    """The phase portrait of an autonomous uniform-field scene and its equilibria's trajectories.

    Parameters
    ----------
    scene : Scene
        Uniform field (or none), constant b and α, no distributed load (:func:`check_autonomous`).
    equilibria : sequence of EquilibriumResult, optional
        The equilibria to highlight; default: every equilibrium of the scene
        (:func:`~actuator_design.analysis.equilibria.find_equilibria`).
    options : SolverOptions, optional
        For the default equilibria search.
    theta_range, dtheta_range : (float, float), optional
        Plot window (rad, rad/ℓ); default: the trajectories with a margin and at least [−π, π] in θ
        around θ0.
    n_grid : int
        Grid points per axis (≥ 11).
    n_levels : int
        Background contour levels (≥ 2).

    Returns
    -------
    PhasePortrait
    """
    H = first_integral(scene)
    if int(n_grid) < 11:
        raise ValueError(f"n_grid: must be >= 11, got {n_grid}")
    if int(n_levels) < 2:
        raise ValueError(f"n_levels: must be >= 2, got {n_levels}")
    notes, complete = [], True
    if equilibria is None:
        found = find_equilibria(scene, options)
        equilibria = [e.result for e in found.equilibria]
        if not found.complete:
            complete = False
            notes.append("the equilibria search did not certify completeness"
                         + (f": {found.incomplete_reason}" if found.incomplete_reason else " (see its scan)"))
    trajs = [trajectory(r, H) for r in equilibria if r.success]
    if len(trajs) < len(equilibria):
        notes.append(f"{len(equilibria) - len(trajs)} non-converged equilibria were left out")
    th0 = float(scene.theta0)
    m = signed_end_moment(scene) / float(scene.stiffness.value)
    all_th = np.concatenate([[th0 - math.pi, th0 + math.pi]] + [t.theta for t in trajs])
    all_dth = np.concatenate([[1.0, -1.0, m]] + [t.dtheta for t in trajs])
    if theta_range is None:
        pad = 0.1 * np.ptp(all_th)
        theta_range = (float(np.min(all_th) - pad), float(np.max(all_th) + pad))
    if dtheta_range is None:
        big = 1.2 * float(np.max(np.abs(all_dth)))
        dtheta_range = (-big, big)
    for name, rng in (("theta_range", theta_range), ("dtheta_range", dtheta_range)):
        if not (len(rng) == 2 and all(math.isfinite(v) for v in rng) and rng[1] > rng[0]):
            raise ValueError(f"{name}: need two finite increasing values, got {rng!r}")
    th = np.linspace(theta_range[0], theta_range[1], int(n_grid))
    dth = np.linspace(dtheta_range[0], dtheta_range[1], int(n_grid))
    grid = H(th[None, :], dth[:, None])
    lo, hi = float(np.min(grid)), float(np.max(grid))
    # background levels spaced evenly in sign(H − H_min)·sqrt(H − H_min): even spacing in θ'
    u = np.linspace(0.0, math.sqrt(max(hi - lo, 1e-300)), int(n_levels) + 2)[1:-1]
    levels = np.unique(lo + u ** 2)
    return PhasePortrait(scene=scene, theta=th, dtheta=dth, H=grid, levels=levels, trajectories=trajs,
                         theta0=th0, end_dtheta=m, notes=notes, complete=complete)
