"""Loading paths on the continuation engine: the segment problem, the fold locator along a
segment, and the engine's stop events and step bounds, against independent references.

References: central finite differences through the parameter lens and the solver's own compiled
gradient (second-order convergence to the exact chain-rule derivatives), folds of the shooting
family (numpy/scipy only) along a segment on which two parameters move at once, and the shooting
fold load of the elastica.
"""
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import fsolve

from actuator_design.physics import parameters as lens
from actuator_design.continuation.loading import follow_path, prepare_scene
from actuator_design.continuation import (PALC, BifurcationProblem, BranchPoint, ContinuationSettings,
                                          Fold, Natural, continuation)
from actuator_design.continuation.segment import LensSegment, SegmentProblem, followers
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reduced import locate_fold, reduced_system
from actuator_design.reference.shooting import ShootingParams, shoot, solve_shooting
from actuator_design.model.scene import DipoleField, default_scene
from actuator_design.equilibrium.solver import get_solver
from fold_problems import elastica_fold_problem

HALF_PI = 0.5 * math.pi


def dipole_scene():
    return replace(default_scene(h=0.4), field=DipoleField(x0=1.2, y0=-0.3), h_pos=0.2)


def test_h_pos_follows_the_field_magnitude_with_exact_slope():
    """Ramping h² in a dipole field moves h_pos ∝ √(h²) (THEORY §5): the segment's values are the
    lens' values, and its slope dp/dλ is the limit of central differences of the lens' values, which
    converge to it at second order."""
    base = dipole_scene()
    names, rows = ["h2", "p"], np.array([[0.04, 0.0], [0.36, 0.3]])
    follow = followers(base, names, rows)
    assert follow == ["h_pos"]
    seg = LensSegment(base, names, rows[0], rows[1], follow)
    lam = 0.37

    def lens_values(l):
        sc = seg.scene(l)
        return np.array([lens.get_value(sc, n) for n in seg.system_names])

    p, dp = seg.point(lam)
    assert np.allclose(p, lens_values(lam), rtol=1e-13, atol=0)
    errors = []
    for d in (1e-2, 5e-3, 2.5e-3):
        fd = (lens_values(lam + d) - lens_values(lam - d)) / (2 * d)
        errors.append(np.max(np.abs(fd - dp)))
    assert errors[-1] < 1e-5
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.05)  # second order: dp is exact
    assert errors[1] / errors[2] == pytest.approx(4.0, rel=0.05)


def test_segment_G_lambda_is_the_derivative_of_the_solvers_gradient_along_the_schedule():
    """G_λ of the segment problem (chain rule over h, p and the following h_pos) against central
    differences of the solver's compiled gradient at the lens' scenes λ ± d (second order)."""
    coarse = SolverOptions(elements=2, degree=6)  # the dipole NLP is slow to build: keep it small
    names, rows = ["h", "p"], np.array([[0.2, 0.0], [0.6, 0.4]])
    base = prepare_scene(dipole_scene(), names)
    follow = followers(base, names, rows)
    seg = LensSegment(base, names, rows[0], rows[1], follow)
    solver = get_solver(base, coarse)
    prob = SegmentProblem(reduced_system(solver, list(names) + follow), solver.parameter_vector(seg.scene(0)), seg)
    lam = 0.45
    u = solve(seg.scene(lam), coarse, solver=solver).z[1:] + 0.01  # any state will do
    g, _, gl = prob.ev(u, lam)
    gl = gl.copy()
    k = solver.kernel

    def grad(l):
        k.set_params(solver.parameter_vector(seg.scene(l)))
        k.evaluate(u, hessian=False)
        return k.g.copy()

    assert np.allclose(g, grad(lam), atol=1e-12)
    # g is quadratic in λ along this segment (h, h_pos and p all linear in λ), so central
    # differences are exact up to rounding, for every step d
    for d in (1e-2, 1e-3):
        fd = (grad(lam + d) - grad(lam - d)) / (2 * d)
        assert np.max(np.abs(fd - gl)) < 1e-8 * np.max(np.abs(gl))
    # and the follower matters: without h_pos' share, G_λ would be visibly wrong
    _, _, gl_parts = prob.ev.inner(u, seg.point(lam)[0])
    without = gl_parts[:, :2] @ seg.point(lam)[1][:2]
    assert np.max(np.abs(without - gl)) > 1e-3 * np.max(np.abs(gl))
    assert np.allclose(prob.params(lam), solver.parameter_vector(seg.scene(lam)), rtol=1e-14, atol=0)


