"""The split rounds' bookkeeping (actuator_design.contact_split): which rounds Anderson's mixing uses."""
import numpy as np

from actuator_design.contact_split import accelerated, extended


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
