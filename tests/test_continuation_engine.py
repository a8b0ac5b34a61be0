"""The continuation engine (actuator_design.continuation) against independent references.

References: the pitchforks h_crit^(m) = (2m−1)π/(2√2) of the straight rod in a transverse field and
the elliptic first mode (THEORY §6, ``reference.closed_forms``); numpy's dense eigendecomposition
for the stability recorded along a branch; a user event "the tip crosses the wall
x = c" against a plain bisection of independent forward solves (``equilibrium.solve``); the fold
load p_crit^(1) of the elastica by the shooting solver.
"""
import dataclasses
import math

import numpy as np
import pytest

from actuator_design.continuation import (PALC, BifurcationProblem, BranchPoint, ContinuationSettings,
                                          Fold, Natural, UserEvent, continuation)
from actuator_design.reduced.banded import BandedBordered
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reduced import reduced_system
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.model.scene import default_scene
from actuator_design.equilibrium.solver import get_solver


def problem_for(scene, name, lam0, u0=None, options=SolverOptions()):
    solver = get_solver(scene, options)
    if u0 is None:
        u0 = solve(scene, options, solver=solver).z[1:]
    return BifurcationProblem(reduced_system(solver, [name]), solver.parameter_vector(scene), u0, lam0)


def test_transverse_pitchfork_is_a_branch_point_not_a_fold():
    """Straight rod, φ = π/2, h ∈ [0, 2]: one branch point at π/(2√2), no fold, index 0 → 1."""
    prob = problem_for(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0)
    br = continuation(prob, PALC(), ContinuationSettings(window=(0.0, 2.0)), (Fold(), BranchPoint()))
    assert br.status == "left_window" and br.lam[-1] == pytest.approx(2.0)
    assert [e.kind for e in br.events] == ["branch_point"]
    bp = br.events[0]
    assert bp.located and bp.lam == pytest.approx(critical_field_transverse(1), abs=1e-8)
    assert bp.lam == pytest.approx(math.pi / (2 * math.sqrt(2)), abs=1e-8)
    assert (bp.index_before, bp.index_after) == (0, 1)


def test_straight_rod_meets_five_pitchforks_at_the_closed_form_fields():
    """Straight rod, φ = π/2, h ∈ [0, 12]: a branch point at each h_crit^(m) = (2m−1)π/(2√2),
    m = 1..5, and no fold; the Morse index rises by one at each (Sturm: index = #modes below h).
    The test function is the signed smallest |μ| from a partial spectrum (LDLᵀ inertia + dsyevr)."""
    prob = problem_for(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0)
    br = continuation(prob, PALC(), ContinuationSettings(ds_max=0.05, window=(0.0, 12.0)),
                      (Fold(), BranchPoint()))
    assert br.status == "left_window" and [e.kind for e in br.events] == ["branch_point"] * 5
    for m, e in enumerate(br.events, start=1):
        assert e.located and e.lam == pytest.approx((2 * m - 1) * math.pi / (2 * math.sqrt(2)), abs=1e-8)
        assert (e.index_before, e.index_after) == (m - 1, m)
    assert br.morse_index[-1] == 5


