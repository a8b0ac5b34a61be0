"""The path from rest on a mesh graded for a strong field (issue 18's sweep of extremes: h = 1e4
with the clamp turned stopped at rest, the answer then came from the straight-rod start).

At rest the rod is straight at the clamp angle; on a mesh graded for h = 1e4 (end elements
~1e-5 long) rounding alone leaves |g|/m ~ 1e-5 there, above tol at rest's own scale. The path's
states are held to tol at their load's scale and may be excused by rounding as the full load's
state is (with a Newton step below 10 tol). Reference: the clamp layer's closed form (THEORY §5,
first integral θ'² = 2h² sin²(θ − φ)): tan((θ − φ)/2) = tan((θ0 − φ)/2) e^{−√2 h s}, so for φ = 0
the tip lies at y = θ0/(√2 h), x = 1 + 2 ln cos(θ0/2)/(√2 h) (exponentially small corrections).
"""
import math

import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import Scene, UniformField


@pytest.mark.parametrize("h, theta0", [(1e4, 0.3), (1e4, -0.3), (1e4, 1.0), (1e3, 0.3)])
def test_a_turned_clamp_in_a_strong_field_is_reached_from_rest_and_matches_the_layer(h, theta0):
    r = solve(Scene(field=UniformField(phi=0.0), h=h, theta0=theta0))
    assert r.success and r.stable
    assert r.stats["from_rest"]["reached"] and r.stats["from_rest"]["snaps_at"] == []
    k = math.sqrt(2.0) * h
    assert r.tip["y"] == pytest.approx(theta0 / k, rel=1e-7, abs=1e-12)
    assert r.tip["x"] == pytest.approx(1.0 + 2.0 * math.log(math.cos(theta0 / 2.0)) / k, abs=1e-11)
    assert abs(r.tip["angle"]) < 1e-9
