"""Newton's method on the KKT system of a guessed contact set (actuator_design/contact/newton.py)
against IPOPT on the same NLP (a second method), and its refusals: a guessed set with a row that
would have to pull the rod onto an obstacle, and answers IPOPT would not give (tested through the
paths that need them in tests/test_contact_tip_roll.py and tests/test_self_contact.py)."""
import numpy as np

from actuator_design.contact.equilibrium import contact_nlp
from actuator_design.contact.newton import newton_on_contact_set, pressing_rows
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Peg
from actuator_design.model.scene import Scene
from actuator_design.equilibrium.solver import get_solver


def _peg_problem():
    scene = Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025)
    r = solve(scene)
    assert r.success and len(r.contact["points"]) == 1, r.message
    solver = get_solver(scene, r.options)  # the mesh with the element boundary at the contact
    nlp = contact_nlp(solver, scene)
    P = nlp.parameters(solver.parameter_vector(scene))
    lbg, ubg = nlp.bounds()
    sol = nlp.nlpsol(False)(x0=np.zeros(solver.transcription.nodes.size), p=P, lbg=lbg, ubg=ubg)
    z, lam = (np.asarray(sol[k], float).ravel() for k in ("x", "lam_g"))
    return solver, nlp, P, lbg, z, lam


def test_newton_on_the_contact_set_lands_on_ipopts_minimum():
    solver, nlp, P, lbg, z_ip, lam_ip = _peg_problem()
    rows = pressing_rows(nlp, lam_ip, None, ())
    assert len(rows) == 1
    s = np.asarray(solver.transcription.nodes, float)
    start = z_ip + 0.05 * np.sin(np.pi * s)  # a shape a load step away, clear of the peg
    start[0] = 0.0
    mass = np.asarray(solver.transcription.mass, float)
    z, lam, iterations, (grad, _, _) = newton_on_contact_set(nlp, start, P, lbg, rows, mass, 1e-10)
    assert iterations <= 8
    assert np.max(np.abs(z - z_ip)) < 1e-10
    assert np.max(np.abs(lam - lam_ip)) < 1e-8 * np.max(np.abs(lam_ip))
    assert np.max(np.abs(grad[1:] / mass[1:])) < 1e-10


def test_a_guessed_row_that_would_pull_is_refused():
    """The tip row added to the set: holding the free tip at the gap from the peg needs a pulling
    force (μ < 0), which no contact gives: no answer (the caller solves with IPOPT)."""
    solver, nlp, P, lbg, z_ip, lam_ip = _peg_problem()
    tip_row = 1 + nlp.n_points - 1  # the last constrained point of the peg's rows is the tip
    assert nlp.s_points[-1] == 1.0
    rows = pressing_rows(nlp, lam_ip, None, ()) + [tip_row]
    mass = np.asarray(solver.transcription.mass, float)
    assert newton_on_contact_set(nlp, z_ip, P, lbg, rows, mass, 1e-10) is None


def test_a_self_contact_split_round_is_newtons_and_lands_on_ipopts_minimum():
    """The coiled strip's last split round: its pairs are the round before's self-contacts (element
    boundaries now), guessed to press. Newton's answer is IPOPT's on the same NLP and pairs — on a mesh
    graded towards the tip, where |∇L|/m stalls at the rounding floor of the small end elements, above
    1e-10 but within each unknown's floor (reduced.linalg.within_rounding_floor)."""
    from actuator_design.model.profiles import expression_profile

    scene = Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01)
    r = solve(scene)
    assert r.success and "Newton on the contact set of the round before" in r.message, r.message
    solver = get_solver(scene, r.options)
    nlp = contact_nlp(solver, scene, True)
    _, pairs, lam_r, signs = r._contact_multipliers
    P = nlp.parameters(solver.parameter_vector(scene), pairs, signs)
    lbg, ubg = nlp.bounds(pairs)
    sol = nlp.nlpsol(False)(x0=np.asarray(r.z, float) * 0.99, p=P, lbg=lbg, ubg=ubg)
    z_ip, lam_ip = (np.asarray(sol[k], float).ravel() for k in ("x", "lam_g"))
    assert np.max(np.abs(r.z - z_ip)) < 1e-9
    assert np.max(np.abs(lam_r - lam_ip)) < 1e-7 * np.max(np.abs(lam_ip))


def test_a_state_presses_nowhere_when_no_contact_row_carries_a_force():
    """nothing_pressed: the clamp row's multiplier is no contact force; a contact row's counts when
    it is above ACTIVE relative to the largest (CasADi's sign: a pressing row has λ < 0)."""
    from actuator_design.contact.newton import nothing_pressed
    from actuator_design.contact.report import ACTIVE

    assert nothing_pressed(np.array([5.0, 0.0, 0.0, 0.0]))
    assert nothing_pressed(np.array([5.0, -0.5 * ACTIVE, 0.0, 1e-3]))  # below ACTIVE, or pulling
    assert not nothing_pressed(np.array([5.0, 0.0, -2.0 * ACTIVE, 0.0]))
    assert not nothing_pressed(np.array([0.0, -3.0, -1e-3, 0.0]))


def test_a_newton_answer_too_far_from_its_start_is_not_vouched_for():
    """kept_clear samples the straight way from the start to Newton's answer every SWEEP of the
    largest point motion; beyond SWEEP_STEPS samples it no longer vouches for the way (IPOPT
    decides): the samples were capped at 64 whatever the length, coarser than a thin strip's
    thickness. From a start a load step away the way is checked; from the rod bent the other way
    (the tip moves 0.4 rod lengths) it is not."""
    from actuator_design.contact.newton import SWEEP, SWEEP_STEPS, kept_clear

    solver, nlp, P, lbg, z_ip, lam_ip = _peg_problem()
    s = np.asarray(solver.transcription.nodes, float)
    mass = np.asarray(solver.transcription.mass, float)
    rows = pressing_rows(nlp, lam_ip, None, ())
    near = z_ip + 0.05 * np.sin(np.pi * s)
    near[0] = 0.0
    assert kept_clear(nlp, near, P, newton_on_contact_set(nlp, near, P, lbg, rows, mass, 1e-10))
    mirrored = -z_ip
    X0, Y0 = (np.asarray(v, float).ravel() for v in nlp.f_xy(mirrored))
    X1, Y1 = (np.asarray(v, float).ravel() for v in nlp.f_xy(z_ip))
    assert np.max(np.hypot(X1 - X0, Y1 - Y0)) > SWEEP_STEPS * SWEEP
    assert not kept_clear(nlp, mirrored, P, (z_ip, lam_ip))