def shooting_fold_on_line(h, p, gamma0, lam0):
    """(γ, λ) of the shooting fold on the line (h(λ), p(λ)) of a transverse field (numpy/scipy)."""
    def F(x):
        s = shoot(x[0], ShootingParams(h=h(x[1]), phi=HALF_PI, fy=p(x[1])), variational=True)
        return [s.residual, s.dresidual]

    sol, _, ier, msg = fsolve(F, [gamma0, lam0], full_output=True, xtol=1e-13)
    assert ier in (1, 3), msg
    assert max(abs(v) for v in F(sol)) < 1e-10
    return sol


def test_jump_on_a_segment_where_field_and_load_move_at_once_is_the_shooting_fold():
    """(h, p) from (2, −0.1) to (0.6, −0.5) on the buckled upper branch: both slots move in one
    segment; the jump is the shooting fold on that line (to 1e-8) and the landing is stable."""
    a, b = np.array([2.0, -0.1]), np.array([0.6, -0.5])
    sched = [{"h": 2.0, "p": 0.2}, {"h": a[0], "p": a[1]}, {"h": b[0], "p": b[1]}]
    path = follow_path(default_scene(h=2.0, phi=HALF_PI, p=0.2), None, sched)
    assert path.success and path.param is None and len(path.jumps) == 1
    jump = path.jumps[0]
    assert 1.0 < jump.t < 2.0 and jump.kind == "fold"
    lam = jump.t - 1.0
    h = lambda l: a[0] + l * (b[0] - a[0])
    p = lambda l: a[1] + l * (b[1] - a[1])
    _, lam_ref = shooting_fold_on_line(h, p, jump.from_state.gamma, lam)
    assert lam == pytest.approx(lam_ref, rel=1e-8)
    assert jump.values["h"] == pytest.approx(h(lam_ref), rel=1e-8)
    assert jump.values["p"] == pytest.approx(p(lam_ref), rel=1e-8)
    ref = solve_shooting(ShootingParams(h=jump.values["h"], phi=HALF_PI, fy=jump.values["p"]),
                         jump.to_state.gamma)
    assert ref.converged and ref.tip_angle == pytest.approx(jump.to_state.tip["angle"], abs=1e-9)
    assert jump.to_state.stable and jump.from_state.tip["angle"] * jump.to_state.tip["angle"] < 0


def test_a_stop_event_ends_the_run_on_the_near_side_of_the_fold():
    """Fold(stop=True): the run ends at the elastica's fold load (shooting), every point on the
    side it came from, and the Moore–Spence locator from the event agrees."""
    prob, p1 = elastica_fold_problem()
    st = ContinuationSettings(ds=0.05, ds_max=0.2, window=(p1 - 1.0, p1 + 2.0), max_steps=400, direction=-1.0)
    br = continuation(prob, PALC(), st, (Fold(stop=True), BranchPoint()))
    assert br.status == "event" and [e.kind for e in br.events] == ["fold"]
    assert br.events[0].lam == pytest.approx(p1, abs=1e-7)
    assert np.all(br.lam > p1)
    ms = locate_fold(prob.system, prob.P, br.events[0].x[:-1], br.events[0].lam)
    assert ms.converged and ms.lam == pytest.approx(p1, abs=1e-9)


def test_step_bounds_hold_for_natural_and_palc():
    """max_dlam and max_du bound every step (the predictor is shortened, not just rejected)."""
    scene = default_scene(h=1.5, phi=HALF_PI)
    solver = get_solver(scene, SolverOptions())
    prob = BifurcationProblem(reduced_system(solver, ["h"]), solver.parameter_vector(scene),
                              solve(scene, solver=solver).z[1:], 1.5)
    for algo in (PALC(), Natural()):
        st = ContinuationSettings(ds=0.5, ds_max=0.5, window=(1.5, 4.0), max_du=0.02, max_dlam=0.1)
        br = continuation(prob, algo, st)
        assert br.status == "left_window" and br.lam[-1] == pytest.approx(4.0)
        steps = np.diff(br.x, axis=0)
        # natural steps are exactly the predictor's; PALC's corrector moves λ off the predictor a little
        assert np.max(np.abs(steps[:, -1])) <= 0.1 * (1 + (1e-2 if isinstance(algo, PALC) else 1e-12))
        assert np.max(np.abs(steps[:-1, :-1])) <= 0.02 + 1e-12  # (the last is cut at the window)


