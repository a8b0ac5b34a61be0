"""Design variables have physics (issue 17): on a strip of isotropic particles the easy axis is the
rod's tangent (THEORY §10), so a fibre layout, constant or varying, changes nothing and is never
designed."""
import json

import pytest
import yaml

from actuator_design.inverse.design import design_problem
from actuator_design.cli.main import main
from actuator_design.config.model import load_config
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions

STRIP = {"type": "physical",
         "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm", "youngs_modulus": "1 MPa"},
         "magnetics": {"particles": {"material": "carbonyl_iron", "volume_fraction": 0.1}},
         "field": {"type": "uniform", "magnitude": "60 mT", "angle": "60 deg"}}
VARYING = {"type": "expression", "expression": "0.8*sin(pi*s/2)"}


def strip(**extra):
    return load_config({"scene": {**STRIP, **extra}}).to_scene()


@pytest.mark.parametrize("fibres", [None, "30 deg", VARYING])
def test_a_fibre_layout_on_iron_spheres_changes_nothing(fibres):
    """The tip with any layout equals the tip without one (the body's axis, the tangent, rules)."""
    bare = strip()
    sc = strip(**({} if fibres is None else {"fibres": fibres}))
    assert not sc.fibres_physical and sc.h == pytest.approx(bare.h, rel=1e-14)
    a, b = solve(bare, SolverOptions()), solve(sc, SolverOptions())
    assert a.success and b.success
    assert abs(a.tip["x"] - b.tip["x"]) < 1e-12 and abs(a.tip["y"] - b.tip["y"]) < 1e-12
    assert abs(a.tip["y"]) > 1e-3  # and the strip does bend (THEORY §10)


def test_the_automatic_design_leaves_the_fibre_layout_out():
    problem = design_problem((0.6, 0.6), strip(fibres=VARYING), None, None, None, None, 0.0)
    assert problem.variable_sets == (("h", "phi"),) and not problem.fibres_fixed


def test_varying_alpha_on_iron_spheres_is_one_clear_error(tmp_path, capsys):
    cfg = tmp_path / "strip.yaml"
    cfg.write_text(yaml.safe_dump({"scene": STRIP}))
    out = tmp_path / "out"
    assert main(["design", str(cfg), "--target-tip", "0.6,0.6", "--vary", "h,phi,alpha",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--vary alpha" in err[0] and "no effect" in err[0]
    assert not out.exists()


def test_validate_says_the_layout_has_no_effect(tmp_path, capsys):
    cfg = tmp_path / "strip.yaml"
    cfg.write_text(yaml.safe_dump({"scene": {**STRIP, "fibres": VARYING}}))
    assert main(["validate", "--json", str(cfg)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert any("fibre layout has no effect" in n for n in d["notes"])
