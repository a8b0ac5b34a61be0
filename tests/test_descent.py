"""The trust-region descent of the loading path's escapes (:mod:`actuator_design.reduced.descent`), on
hand-built states of a rod across a uniform field past its pitchfork (h = 5, φ = 90°): the straight
rod is an unstable equilibrium, the buckled rods to either side stable ones. Checked against
shooting (a second method), the scene's mirror symmetry, and the energy."""
import math
import re

import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import get_solver
from actuator_design.model.scene import Scene, UniformField
from actuator_design.reduced.descent import _boundary_step, trust_region_descent
from actuator_design.reference.shooting import ShootingParams, solve_shooting

H = 5.0


@pytest.fixture(scope="module")
def rod():
    scene = Scene(h=H, field=UniformField(phi=0.5 * math.pi))
    solver = get_solver(scene, SolverOptions())
    params = solver.parameter_vector(scene)
    straight = solver.initial_guess(params)
    mode = solver.stability(straight, params).eigenvector
    return solver, params, straight, mode * (1.0 if mode[-1] >= 0 else -1.0)


def _descend(rod, z0, **kwargs):
    solver, params, _, _ = rod
    solver.kernel.set_params(params)
    tol = solver.options.tol
    scale = solver.residual_scale(params)
    return trust_region_descent(solver.kernel, lambda z: solver.summary(z, params)[0], z0, 0.0,
                                tol * scale, 10.0 * tol, **kwargs)


def _tip_angle(rod, z):
    solver, params, _, _ = rod
    return solver.summary(z, params)[1]


def test_from_a_kick_the_descent_reaches_the_buckled_rod_that_shooting_finds(rod):
    solver, params, straight, mode = rod
    assert solver.stability(straight, params).morse_index >= 1  # past the pitchfork
    out = _descend(rod, straight + 0.05 * mode)
    assert out.converged, out.message
    verdict = solver.stability(out.z, params)
    assert verdict.stable
    assert solver.summary(out.z, params)[0] < solver.summary(straight, params)[0]
    _, angle, x, y = solver.summary(out.z, params)
    assert angle > 0.3  # the kick's side
    gamma = float(np.dot(np.array([1.0, -1.0]), out.z[1::-1]) / solver.transcription.nodes[1])
    shot = solve_shooting(ShootingParams(h=H, phi=0.5 * math.pi), gamma_guess=gamma)
    assert shot.converged
    assert max(abs(shot.tip[0] - x), abs(shot.tip[1] - y), abs(shot.tip[2] - angle)) <= 1e-6


def test_the_mirror_kick_reaches_the_mirror_rod(rod):
    """(From the saddle itself the side is round-off's: the path always kicks first.)"""
    _, _, straight, mode = rod
    up = _descend(rod, straight + 0.05 * mode)
    down = _descend(rod, straight - 0.05 * mode)
    assert down.converged and np.max(np.abs(down.z + up.z)) <= 1e-9  # the scene is symmetric


@pytest.mark.parametrize("lam0, g0", [(-1e7, 1e-10), (-1e5, 2e-12), (-3.0, 0.0), (-3.0, 1e-3), (2.0, 1.0)])
def test_the_trust_region_step_minimises_the_model_on_the_sphere(lam0, g0):
    """Against the model's minimum on the sphere |s| = r by brute force over a dense sample of it
    (n = 3: the sphere parametrised by two angles), nearly-hard and hard cases included."""
    lam = np.array([lam0, 1.0, 4.0])
    g = np.array([g0, 0.6, -0.8])
    r = 0.5
    sq, hard = _boundary_step(lam, g, r)
    if hard:
        sq[0] = np.sqrt(max(r ** 2 - float(np.dot(sq, sq)), 0.0))
    model = lambda s: float(np.dot(g, s) + 0.5 * np.dot(lam * s, s))
    a, b = np.meshgrid(np.linspace(0, np.pi, 721), np.linspace(-np.pi, np.pi, 1441))
    sphere = r * np.stack([np.cos(a), np.sin(a) * np.cos(b), np.sin(a) * np.sin(b)], axis=-1)
    best = float(np.min(sphere @ g + 0.5 * np.einsum("...i,i,...i->...", sphere, lam, sphere)))
    assert abs(np.linalg.norm(sq) - r) <= 1e-9 * r
    assert model(sq) <= best + 1e-6 * max(1.0, abs(best))


def test_the_iteration_cap_decides_only_whether_the_descent_finished(rod):
    _, _, straight, mode = rod
    z0 = straight + 0.05 * mode
    full = _descend(rod, z0)
    steps = int(re.search(r"\((\d+) steps\)", full.message).group(1))
    assert steps >= 2
    short = _descend(rod, z0, max_iter=steps - 1)
    assert not short.converged and short.status == "max_iter"
    longer = _descend(rod, z0, max_iter=10 * steps)
    assert np.array_equal(longer.z, full.z)


def test_an_energy_that_is_not_finite_or_states_not_admissible_end_the_descent_without_an_answer(rod):
    solver, params, straight, mode = rod
    out = trust_region_descent(solver.kernel, lambda z: math.nan, straight + 0.05 * mode, 0.0, 1e-9, 1e-9)
    assert not out.converged and out.status == "not_finite"
    # states only within 0.01 rad of the start: the descent cannot reach the buckled rod
    z0 = straight + 0.05 * mode
    out = _descend(rod, z0, admissible=lambda z: np.max(np.abs(z - z0)) <= 0.01)
    assert not out.converged and out.status == "inadmissible", out.message
