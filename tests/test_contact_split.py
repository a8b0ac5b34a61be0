"""The split rounds' bookkeeping (actuator_design.contact.split): which rounds Anderson's mixing uses."""
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
    import math

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