def test_fixed_step_palc_points_lie_on_the_elliptic_mode_with_their_true_spectrum():
    """300 PALC steps of exactly ds on the first transverse mode, each corrector started from the
    predictor plus the curvature term: every point has the closed-form tip angle β(h), lies at
    arclength ds along the previous tangent (the PALC constraint: the start does not move the
    point), and its recorded Morse index and smallest eigenvalue are those of numpy's dense
    eigendecomposition of the mass-scaled Hessian there."""
    prob = problem_for(default_scene(h=1.5, phi=math.pi / 2), "h", 1.5)
    ds = 0.01
    br = continuation(prob, PALC(), ContinuationSettings(ds=ds, ds_max=ds, max_steps=300),
                      (Fold(), BranchPoint()))
    assert len(br) == 300 and br.status == "max_points" and not br.events
    n = prob.n
    scale = 1.0 / np.sqrt(np.outer(prob.mass, prob.mass))
    for x, index, lowest in zip(br.x, br.morse_index, br.min_eig):
        assert abs(abs(prob.tip(x)[0]) - transverse_mode(x[n], 1).beta) < 1e-8
        A = prob.ev(x[:n], x[n])[1] * scale
        w = np.linalg.eigvalsh(0.5 * (A + A.T))
        assert index == int(np.sum(w < 0)) == 0
        assert lowest == pytest.approx(w[0], rel=1e-10)
    arc = np.einsum("ij,j,ij->i", br.tangents[:-1], prob.W, np.diff(br.x, axis=0))
    assert np.max(np.abs(arc - ds)) < 1e-9


