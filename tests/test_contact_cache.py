"""The contact NLPs kept for reuse are bounded by their estimated memory (actuator_design.contact_cache),
and a contact result that passes through itself is solved again with self-contact."""
import math
from dataclasses import replace

import numpy as np

import pytest
from contact_references import peg_reference

from actuator_design import contact_cache
from actuator_design.contact_split import accelerated, extended
from actuator_design.equilibrium import solve
from actuator_design.obstacles import Peg
from actuator_design.options import SolverOptions
from actuator_design.scene import Scene

PEG = Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025)


def test_nlps_beyond_the_budget_are_dropped_and_the_answer_is_unchanged(monkeypatch):
    """With no budget, every split round's NLP but the one in use is dropped as the next is built;
    the solve is the same (the peg's shooting reference, as tests/test_contact.py checks it)."""
    monkeypatch.setattr(contact_cache, "BUDGET", 0.0)
    r = solve(PEG)
    assert r.success and r.stable, r.message
    assert len(r.contact["split_at"]) == 1  # rounds on several meshes: several NLPs were built
    assert sum(1 for e in contact_cache._KEPT.values() if e[2] > 0) <= 1
    f, centre = np.array([0.0, -1.6]), np.array([0.6, -0.2])
    big = [q for q in r.contact["points"] if not q["weak"]]
    F = np.array(r.contact["total_force"])
    guess = [r.evaluate(np.array([0.0]))["dtheta"][0], big[0]["s"], np.hypot(*F), math.atan2(F[1], F[0])]
    (_, sc, R, psi), end, nu = peg_reference(f, centre, 0.1 + 0.025, guess)
    assert abs(r.tip["x"] - end[2]) <= 1e-6 and abs(r.tip["y"] - end[3]) <= 1e-6
    assert np.max(np.abs(F - R * nu)) <= 1e-4 and abs(big[0]["s"] - sc) <= 1e-4


def test_a_contact_result_judged_inaccurate_while_passing_through_itself_gets_self_contact(monkeypatch):
    """A rod wound round a peg onto itself enters the peg where it passes through its own turn: that
    contact result (inaccurate) is solved again with self-contact, not reported as it is."""
    import actuator_design.contact as contact
    import actuator_design.self_contact as self_contact

    from actuator_design.profiles import expression_profile
    coil = Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01,
                 obstacles=(Peg((5.0, 5.0), 0.1),))
    through = solve(replace(coil, obstacles=()), SolverOptions(keep_self_intersecting=True))
    assert self_contact.self_penetration(through, coil.contact_gap) is not None
    through.success, through.status = False, "inaccurate"
    calls = []
    monkeypatch.setattr(contact, "solve_contact", lambda *a, **k: through)
    monkeypatch.setattr(self_contact, "solve_self_contact", lambda *a, **k: calls.append(a) or "with self-contact")
    assert solve(coil) == "with self-contact" and len(calls) == 1
    # a result that fails for another reason is reported as it is
    through.status = "not_converged"
    assert solve(coil) is through and len(calls) == 1


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
