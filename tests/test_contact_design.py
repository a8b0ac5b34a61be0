"""Design with contact, the gripper case (issue 20 item 5): the field at which a strip loaded from
rest presses a floor with a given force, against the elastica shot with its tip on the floor (the
reference's own Runge–Kutta; the floor's reaction and the field its unknowns), verified from rest
and judged over the lab's tolerance box."""
import math
from pathlib import Path

import pytest
from scipy.optimize import brentq

from actuator_design.contact.design import design_contact_force
from actuator_design.config.model import load_scene
from actuator_design.reference.shooting import ShootingParams, solve_shooting
from actuator_design.robust.tolerances import Tolerances

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "contact_tip_on_floor.yaml"


def _reference_field(force, phi, tip_y, gamma_guess, bracket):
    """h at which the elastica with the floor's reaction ``force`` on its tip has its tip at
    ``tip_y`` (shooting; the branch of the design state through ``gamma_guess``)."""
    def miss(h):
        sol = solve_shooting(ShootingParams(h=h, phi=phi, fy=force), gamma_guess=gamma_guess)
        assert sol.converged
        return sol.tip_y - tip_y

    return brentq(miss, *bracket, xtol=1e-14)


def test_the_field_that_presses_a_floor_with_a_given_force():
    scene, options, _ = load_scene(CONFIG)
    d = design_contact_force(scene, 0.5, h_max=3.0)
    assert d.success and d.verified and d.holds_over_box, d.message
    assert abs(d.force - 0.5) <= 1e-8 and abs(d.verification_force - 0.5) <= 1e-6
    tip_y = -0.15 + scene.contact_gap  # the floor 3 mm below a 20 mm rod, the surface touching
    h_ref = _reference_field(0.5, scene.phi, tip_y, d.state.gamma, (0.9 * d.h, 1.1 * d.h))
    assert abs(d.h - h_ref) <= 1e-6
    lo, hi = d.box_force_range
    assert lo < 0.5 < hi and len(d.box) == 4
    assert d.to_dict()["physical"]["force_N"] == pytest.approx(0.5 * scene.scales.force)


def test_the_force_over_the_box_is_in_the_nominal_units_with_youngs_modulus_moved():
    # E and the susceptibility moved together by the same fraction leave every dimensionless group
    # as it is (h^2 ∝ χ/E): the rod takes the same shape, and every force, the floor's too, scales
    # with E (THEORY §5: forces in units of B0/l^2, B0 ∝ E)
    scene, _, _ = load_scene(CONFIG)
    d = design_contact_force(scene, 0.5, h_max=3.0,
                             tolerances=Tolerances(field_rel=0.0, angle=0.0, youngs_rel=0.1, chi_rel=0.1))
    assert d.success, d.message
    same = [c for c in d.box if c["deltas"]["youngs_rel"] == c["deltas"]["chi_rel"]]
    assert len(same) == 2
    for corner in same:
        assert corner["force"] == pytest.approx(0.5 * (1 + corner["deltas"]["youngs_rel"]), rel=1e-6)


def test_an_unreachable_force_says_how_far_the_path_got():
    scene, _, _ = load_scene(CONFIG)
    d = design_contact_force(scene, 50.0, h_max=1.5)
    assert not d.success and d.status == "unreachable"
    assert "largest force" in d.message and "h = 1.5" in d.message


@pytest.mark.parametrize("kwargs, words", [({"force": -1.0}, "force"), ({"force": math.nan}, "force"),
                                           ({"force": 1.0, "obstacle": 3}, "obstacle"),
                                           ({"force": 1.0, "h_max": 0.0}, "h_max")])
def test_bad_requests_name_the_argument(kwargs, words):
    scene, _, _ = load_scene(CONFIG)
    with pytest.raises(ValueError, match=words):
        design_contact_force(scene, **kwargs)


def test_the_cli_designs_a_force_in_newtons(tmp_path, capsys):
    """`design --target-force '50 uN'` on the floor config: the printed force and the JSON in N and
    mT, the state written; the field it reports presses with 50 uN in a forward solve from rest."""
    import json

    from actuator_design.cli.main import main
    from actuator_design.equilibrium.pipeline import solve

    out = tmp_path / "out"
    assert main(["design", str(CONFIG), "--target-force", "50 uN", "--json", "--out", str(out)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["success"] and d["physical"]["force_N"] == pytest.approx(50e-6, rel=1e-8)
    assert {p.name for p in out.iterdir()} == {"design.json", "shape.csv", "shape.png"}
    scene, _, _ = load_scene(CONFIG)
    check = solve(scene.with_values(h=d["h"]))
    f = check.contact["points"][0]["force_N"]
    assert math.hypot(*f) == pytest.approx(50e-6, rel=1e-6)
    assert d["physical"]["field_mT"] == pytest.approx(15.0 * d["h"] / scene.h, rel=1e-12)  # h ∝ H


@pytest.mark.parametrize("argv, code, words", [
    (["--target-force", "1"], 2, "no obstacles"),
    ([str(CONFIG), "--target-force", "-1"], 2, "> 0"),
    ([str(CONFIG), "--target-force", "2 m"], 2, "expected a force"),
    ([str(CONFIG), "--target-force", "1", "--target-tip", "0.5,0.5"], 2, "alone"),
    ([str(CONFIG), "--target-force", "1e-5", "--obstacle", "2"], 2, "--obstacle"),
    ([str(CONFIG), "--target-force", "5 mN", "--h-max", "2"], 4, None),
])
def test_the_cli_force_design_refuses_and_fails_in_one_line(argv, code, words, capsys):
    from actuator_design.cli.main import main

    assert main(["design", *argv]) == code
    cap = capsys.readouterr()
    if words is not None:
        err = cap.err.strip().splitlines()
        assert len(err) == 1 and words in err[0]
    else:
        assert "UNREACHABLE" in cap.out and "largest force" in cap.out
