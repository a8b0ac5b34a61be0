"""A solved state's dense shape (EquilibriumResult.evaluate) against the closed form of a uniform
strip under a tip moment M: a circle of curvature M, x = sin(Ms)/M, y = (1 − cos(Ms))/M. A dense
sorted grid is integrated piece by piece between its points (short Gauss rules), any other request
point by point from the element's start (12-point rule): both exact to rounding."""
import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene


@pytest.mark.parametrize("moment", [2.0, 8.0, 40.0])  # 40: 6.4 turns, each element turning 10 rad
def test_dense_shape_is_the_circle_on_a_sorted_grid_and_point_by_point(moment):
    r = solve(Scene(field=None, tip_moment=moment), SolverOptions(keep_self_intersecting=True))
    assert r.tip["angle"] == pytest.approx(moment, rel=1e-12)
    s = np.linspace(0.0, 1.0, 2001)
    exact_x, exact_y = np.sin(moment * s) / moment, (1.0 - np.cos(moment * s)) / moment
    grid = r.evaluate(s)
    order = np.random.default_rng(0).permutation(s.size)  # unsorted: point by point
    single = r.evaluate(s[order])
    for d, idx in ((grid, slice(None)), (single, order)):
        assert np.max(np.abs(d["x"] - exact_x[idx])) < 1e-12
        assert np.max(np.abs(d["y"] - exact_y[idx])) < 1e-12
        assert np.max(np.abs(d["theta"] - moment * s[idx])) < 1e-10 * moment
