"""Multiplicity maps (analysis.multiplicity) against the critical curves and the NLP.

The counts come from the vectorised shooting scan; the critical (fold) curves p_crit^(k)(h²) come
from continuing the Moore–Spence system of the collocation NLP, an independent computation. Away
from the curves, the number of equilibria must be 1 + 2·(number of fold curves below p) — it
changes exactly across the fold curves — and 1 below p_crit^(1). The stable counts (Sturm's index
of the Jacobi field) are compared with the reduced-Hessian verdicts of the NLP equilibria.
"""
import numpy as np
import pytest

from actuator_design.continuation.critical import critical_curves
from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.analysis.multiplicity import count_row, multiplicity_map
from actuator_design.model.scene import default_scene


@pytest.fixture(scope="module")
def curves():
    return critical_curves(default_scene(h=0.0, p=0.0), "p", "h2", (0.0, 60.0), (0.0, 20.0), n_starts=1)


def test_counts_change_exactly_across_the_fold_curves(curves):
    assert len(curves) == 2
    xs, ys = np.linspace(0, 20, 6), np.linspace(0.5, 59.5, 12)
    m = multiplicity_map(default_scene(h=0.0, p=0.0), "h2", xs, "p", ys, workers=2, progress=False)
    checked = 0
    for j, x in enumerate(xs):
        crit = [float(np.interp(x, c.mu, c.lam)) for c in curves]
        for i, y in enumerate(ys):
            if min(abs(y - c) for c in crit) < 1.0:
                continue  # within the resolution of the scan near a fold
            assert m.counts[i, j] == 1 + 2 * sum(c < y for c in crit), (x, y)
            if y < crit[0]:
                assert m.counts[i, j] == 1 and m.stable[i, j] == 1
            checked += 1
    assert checked > 50


def test_stable_counts_match_the_reduced_hessian():
    scenes = [default_scene(h=h, p=p) for h, p in ((0.0, 5.0), (2.0, 30.0), (4.0, 55.0), (1.0, 58.0))]
    counts, stable = count_row(scenes)
    for sc, c, s in zip(scenes, counts, stable):
        r = find_equilibria(sc)
        assert (c, s) == (r.count, r.stable_count)


def test_bad_parameters_are_rejected():
    with pytest.raises(ValueError, match="unknown map parameter"):
        multiplicity_map(default_scene(), "bogus", [0, 1], "p", [0, 1])
    with pytest.raises(ValueError, match="h2"):
        multiplicity_map(default_scene(), "h2", [-1, 1], "p", [0, 1], workers=1)


def _full_scan(scenes, n_gamma=161, rad_per_step=0.3):
    """The brute-force count: sign changes of r on every fine γ sample (no coarse grid, no bisection),
    Morse index from the bracket end with the smaller |r| (THEORY §7)."""
    from actuator_design.analysis.shooting_scan import (ShootingProblem, gamma_bound, min_gamma_points,
                                                        steps_for)
    W = np.array([gamma_bound(sc)["window"] for sc in scenes])
    N = max(steps_for(sc, w, min_steps=16, rad_per_step=rad_per_step) for sc, w in zip(scenes, W))
    G = max(n_gamma, max(min_gamma_points(sc, w) for sc, w in zip(scenes, W))) | 1
    r, Z, eta1 = ShootingProblem(scenes, N).residual(W[:, None] * np.linspace(-1, 1, G), jacobi=True)
    sign_change = r[:, :-1] * r[:, 1:] < 0
    left = np.abs(r[:, :-1]) <= np.abs(r[:, 1:])
    Zb, eb = np.where(left, Z[:, :-1], Z[:, 1:]), np.where(left, eta1[:, :-1], eta1[:, 1:])
    stable = sign_change & (Zb == 0) & (eb * (r[:, 1:] - r[:, :-1]) > 0)
    return sign_change.sum(1) + (r == 0).sum(1), stable.sum(1)