@pytest.mark.parametrize("field, value", [("max_du", 0.0), ("max_dlam", -1.0), ("max_du", float("nan"))])
def test_step_bound_settings_validate_themselves(field, value):
    with pytest.raises(ValueError, match=f"{field}: must be a number > 0"):
        ContinuationSettings(**{field: value})


def _combined_rod():
    from actuator_design.config.model import load_scene
    from pathlib import Path
    return load_scene(Path(__file__).resolve().parents[1] / "configs" / "combined_soft_hard_rod.yaml")[0]


def test_h2_from_zero_field_moves_the_remanent_group_smoothly():
    """Ramping h² from zero field on a rod with remanence: h_r ∝ H = √(h²) would leave zero with an
    infinite slope in h²; the segment moves linearly in the field instead (h² = (λ h_b)², h_r ∝ λ),
    its values are the lens' values and dp/dλ is exact (central differences of the lens' values give
    it, and one-sided ones at λ = 0 converge to it at first order)."""
    base = _combined_rod()
    names, rows = ["h2"], np.array([[0.0], [4.0]])
    follow = followers(base, names, rows)
    assert follow == ["h_r"]
    seg = LensSegment(base, names, rows[0], rows[1], follow)

    def lens_values(l):
        sc = seg.scene(l)
        return np.array([lens.get_value(sc, n) for n in seg.system_names])

    for lam in (0.37, 1.0):
        p, _ = seg.point(lam)
        assert np.allclose(p, lens_values(lam), rtol=1e-13, atol=0)
    assert seg.values(0.5)["h2"] == pytest.approx(1.0, rel=1e-15)  # (½ · 2)²: linear in the field
    p, dp = seg.point(0.37)  # h² and h_r are quadratic and linear in λ: central differences are exact
    assert np.allclose((lens_values(0.37 + 1e-3) - lens_values(0.37 - 1e-3)) / 2e-3, dp, rtol=1e-9, atol=0)
    p0, dp0 = seg.point(0.0)
    assert np.all(np.isfinite(dp0)) and dp0[1] == pytest.approx(1.5 / 0.8 * 2.0, rel=1e-14)
    one_sided = [np.max(np.abs((lens_values(d) - lens_values(0.0)) / d - dp0)) for d in (1e-3, 5e-4)]
    assert one_sided[0] / one_sided[1] == pytest.approx(2.0, rel=0.05)
    # the ends are the schedule's values exactly, and no field is made beyond them
    assert seg.values(1.0)["h2"] == 4.0 and seg.values(0.0)["h2"] == 0.0
    assert seg.point(-1e-3)[0][0] == 0.0 and seg.point(1.0 + 1e-3)[0][0] == pytest.approx(4.0, rel=1e-15)
    # a follower whose energy is smooth in h² (h_pos² ∝ h² of a dipole field) keeps the straight segment
    dip = LensSegment(dipole_scene(), names, rows[0], rows[1], followers(dipole_scene(), names, rows))
    assert dip.values(0.5)["h2"] == 2.0


def test_a_path_in_h2_from_zero_field_is_the_field_ramp_from_rest():
    """The loading path over h² from 0 on a rod with remanence (it failed at t = 0 before) follows
    the same states as the path over h from 0 (the same field ramp, written in h): both end on the
    same state, and each state of the h² path is the equilibrium ``solve`` reaches from rest there."""
    base = _combined_rod()
    in_h2 = follow_path(base, schedule={"h2": [0.0, 4.0]})
    in_h = follow_path(base, schedule={"h": [0.0, 2.0]})
    assert in_h2.success and in_h.success and in_h2.snap_free
    assert in_h2.final.tip["x"] == pytest.approx(in_h.final.tip["x"], abs=1e-8)
    assert in_h2.final.tip["y"] == pytest.approx(in_h.final.tip["y"], abs=1e-8)
    values = [pt.values["h2"] for pt in in_h2.points]
    assert values == sorted(values) and values[0] == 0.0 and values[-1] == pytest.approx(4.0, rel=1e-14)
    for pt in in_h2.points[3::6]:
        r = solve(lens.apply_values(base, {"h2": pt.values["h2"]}))
        assert r.success and r.stable
        assert (r.tip["x"], r.tip["y"]) == pytest.approx((pt.tip["x"], pt.tip["y"]), abs=1e-7)
