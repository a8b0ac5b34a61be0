"""The contact NLPs kept for reuse are bounded by their estimated memory (actuator_design.contact.cache)."""
import math

import numpy as np
from contact_references import peg_reference

from actuator_design.contact import cache as contact_cache
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Peg
from actuator_design.model.scene import Scene

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
