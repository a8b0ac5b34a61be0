"""A stiffness target over the lab's tolerance box: the claim is what was computed.

``design --target-stiffness 10 --tolerance field=10%`` said the design "holds over the tolerance
box" although nothing was evaluated over the box for a stiffness target. Now the design's branch
is followed over the box and its stiffness taken at a 3 × 3 grid of points (corners, edge
midpoints, centre). The references here are independent of the design code's central
differences: THEORY §6's closed form s(h) of the straight rod in an axial field (exact at the
points with no angle offset: the design field is axial) and the package's ``stiffness`` analysis
(the implicit-function compliance of a fresh forward solve from rest) at every perturbed scene.
"""
import json
import math

import pytest

from actuator_design.inverse.design import DesignSettings, design
from actuator_design.analysis.stiffness import tip_stiffness
from actuator_design.equilibrium.pipeline import solve
from actuator_design.physics import parameters as lens
from actuator_design.robust.design_stiffness_box import stiffness_over_box
from actuator_design.robust.tolerances import Tolerances, parse_tolerances, perturb
from actuator_design.cli.main import main
from actuator_design.reference.closed_forms import lowload_stiffness
from actuator_design.model.scene import default_scene

from result_invariants import design_contradictions

BOX = parse_tolerances("field=10%")  # the angle keeps its default ±2 deg


@pytest.fixture(scope="module")
def result():
    return design(None, scene=default_scene(h=0.0), stiffness=10.0, settings=DesignSettings(tolerances=BOX))


def test_the_stiffness_over_the_box_is_computed_and_matches_independent_references(result):
    rob = result.to_dict()["robustness"]
    assert rob is not None, "the box was not evaluated"
    box = rob["stiffness_over_box"]
    assert len(box["points"]) == 9 and box["complete"]
    scene = result.design_scene
    assert abs(math.sin(scene.phi)) < 1e-9  # the design field is axial: s(h) applies at angle offset 0
    values = []
    for pt in box["points"]:
        assert pt["reached"]
        at = perturb(scene, BOX, pt["offset"])
        independent = tip_stiffness(at).vertical  # a forward solve from rest + its sensitivity
        assert independent == pytest.approx(pt["stiffness"], rel=1e-6)
        if pt["offset"].get("angle", 0.0) == 0.0:
            assert float(lowload_stiffness(at.h)) == pytest.approx(pt["stiffness"], rel=1e-6)
        values.append(independent)
    assert box["min"] == pytest.approx(min(values), rel=1e-6)
    assert box["max"] == pytest.approx(max(values), rel=1e-6)
    assert box["worst_rel_error"] == pytest.approx(max(abs(v / 10.0 - 1.0) for v in values), rel=1e-5)
    # ±10 % of field moves s(h) by several per cent: the box is not a point
    assert box["worst_rel_error"] > 0.02
    # the angle's extreme lies at the edge midpoint (angle offset 0), not at a corner: s is even in
    # the field angle about the axial design
    k_mid = [p["stiffness"] for p in box["points"] if p["offset"] == {"field_rel": 1.0, "angle": 0.0}][0]
    k_corner = [p["stiffness"] for p in box["points"] if p["offset"] == {"field_rel": 1.0, "angle": 1.0}][0]
    assert k_mid != pytest.approx(k_corner, rel=1e-9)


def test_holds_is_claimed_only_with_what_holds_means(result):
    d = result.to_dict()
    rob = d["robustness"]
    assert rob["holds"] == (rob["stable_over_box"] and rob["stiffness_over_box"]["complete"])
    assert d["success"] == rob["holds"]
    assert not design_contradictions(d)


def test_the_cli_text_and_json_state_the_stiffness_over_the_box(capsys):
    code = main(["design", "--target-stiffness", "10", "--tolerance", "field=10%", "--json"])
    d = json.loads(capsys.readouterr().out)
    box = d["robustness"]["stiffness_over_box"]
    assert code == (0 if d["success"] else 4)
    code = main(["design", "--target-stiffness", "10", "--tolerance", "field=10%"])
    text = capsys.readouterr().out
    line = [ln for ln in text.splitlines() if ln.strip().startswith("robustness")][0]
    assert f"{box['min']:.4g} to {box['max']:.4g} B0/l^3" in line
    if "SUCCESS" in text:
        assert "holds over the box" in line and d["robustness"]["holds"]


def test_a_tolerance_box_not_checked_is_never_a_success(monkeypatch):
    """The guard behind the claim: were the box skipped for any reason, the result says so and is
    not a success (the stage is replaced by one that evaluates nothing)."""
    from actuator_design.inverse import design as design_module

    monkeypatch.setattr(design_module, "robust_stage", lambda problem, choice, follow=None: (choice, None, None))
    res = design(None, scene=default_scene(h=0.0), stiffness=10.0, settings=DesignSettings(tolerances=BOX))
    assert res.verified and not res.success
    assert "not checked over the tolerance box" in res.message
    assert res.to_dict()["status"] == "not_accepted"


def test_a_youngs_modulus_tolerance_gives_the_stiffness_in_the_nominal_units():
    # a scene with E moved is solved in its own units (b = 1, h and loads rescaled): its stiffness,
    # in B'/l^3, is brought back to B0/l^3. Closed form (THEORY §6): the straight rod in an axial
    # field h has s(h) B/l^3, and E·(1 + d) turns h into h/sqrt(1 + d), B into B(1 + d)
    scene = lens.parameter("p").require(default_scene(h=2.0))
    r = solve(scene)
    box = stiffness_over_box(scene, r.z, Tolerances(field_rel=0.0, angle=0.0, youngs_rel=0.1), r.options, 10.0)
    assert len(box.points) == 3 and box.complete
    for pt in box.points:
        d = 0.1 * pt["offset"]["youngs_rel"]
        assert pt["stiffness"] == pytest.approx((1 + d) * float(lowload_stiffness(2.0 / math.sqrt(1 + d))), rel=1e-6)