def test_coarse_to_fine_counts_equal_the_full_scan_near_the_folds(curves):
    """Every fine sample scanned (a second method) against the coarse scan with bisection, on rows
    of 40 points (one resolution per row, as the map) straddling both fold curves closely."""
    xs = np.linspace(0.0, 20.0, 40)
    for c in curves:
        for dp in (-0.3, -0.05, 0.0, 0.05, 0.3):
            scenes = [default_scene(h=float(np.sqrt(x)), p=float(np.interp(x, c.mu, c.lam)) + dp) for x in xs]
            counts, stable = count_row(scenes)
            ref_counts, ref_stable = _full_scan(scenes)
            assert np.array_equal(counts, ref_counts) and np.array_equal(stable, ref_stable), dp


def test_counts_equal_an_independent_shooting_reference(curves):
    """Sign changes of the reference solver's residual (DOP853, rtol 1e-12, nothing shared with the
    map) on a γ grid over the first-integral window |γ| ≤ √(2p) (THEORY §5 scene, φ = 0), each root
    refined by brentq and its stability by the Jacobi conjugate-point test, at points ≥ 2 away in p
    from the fold curves (1, 3 and 5 equilibria)."""
    from actuator_design.reference.jacobi import jacobi_morse_index
    from actuator_design.reference.shooting import ShootingParams, shoot, solve_shooting
    points = [(0.0, 5.0), (0.0, 30.0), (15.0, 40.0), (2.0, 58.0)]
    m = multiplicity_map(default_scene(h=0.0, p=0.0), "h2", [p[0] for p in points], "p",
                         [p[1] for p in points], workers=1, progress=False)
    seen = set()
    for j, (h2, p) in enumerate(points):
        assert min(abs(p - float(np.interp(h2, c.mu, c.lam))) for c in curves) > 2.0
        params = ShootingParams(h=float(np.sqrt(h2)), fy=p)
        g = np.linspace(-1.0, 1.0, 121) * 1.01 * np.sqrt(2 * p)
        r = np.array([shoot(x, params).residual for x in g])
        roots = [solve_shooting(params, bracket=(g[i], g[i + 1])) for i in np.flatnonzero(r[:-1] * r[1:] < 0)]
        assert all(s.converged for s in roots)
        stable = sum(jacobi_morse_index(s).index == 0 for s in roots)
        assert (m.counts[j, j], m.stable[j, j]) == (len(roots), stable), (h2, p)
        seen.add((len(roots), stable))
    assert {c for c, _ in seen} == {1, 3, 5} and any(s >= 2 for _, s in seen)


def test_on_the_axial_field_without_load_the_straight_rod_is_the_only_equilibrium():
    """p = 0, φ = 0: the first integral ½θ'² + ½h² cos 2θ = const with θ(0) = 0 = θ'(1) forces
    ½γ² = ½h²(cos 2θ(1) − 1) ≤ 0, so γ = 0: one equilibrium (the straight rod, stable) for every h."""
    m = multiplicity_map(default_scene(h=0.0, p=0.0), "h2", np.linspace(0, 60, 25), "p", [0.0, 1e-9],
                         workers=1, progress=False)
    assert np.all(m.counts == 1) and np.all(m.stable == 1)


@pytest.mark.parametrize("phi, p, hs", [(np.pi / 2, 0.9310344827586206, np.linspace(0, 9, 60)[20:]),
                                        (np.pi / 4, -1.206896551724138, np.linspace(0, 11, 60)[:40])])
def test_coarse_to_fine_counts_equal_the_full_scan_where_the_ivp_amplifies(phi, p, hs):
    """Transverse and oblique fields up to h ≈ 9: shots near the aligned state make r(γ) jump within
    a fine step (close root pairs); the coarse scan must still find every root the full scan finds
    (these rows once lost a pair to a test that looked only at the tangent pointing to zero)."""
    scenes = [default_scene(h=float(h), p=p, phi=phi) for h in hs]
    counts, stable = count_row(scenes)
    ref_counts, ref_stable = _full_scan(scenes)
    assert np.array_equal(counts, ref_counts) and np.array_equal(stable, ref_stable)
    assert ref_counts.max() >= 7
