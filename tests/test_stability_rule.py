"""The stability rule has one home (issue 18 item 2): ``reduced.stability.classify_spectrum``, used by
``solver.stability``, the cheap path verdicts and the signed distance to a singularity. Checked against
numpy's full spectrum and against the closed form of the transverse-field pitchfork."""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.solver import get_solver
from actuator_design.model.scene import default_scene
from actuator_design.reduced.linalg import signed_distance_to_singularity
from actuator_design.reduced.stability import classify_spectrum, is_unstable, verdict_of


@pytest.mark.parametrize("lam,expected", [
    ([0.5, 1.0, 2.0], (0, True, False)),
    ([-0.5, 1.0, 2.0], (1, False, False)),
    ([-2.0, -0.1, 3.0], (2, False, False)),
    ([1e-12, 1.0, 2.0], (0, False, True)),      # |λ0| ≤ 1e-9: marginal, neither stable nor a descent
    ([-1e-12, 1.0, 2.0], (0, False, True)),
    ([-5e-10, 1.0, 2.0], (0, False, True)),
    ([-5e-9, 1.0, 2.0], (1, False, False)),
    ([-2e3, -1e-6, 2.0], (1, False, False)),  # the scale is relative: τ = 2e-6 here
    ([-2e3, 1.0, 2.0], (1, False, False)),
])
def test_the_rule(lam, expected):
    assert classify_spectrum(lam) == expected


def test_the_rule_agrees_with_the_full_spectrum_of_random_matrices():
    rng = np.random.default_rng(3)
    for _ in range(50):
        Q = rng.normal(size=(7, 7))
        A = (Q + Q.T) / 2 + rng.normal() * np.eye(7)
        mu = np.linalg.eigvalsh(A)
        morse, stable, _ = classify_spectrum(mu)
        assert morse == int(np.sum(mu < -1e-9 * max(1.0, abs(mu[0]))))
        assert stable == bool(mu[0] > 1e-9 * max(1.0, abs(mu[0])))
        assert signed_distance_to_singularity(A)[0] == morse


def test_every_verdict_site_agrees_across_the_pitchfork():
    """Transverse field (φ = 90°): the straight rod is stable below h_c = π/(2√2) and unstable above
    (THEORY §6); the solver, the cheap check and the verdict give the same answer on both sides."""
    h_c = math.pi / (2 * math.sqrt(2))
    opts = SolverOptions()
    for h, unstable in ((0.9 * h_c, False), (1.1 * h_c, True)):
        scene = default_scene(h=h, phi=math.pi / 2)
        sv = get_solver(scene, opts)
        P = sv.parameter_vector(scene)
        z = np.zeros(sv.transcription.nodes.size)
        v = sv.stability(z, P)
        assert (v.morse_index > 0) == unstable == is_unstable(sv, z, P)
        assert verdict_of(sv, z, P).morse_index == v.morse_index
        assert v.stable == (not unstable)
