"""Continuing in the field magnitude h moves h alone (the lens's group), and says so when the scene
has other groups the field drives (h_r, h_pos in a non-uniform field: ∝ H too, THEORY §5, §9),
since such a branch is not a change of the applied field; a loading path in h moves them all.
References: the branch's end state against an independent forward solve with h_r kept, and the
path's end scene against the field rule h_r/h = const."""
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.continuation.follow import continue_branch
from actuator_design.continuation.loading import follow_path
from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import default_scene

SOFT_HARD = replace(default_scene(h=0.8, phi=2.0), h_r=1.5, magnetization=constant_profile(0.4))


def test_a_branch_in_h_keeps_h_r_and_says_so():
    res = continue_branch(SOFT_HARD, "h", 0.8, 1.2)
    assert len(res.notes) == 1 and "h_r = 1.5" in res.notes[0] and "stays fixed" in res.notes[0]
    assert res.to_dict()["notes"] == res.notes
    end = solve(replace(SOFT_HARD, h=1.2))  # h_r kept at 1.5, as the note says
    assert res.branch.lam[-1] == pytest.approx(1.2, abs=1e-12)
    tip = res.branch.tips[-1]  # (angle, x, y)
    assert np.allclose(tip, [end.tip["angle"], end.tip["x"], end.tip["y"]], atol=1e-8)
    path = follow_path(SOFT_HARD, None, {"h": [0.8, 1.2]})  # ... and the loading path moves h_r with h
    assert path.final.scene.h_r == pytest.approx(1.5 * 1.2 / 0.8, rel=1e-12)


@pytest.mark.parametrize("scene, param", [
    (default_scene(h=1.0, phi=1.0), "h"),  # no other field group
    (replace(default_scene(h=1.0, phi=1.0), h_pos=0.5), "h"),  # h_pos is a constant in a uniform field
    (SOFT_HARD, "p"),  # not the field magnitude
])
def test_no_note_where_nothing_else_moves_with_the_field(scene, param):
    assert continue_branch(scene, param, scene.h if param == "h" else 0.0, 1.2).notes == []