def test_banded_bordered_solve_and_determinant_sign_match_dense_lapack():
    """Block elimination with a banded LU (plus one refinement step) against numpy's dense solve
    and determinant of the bordered matrix, also with H close to singular (as near a fold)."""
    rng = np.random.default_rng(2)
    for trial in range(16):
        n = int(rng.integers(64, 130))
        bw = int(rng.integers(1, n // 4))
        H = np.triu(np.tril(rng.standard_normal((n, n)), bw), -bw)
        H = H + H.T + rng.uniform(-3, 3) * np.eye(n)
        if trial % 2 == 0:  # nearly singular: shift by the eigenvalue closest to zero
            w = np.linalg.eigvalsh(H)
            H -= (w[np.argmin(np.abs(w))] + 1e-9) * np.eye(n)
        b, c, r = rng.standard_normal(n), rng.standard_normal(n), rng.standard_normal(n + 1)
        d = float(rng.standard_normal())
        J = np.block([[H, b[:, None]], [c[None, :], np.array([[d]])]])
        x, sign = BandedBordered(n, bw, np.ones(n)).bordered(H, b, c, d, r)
        ref = np.linalg.solve(J, r)
        assert np.max(np.abs(x - ref)) < 1e-8 * np.max(np.abs(ref))
        assert sign == np.sign(np.linalg.det(J))


def test_band_path_pitchforks_converge_at_second_order():
    """Fine midpoint meshes (n = 200 and 400: band storage throughout): the straight rod's branch
    points approach (2m−1)π/(2√2) at second order (the error falls fourfold when the mesh is
    halved), with the Morse index 0 → 1 → 2, and the recorded smallest eigenvalues are numpy's."""
    errors = []
    for elements in (200, 400):
        opts = SolverOptions(transcription="midpoint", elements=elements)
        prob = problem_for(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0, options=opts)
        assert prob._band is not None
        br = continuation(prob, PALC(), ContinuationSettings(ds_max=0.1, window=(0.0, 4.0)),
                          (Fold(), BranchPoint()))
        assert [e.kind for e in br.events] == ["branch_point"] * 2
        assert [(e.index_before, e.index_after) for e in br.events] == [(0, 1), (1, 2)]
        errors.append([e.lam - critical_field_transverse(m) for m, e in enumerate(br.events, start=1)])
        n = prob.n
        scale = 1.0 / np.sqrt(np.outer(prob.mass, prob.mass))
        for x, lowest in zip(br.x[::9], br.min_eig[::9]):
            A = prob.ev(x[:n], x[n])[1] * scale
            assert lowest == pytest.approx(np.linalg.eigvalsh(0.5 * (A + A.T))[0], abs=1e-9)
    ratio = np.array(errors[0]) / np.array(errors[1])
    assert np.all((3.9 < ratio) & (ratio < 4.1)), ratio


def test_user_event_tip_crosses_a_wall_matches_bisection_of_forward_solves():
    """Elastica in p from 0: where x(1) = 0.9, by the engine and by bisection on forward solves."""
    wall = 0.9
    scene = default_scene(h=0.0, p=0.0)
    prob = problem_for(scene, "p", 0.0)
    event = UserEvent("wall", lambda state: state.tip["x"] - wall)
    br = continuation(prob, PALC(), ContinuationSettings(window=(0.0, 5.0)), (event,))
    hits = [e for e in br.events if e.name == "wall"]
    assert len(hits) == 1 and hits[0].located
    opts = SolverOptions()

    def gap(p):
        r = solve(default_scene(h=0.0, p=p), opts)
        assert r.success
        return r.tip["x"] - wall

    a, b = 0.0, 5.0
    assert gap(a) > 0 > gap(b)
    while b - a > 1e-11:
        m = 0.5 * (a + b)
        a, b = (m, b) if gap(m) > 0 else (a, m)
    assert hits[0].lam == pytest.approx(0.5 * (a + b), abs=1e-8)


def test_natural_continuation_follows_the_elliptic_mode():
    """Natural steps in h on the first transverse mode: tip angle = β(h) of the closed form."""
    scene = default_scene(h=1.5, phi=math.pi / 2)
    prob = problem_for(scene, "h", 1.5)
    br = continuation(prob, Natural(), ContinuationSettings(ds=0.05, ds_max=0.05, window=(1.5, 2.5)))
    assert br.status == "left_window" and len(br) > 15
    n = prob.n
    for x in br.x:
        beta = transverse_mode(x[n], 1).beta
        assert abs(abs(prob.tip(x)[0]) - beta) < 1e-8
    assert np.allclose(np.diff(br.lam)[:-1], 0.05, atol=1e-12)  # steps of exactly ds in λ


def test_palc_passes_the_elastica_fold_natural_stops_there():
    """Through the fold p_crit^(1) ≈ 10.3252 (shooting value in the suite): PALC turns round it
    and locates it; natural continuation cannot pass it and ends with a small step."""
    from actuator_design.reduced import locate_fold
    from fold_problems import elastica_fold_problem

    prob, p1 = elastica_fold_problem()
    st = ContinuationSettings(ds=0.05, ds_max=0.2, window=(p1 - 1.0, p1 + 2.0), max_steps=400,
                              direction=-1.0)
    br = continuation(prob, PALC(), st, (Fold(), BranchPoint()))
    folds = [e for e in br.events if e.kind == "fold"]
    assert len(folds) == 1 and folds[0].lam == pytest.approx(p1, abs=1e-7)
    # the located event and the Moore–Spence locator agree
    ms = locate_fold(prob.system, prob.P, folds[0].x[:-1], folds[0].lam)
    assert ms.converged and ms.lam == pytest.approx(folds[0].lam, abs=1e-8)
    nat = continuation(prob, Natural(), st)
    assert nat.status == "step_too_small" and nat.lam.min() == pytest.approx(p1, abs=1e-3)


@pytest.mark.parametrize("field, value, fragment", [
    ("ds", -0.1, "ds: must be a finite number > 0"),
    ("ds_min", 1.0, "ds_min: must be <= ds"),
    ("max_steps", 1, "max_steps: must be an integer >= 2"),
    ("window", (1.0, 0.0), "window: must be two numbers (lo, hi) with lo <= hi"),
    ("direction", 0.5, "direction: must be +1 or -1"),
    ("tol", float("nan"), "tol: must be a finite number > 0"),
    ("min_cos_turn", 1.5, "min_cos_turn: must be in [-1, 1)"),
    ("grow_iterations", -1, "grow_iterations: must be an integer >= 0"),
])
def test_settings_validate_themselves(field, value, fragment):
    with pytest.raises(ValueError) as err:
        ContinuationSettings(**{field: value})
    assert fragment in str(err.value)


def test_settings_are_frozen():
    st = ContinuationSettings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        st.ds = 1.0
    assert dataclasses.replace(st, ds=0.1).ds == 0.1
