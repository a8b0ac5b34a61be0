"""The split rounds' bookkeeping (actuator_design.contact.split): which rounds Anderson's mixing uses;
and where they put element boundaries (actuator_design.contact.nearest), against other methods."""
import math

import numpy as np

from actuator_design.contact.split import accelerated, extended


def test_split_rounds_mix_only_rounds_with_as_many_points_in_start_and_answer():
    """A first round whose answer has another number of points than its start (a contact appearing)
    starts the history afresh; before, the next round mixed arrays of two lengths and raised."""
    first = ((0.5,), (0.4, 0.6))
    # F(s) = s* + (s − s*)/2, s* = (0.42, 0.63): the rounds' differences are parallel, and one
    # difference takes Anderson's mixing to the fixed point
    second = ((0.4, 0.6), (0.41, 0.615))
    history = extended(extended([], first), second)
    assert history == [second]
    assert accelerated(history) == (0.41, 0.615)
    third = ((0.41, 0.615), (0.415, 0.6225))
    history = extended(history, third)
    assert history == [second, third]
    assert np.allclose(accelerated(history), (0.42, 0.63), atol=1e-12)


def test_boundary_rounds_cut_short_say_the_contact_was_still_moving(monkeypatch):
    """A peg under the rod's middle needs several boundary rounds (its contact point is first a
    quadrature point); capped at one, the rod still enters the peg between the constrained points
    and the result says the rounds stopped with the contact still moving, not "more elements"."""
    import actuator_design.contact.equilibrium as contact
    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.contact.obstacles import Peg
    from actuator_design.model.scene import Scene

    peg = Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025)
    full = solve(peg)
    assert full.success and 2 <= full.contact["boundary_rounds"] < contact.MAX_SPLIT_ROUNDS, full.message
    monkeypatch.setattr(contact, "MAX_SPLIT_ROUNDS", 1)
    cut = solve(peg)
    assert not cut.success and cut.contact["boundary_rounds"] == 1
    assert "still moving after 1 boundary rounds" in cut.message and "more elements" not in cut.message
    assert math.hypot(cut.tip["x"] - full.tip["x"], cut.tip["y"] - full.tip["y"]) < 1e-2  # the same contact


def _slope_root(scene, result, k, a, b):
    """The root of ∇d(r(s))·t(s) in [a, b] by Brent's method on the obstacle's own normal (no
    derivative of the slope, no bracket narrowing): the reference for nearest_point."""
    from scipy.optimize import brentq

    ob = scene.obstacles[k]

    def slope(s):
        e = result.evaluate(np.array([s]))
        n = np.asarray(ob.normal(e["x"], e["y"]), float).ravel()
        return n[0] * np.cos(e["theta"][0]) + n[1] * np.sin(e["theta"][0])
    return brentq(slope, a, b, xtol=1e-15, rtol=1e-15)


def test_nearest_point_is_the_root_of_the_distances_slope_also_at_a_kink():
    """nearest_point (Newton's method on one smooth piece between nodes) against Brent's method on
    the slope: on a peg's converged state, whose contact point is an element boundary where θ'
    kinks (there, Newton across the kink converged only linearly: 3e-11 off), from starts on both
    sides and afar, and on a lumen's bend; and at the same point from every start."""
    from actuator_design.contact.obstacles import Lumen, Peg
    from actuator_design.contact.nearest import nearest_point
    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.model.scene import Scene

    cases = [Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025),
             Scene(field=None, tip_force=(0.0, -20.0), obstacles=(Peg((0.5, -0.1), 0.05),), contact_gap=0.01),
             Scene(field=None, contact_gap=0.01, obstacles=(Lumen((-0.1, 0.0), 0.0, 0.06, (
                 ("straight", 0.3), ("arc", 0.5, math.radians(70)), ("straight", 0.6))),))]
    for scene in cases:
        r = solve(scene)
        assert r.success, r.message
        for p in [q for q in r.contact["points"] if 0.0 < q["s"] < 1.0 and not q["weak"]]:
            ref = _slope_root(scene, r, p["obstacle"], p["s"] - 0.02, p["s"] + 0.02)
            assert abs(ref - p["s"]) < 1e-8  # the converged boundary sits at the contact point
            found = [nearest_point(scene, r, {**p, "s": p["s"] + d}) for d in (0.0, -0.03, 0.03, 0.09, -0.11)]
            assert max(abs(f - ref) for f in found) < 1e-12, (found, ref)


