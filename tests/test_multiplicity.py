"""Multiplicity maps (analysis.multiplicity) against the critical curves and the NLP.

The counts come from the vectorised shooting scan; the critical (fold) curves p_crit^(k)(h²) come
from continuing the Moore–Spence system of the collocation NLP, an independent computation. Away
from the curves, the number of equilibria must be 1 + 2·(number of fold curves below p) — it
changes exactly across the fold curves — and 1 below p_crit^(1). The stable counts (Sturm's index
of the Jacobi field) are compared with the reduced-Hessian verdicts of the NLP equilibria.
"""
import numpy as np
import pytest

from actuator_design.analysis.critical import critical_curves
from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.analysis.multiplicity import count_row, multiplicity_map
from actuator_design.scene import default_scene


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
