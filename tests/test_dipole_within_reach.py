"""A point dipole within the rod's reach: its field grows as 1/ρ³ and nothing stops the rod, so a
rod drawn towards it has no equilibrium. A failed solve whose shape came close to it says so (and
how close); a dipole beyond the reach, a shape that stayed away or a solve that succeeds adds
nothing (nor does a scene with obstacles: one may stand where the magnet is)."""
import math

import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import DIPOLE_CLOSE, DipoleField, Scene


def test_a_rod_pulled_onto_a_dipole_within_its_reach_says_why():
    r = solve(Scene(field=DipoleField(x0=0.5, y0=-0.8), h=1.0))
    assert not r.success and r.status != "converged"
    d = r.evaluate(np.linspace(0.0, 1.0, 401))
    closest = float(np.min(np.hypot(d["x"] - 0.5, d["y"] + 0.8)))
    if closest < DIPOLE_CLOSE:  # (where IPOPT's failed iterate ends depends on the machine)
        assert "the point dipole at (0.5, -0.8) lies within the rod's reach (0.9434 < 1 rod length" in r.message
        said = float(r.message.split("the shape reported comes within ")[1].split(" of it")[0])
        assert abs(said - closest) <= 5e-3 * closest  # (printed to 3 digits)
    else:
        assert "lies within the rod's reach" not in r.message


def test_no_note_beyond_the_reach_far_from_it_or_on_success():
    weak = solve(Scene(field=DipoleField(), h=0.01))  # within reach, but too weak to pull the rod in
    assert weak.success and "reach" not in weak.message
    capped = solve(Scene(field=DipoleField(), h=0.04), SolverOptions(max_iter=1))  # fails on the cap, far from it
    assert not capped.success and "reach" not in capped.message
    far = DipoleField(x0=0.5, y0=-1.2)
    assert math.hypot(far.x0, far.y0) > 1.0
    s = np.linspace(0.0, 1.0, 5)
    assert far.failure_note(0.5 + 0.0 * s, -1.2 + 0.0 * s) is None  # (a shape on the dipole, but out of reach)
    near = DipoleField()
    assert near.failure_note(np.array([0.5]), np.array([-0.45])) is not None
    assert near.failure_note(np.array([np.nan]), np.array([0.0])) is None


def test_validate_says_so_before_any_solve(tmp_path, capsys):
    import json

    from actuator_design.cli.main import main

    def notes(y0):
        path = tmp_path / f"dipole{y0}.yaml"
        path.write_text("scene:\n  type: dimensionless\n  field: {type: dipole, position: {x: 0.5, y: %s}}\n"
                        "  h: 1.0\n" % y0)
        assert main(["validate", str(path), "--json"]) == 0
        return json.loads(capsys.readouterr().out)["notes"]
    assert any("lies within the rod's reach (0.9434 < 1 rod length" in n for n in notes(-0.8))
    assert not any("reach" in n for n in notes(-1.2))
    assert DipoleField(x0=0.5, y0=-1.2).reach_note() is None
