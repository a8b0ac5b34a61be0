"""The engine's Secant algorithm on one-unknown paths with closed forms (folds, snaps, branch points).

The energies E(z; λ) are quartics whose equilibria, folds and pitchforks are known exactly, so the
run's stops, snaps and escapes are checked against numbers that owe nothing to the code.
"""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from actuator_design.continuation import (ContinuationSettings, Fold, Secant, Snap, StabilityLoss, StatePath,
                                          continuation)

MIN_STEP = 1e-7


def _newton(g, dg, z, lam):
    for _ in range(50):
        step = g(z, lam) / dg(z, lam)
        z = z - step
        if abs(step) < 1e-14:
            return SimpleNamespace(z=np.array([z]), converged=True)
    return SimpleNamespace(z=np.array([z]), converged=False)


class Quartic(StatePath):
    """E = z⁴/4 + a(λ) z²/2 − s(λ) z: g = z³ + a z − s, H = 3z² + a."""

    def __init__(self, a, s):
        self.a, self.s = a, s
        self.left_from, self.side = [], None

    def g(self, z, lam):
        return z ** 3 + self.a(lam) * z - self.s(lam)

    def dg(self, z, lam):
        return 3 * z ** 2 + self.a(lam)

    def at(self, lam):
        return lam

    def correct(self, guess, z, lam):
        raw = _newton(self.g, self.dg, float(guess[0]), lam)
        if raw.converged and self.dg(raw.z[0], lam) <= 0 and abs(raw.z[0] - z[0]) > 0.3:
            raw.converged = False  # a jump to the far branch: the step is too long
        return raw

    def stability(self, z, lam):
        return self.dg(z[0], lam) < 0, None

    def snap(self, z, lam):  # the energy's descent from z: the other well
        return _newton(self.g, self.dg, 2.5, lam)

    def continues(self, z_new, guess, z, secant):
        # past a pitchfork both bifurcated branches are stable: stay on the side taken
        return self.side is None or (z_new[0] - self.side) > 0

    def leave(self, z, lam):
        self.left_from.append(lam)
        self.side = float(z[0])
        return _newton(self.g, self.dg, float(z[0]) + 0.05, lam)


def _settings(**kw):
    return ContinuationSettings(**{"ds": 0.1, "ds_min": MIN_STEP, "ds_max": 0.25, "window": (0.0, 1.0),
                                   "max_du": 0.5, **kw})


def _fold_path():
    # z³ − 3z = 4λ − 1: the left well's branch z < −1 folds at z = −1, s = 2, λ = 3/4
    return Quartic(lambda lam: -3.0, lambda lam: 4 * lam - 1)


def _start(path):
    z0 = _newton(path.g, path.dg, -2.0, 0.0).z
    assert z0[0] < -1
    return z0


def test_a_fold_stops_the_run_within_the_smallest_step_of_the_closed_form():
    path = _fold_path()
    run = continuation(path, Secant(), _settings(), [Fold(stop=True)], x0=_start(path))
    assert not run.reached and run.reason == "no convergence"
    assert 0.75 - 2 * MIN_STEP <= run.lam <= 0.75
    # near a fold z + 1 ~ −sqrt((3/4 − λ) 4/3)
    assert abs(run.z[0] + 1) <= 2 * math.sqrt(4 / 3 * (0.75 - run.lam)) + 1e-9


def test_a_snap_releases_the_state_past_the_fold_into_the_other_well():
    path = _fold_path()
    run = continuation(path, Secant(growth=2.0), _settings(), [Snap(past=2.0)], x0=_start(path))
    assert run.reached and run.lam == 1.0 and len(run.snaps) == 1
    assert 0.75 < run.snaps[0] <= 0.75 + 3 * MIN_STEP
    right = max(r.real for r in np.roots([1, 0, -3, -3]) if abs(r.imag) < 1e-12)  # z³ − 3z = 3
    assert run.z[0] == pytest.approx(right, abs=1e-12)


def _pitchfork():
    # z³ + (1 − 2λ) z = ε: the near-straight branch loses stability near λ = 1/2 (ε → 0)
    return Quartic(lambda lam: 1 - 2 * lam, lambda lam: 0.0)


def test_a_refused_stability_loss_stops_at_the_pitchfork():
    path = _pitchfork()
    run = continuation(path, Secant(), _settings(), [Fold(stop=True), StabilityLoss()], x0=np.array([0.0]))
    assert not run.reached and run.reason == "fold or stability loss"
    assert 0.5 - 2 * MIN_STEP <= run.lam <= 0.5 and run.z[0] == 0.0


def test_a_left_stability_loss_follows_the_bifurcated_branch_to_its_closed_form():
    path = _pitchfork()
    loss = StabilityLoss(leave=True, locate=0.02)
    run = continuation(path, Secant(growth=2.0), _settings(), [Snap(), loss], x0=np.array([0.0]))
    assert run.reached and len(run.branch_points) == 1
    lam_b = run.branch_points[0]
    assert 0.5 < lam_b <= 0.5 / (1 - loss.locate) and path.left_from == [lam_b]
    assert run.z[0] == pytest.approx(1.0, abs=1e-12)  # z² = 2λ − 1 at λ = 1


def test_the_work_bound_is_the_number_of_solves():
    path = _fold_path()
    run = continuation(path, Secant(), _settings(max_steps=3, ds=0.01, ds_max=0.01), [Fold(stop=True)],
                       x0=_start(path))
    assert not run.reached and run.reason == "work bound reached" and run.solves == 3
    assert run.lam == pytest.approx(0.03, abs=1e-15)


def test_events_that_do_not_fit_the_algorithm_are_refused():
    path = _fold_path()
    with pytest.raises(ValueError, match="Fold\\(stop=True\\) or Snap"):
        continuation(path, Secant(), _settings(), [StabilityLoss()], x0=_start(path))
    with pytest.raises(ValueError, match="Snap and StabilityLoss events are for the Secant"):
        continuation(SimpleNamespace(), events=[Snap()])
    with pytest.raises(ValueError, match="window"):
        continuation(path, Secant(), _settings(window=(0.0, 2.0)), [Fold(stop=True)], x0=_start(path))


@pytest.mark.parametrize("kw, match", [({"growth": 1.0}, "growth"), ({"min_step_relative": -1e-3}, "min_step_relative")])
def test_secant_settings_validate_themselves(kw, match):
    with pytest.raises(ValueError, match=match):
        Secant(**kw)


def test_a_target_at_the_start_and_the_end_reached_on_the_last_allowed_solve():
    path = _fold_path()
    path.targets = (0.0, 0.05, 0.1)  # a station at the start (no solve given for it) is passed over
    run = continuation(path, Secant(), _settings(ds=0.05, ds_max=0.05, max_steps=2, window=(0.0, 0.1)), [Fold(stop=True)],
                       x0=_start(path))
    assert run.reached and run.solves == 2 and run.lam == 0.1 and run.reason == ""
    right = min(r.real for r in np.roots([1, 0, -3, -(4 * 0.1 - 1)]) if abs(r.imag) < 1e-12)  # z³ − 3z = 4λ − 1
    assert run.z[0] == pytest.approx(right, abs=1e-12)
