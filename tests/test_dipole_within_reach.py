"""A point dipole within the rod's reach: its field grows as 1/ρ³ and nothing stops the rod, so a
rod drawn towards it has no equilibrium. A failed solve says so (and how close the shape it
reports came); a dipole beyond the reach, or a solve that succeeds, adds nothing."""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import DipoleField, Scene


def test_a_rod_pulled_onto_a_dipole_within_its_reach_says_why():
    r = solve(Scene(field=DipoleField(x0=0.5, y0=-0.8), h=1.0))
    assert not r.success and r.status != "converged"
    assert "the point dipole at (0.5, -0.8) lies within the rod's reach (0.9434 < 1 rod length" in r.message, r.message
    d = r.evaluate(np.linspace(0.0, 1.0, 4001))
    closest = float(np.min(np.hypot(d["x"] - 0.5, d["y"] + 0.8)))
    said = float(r.message.split("the shape reported comes within ")[1].split(" of it")[0])
    assert said == pytest.approx(closest, rel=1e-2, abs=1e-4)
    assert closest < 0.05  # the reported shape was drawn onto the dipole


def test_no_note_beyond_the_reach_or_on_success():
    weak = solve(Scene(field=DipoleField(), h=0.01))  # within reach, but too weak to pull the rod in
    assert weak.success and "reach" not in weak.message
    far = DipoleField(x0=0.5, y0=-1.2)
    assert math.hypot(far.x0, far.y0) > 1.0
    assert far.failure_note(np.linspace(0, 1, 5), np.zeros(5)) is None
    assert "comes within" not in DipoleField().failure_note(np.array([np.nan]), np.array([0.0]))