def _pair_by_lbfgsb(result, s_a, s_b, half):
    """The nearest pair by scipy's L-BFGS-B on |r(a) − r(b)|² with its exact gradient, from the
    same start and within the same bounds: the reference for nearest_pair (a quasi-Newton method
    on the whole window, no pieces, no Hessian)."""
    from scipy.optimize import minimize

    def dist2(v):
        e = result.evaluate(np.asarray(v, float))
        d = np.array([e["x"][0] - e["x"][1], e["y"][0] - e["y"][1]])
        t = np.array([np.cos(e["theta"]), np.sin(e["theta"])])
        return float(d @ d), np.array([2.0 * d @ t[:, 0], -2.0 * d @ t[:, 1]])
    bounds = [(max(1e-9, s_a - half), min(1.0, s_a + half)), (max(1e-9, s_b - half), min(1.0, s_b + half))]
    out = minimize(dist2, [s_a, s_b], jac=True, method="L-BFGS-B", bounds=bounds,
                   options={"ftol": 1e-16, "gtol": 1e-15, "maxiter": 500})
    return tuple(sorted(float(v) for v in out.x)), math.sqrt(out.fun)



def test_nearest_pair_against_a_quasi_newton_minimisation():
    """nearest_pair (Newton's method projected on one piece between nodes at a time, its Hessian
    shifted at saddles) against L-BFGS-B on the whole window: every pair the split rounds of a
    coiled strip ask for (tip against body, and two turns sliding along each other: a valley flat
    to ~1e-6, from a start 0.08 of arc from the minimum), the same distance to 1e-14 and the same
    pair to 1e-6 of arc (along a flat valley, round-off moves the minimum that far)."""
    import actuator_design.contact.equilibrium as contact
    from actuator_design.contact.nearest import nearest_pair
    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.model.profiles import expression_profile
    from actuator_design.model.scene import Scene

    asked = []
    real = contact.nearest_pair
    contact.nearest_pair = lambda r, a, b, half: asked.append((r, a, b, half)) or real(r, a, b, half)
    try:
        for moment in (8.0, 8.5):
            r = solve(Scene(field=None, tip_moment=moment, stiffness=expression_profile("exp(-s)"), contact_gap=0.01))
            assert r.success, r.message
    finally:
        contact.nearest_pair = real
    assert len(asked) >= 10 and max(abs(b - a) for _, a, b, _ in asked if b < 1.0) > 0.3
    far = 0.0
    for r, a, b, half in asked:
        found = nearest_pair(r, a, b, half)
        ref, ref_distance = _pair_by_lbfgsb(r, a, b, half)
        e = r.evaluate(np.array(found))
        assert math.hypot(e["x"][0] - e["x"][1], e["y"][0] - e["y"][1]) <= ref_distance + 1e-14
        assert max(abs(f - q) for f, q in zip(found, ref)) < 1e-6
        far = max(far, abs(found[0] - a))
    assert far > 0.05  # a start far along a valley was among them


def test_nearest_pair_from_a_start_one_rounding_off_a_node():
    """A start within round-off of an element boundary, the step pointing across it (a dense
    check's grid point 0.3 beside the node 0.30000000000000004 of a coil's 5-element mesh): the
    step was cut to nothing at the face and the start came back as the answer (distance 0.033
    instead of 0.024); now the search moves onto the face and on, to L-BFGS-B's minimum."""
    from actuator_design.contact.nearest import nearest_pair
    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.model.profiles import expression_profile
    from actuator_design.model.scene import Scene

    r = solve(Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01))
    assert r.success and np.any(np.abs(r.s - 0.3) < 1e-15), r.message
    for a in (0.3, 0.3 + 1e-12, 0.3 - 5e-11):
        found = nearest_pair(r, a, 0.7225, 0.1)
        e = r.evaluate(np.array(found))
        _, ref_distance = _pair_by_lbfgsb(r, a, 0.7225, 0.1)
        assert math.hypot(e["x"][0] - e["x"][1], e["y"][0] - e["y"][1]) <= ref_distance + 1e-12
