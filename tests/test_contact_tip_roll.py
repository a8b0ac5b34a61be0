"""A rod pushed up against a peg near its tip (issue 20): the contact starts at the tip, and as the
load grows the rod rolls onto the peg, the contact moving a fraction of a millimetre onto the body
while the tip lifts free. Before, every state past the roll was refused as inaccurate (the shape
entered the peg between the constrained points, at any number of elements) and a loading path
stopped there; the touch-down of a rod bending past the peg was not located.

References (tests/contact_references.py, nothing of the package's transcription): the elastica
pressed at one interior point against the peg, by shooting with the contact point, the reaction
and its direction as unknowns; the free elastica's load at which it first touches the peg.
"""
import math

import numpy as np
import pytest
from contact_references import peg_reference, tip_slip_load, touch_load

from actuator_design.contact.path import follow_contact_path
from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Peg
from actuator_design.model.scene import Scene

CENTRE, RADIUS = np.array([0.97, 0.22]), 0.05


def _scene(p: float) -> Scene:
    return Scene(field=None, tip_force=(0.0, p), obstacles=(Peg(tuple(CENTRE), RADIUS),))


def _check_against_shooting(r, p: float):
    big = [q for q in r.contact["points"] if not q["weak"] and q["multiplier"] > 1e-3 * p]
    assert len(big) == 1 and 0.99 < big[0]["s"] < 1.0, r.contact["points"]
    F = np.array(r.contact["total_force"])
    guess = [r.evaluate(np.array([0.0]))["dtheta"][0], big[0]["s"], np.hypot(*F), math.atan2(F[1], F[0])]
    (_, s_c, R, _), end, nu = peg_reference(np.array([0.0, p]), CENTRE, RADIUS, guess)
    assert abs(r.tip["x"] - end[2]) <= 1e-6 and abs(r.tip["y"] - end[3]) <= 1e-6
    assert abs(r.tip["angle"] - end[0]) <= 1e-6
    assert np.max(np.abs(F - R * nu)) <= 1e-4 and abs(big[0]["s"] - s_c) <= 1e-4
    # the tip itself is off the peg
    assert math.hypot(r.tip["x"] - CENTRE[0], r.tip["y"] - CENTRE[1]) - RADIUS > 1e-9


@pytest.mark.parametrize("p", [20.0, 100.0])
def test_a_rod_rolled_onto_a_peg_near_its_tip_against_shooting(p):
    r = solve(_scene(p))
    assert r.success and r.stable and r.morse_index == 0, r.message
    _check_against_shooting(r, p)


def test_a_loading_path_locates_the_touch_down_and_follows_the_roll():
    """p from 0 to 16: the free rod bends past the peg (the gap is positive at both ends of the
    first step), touches it with its tip, and rolls onto it at p ≈ 12.7."""
    path = follow_contact_path(_scene(0.0), schedule={"p": [0.0, 16.0]})
    assert path.success and not path.jumps, path.message
    assert all(pt.stable for pt in path.points)
    # one smooth branch: its lowest eigenvalue has no jump where the contact leaves the tip (two
    # nodes 1e-5 apart both counted as contacts kept the rod from rolling: 22.8 jumped to 57.9)
    lam = np.array([pt.min_eigenvalue for pt in path.points if pt.param >= 2.0])
    assert np.max(np.abs(np.diff(lam)) / lam[1:]) < 0.02, lam
    (event,) = path.contact_events
    assert event["kind"] == "touch-down" and event["located"] and event["s"] == pytest.approx(1.0, abs=1e-9)
    assert event["param"] == pytest.approx(touch_load((0.0, 1.0), CENTRE, RADIUS, 0.1, 0.6), abs=1e-6)
    _check_against_shooting(path.final, 16.0)


def test_a_tip_sliding_off_a_peg_snaps_at_the_fold_of_the_contact_branch():
    """Pressed down on the flank of a peg beside it, the tip slides down the flank as the load
    grows, until the contact branch folds and the rod snaps past the peg: a jump of kind "contact"
    located like a fold (the branch's end, to 1e-9 in the load), its lowest eigenvalue at zero there.
    Reference: the shooting branch of tip-on-peg states, the extreme of the load along it."""
    centre, radius = np.array([1.09, -0.05]), 0.1
    scene = Scene(field=None, tip_force=(0.0, 0.0), obstacles=(Peg(tuple(centre), radius),))
    path = follow_contact_path(scene, schedule={"p": [0.0, -10.0]})
    assert path.success and len(path.jumps) == 1, path.message
    jump = path.jumps[0]
    before, after = jump.from_state, jump.to_state
    assert jump.kind == "contact" and [q["s"] for q in before.contact["points"]] == [1.0]
    assert not after.contact["points"] and after.tip["y"] < centre[1] - radius  # past the peg, below it
    assert 0.0 < before.eigenvalues[0] <= 1e-3 * before.eigenvalues[1]  # at the fold
    psi = math.atan2(before.tip["y"] - centre[1], before.tip["x"] - centre[0])
    F = np.array(before.contact["total_force"])
    guess = [before.evaluate(np.array([0.0]))["dtheta"][0], np.hypot(*F), jump.param]
    assert jump.param == pytest.approx(tip_slip_load(centre, radius, psi, guess), abs=1e-6)
    assert jump.energy_released > 0
