"""The applied field is one field (THEORY §5, §9, §11): every group it drives (h, h_pos, h_r) is
fixed by the field, at zero field too, and the field a result reports is the one its groups stand for.

A physical scene carries each group per unit field (``Scales.per_field``). References: the same
YAML written at the other field (the config converts it from scratch), μ0 H by hand, and the
particles' saturation field given in the YAML (configs/micro_rod.yaml: 400 kA/m)."""
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from actuator_design.cli.main import main
from actuator_design.config import load_scene
from actuator_design.continuation.loading import follow_path
from actuator_design.equilibrium.pipeline import solve
from actuator_design.inverse.design import DesignSettings, design
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import UniformField, default_scene
from actuator_design.physics import parameters as lens
from actuator_design.robust.tolerances import parse_tolerances
from actuator_design.schedules.schedule import field_schedule

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
MU0 = 4e-7 * math.pi
SOFT_HARD = """scene:
  type: physical
  rod: {{length: 20 mm, width: 5 mm, thickness: 1 mm, youngs_modulus: 1 MPa}}
  magnetics: {{chi_bar: 0.2, chi_hat: 0, remanent_flux_density: 0.01 T}}
  magnetization: 0 deg
  field: {{type: uniform, magnitude: {mT} mT, angle: {deg} deg}}
"""


def soft_hard(tmp_path, mT, deg=90.0):
    path = tmp_path / f"rod_{mT}_{deg}.yaml"
    path.write_text(SOFT_HARD.format(mT=mT, deg=deg))
    return path


def _solve_json(capsys, *argv):
    assert main(["solve", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_a_field_set_on_a_scene_at_zero_field_moves_every_group(tmp_path, capsys):
    at_zero, at_ten = soft_hard(tmp_path, 0), soft_hard(tmp_path, 10)
    ref = _solve_json(capsys, str(at_ten))
    h10 = ref["groups"]["h"]  # the same field as a plain group value (--h, --set h=...): still the field
    for argv in ([str(at_zero), "--set", "h=10 mT"], [str(at_ten), "--set", "h=0 mT", "--set", "h=10 mT"],
                 [str(at_zero), "--set", "h_r=10 mT"], [str(at_zero), "--set", f"h={h10!r}"],
                 [str(at_zero), "--h", repr(h10)]):
        got = _solve_json(capsys, *argv)
        assert got["groups"]["h"] == pytest.approx(ref["groups"]["h"], rel=1e-12), argv
        assert got["groups"]["h_r"] == pytest.approx(ref["groups"]["h_r"], rel=1e-12), argv
        assert (got["tip"]["x"], got["tip"]["y"]) == pytest.approx((ref["tip"]["x"], ref["tip"]["y"]), abs=1e-10)
        assert got["physical"]["field_A_per_m"] == pytest.approx(10e-3 / MU0, rel=1e-12)  # the field set
        assert got["physical"]["field_mT"] == pytest.approx(10.0, rel=1e-12)


def test_a_design_from_a_scene_at_zero_field_moves_the_remanent_group_with_the_field(tmp_path):
    """The user leaves the field at 0 for the design to find: the designed field must carry h_r
    (∝ H) with it. Reference: the tip of the same rod's YAML at 40 mT and 60 deg."""
    made = solve(load_scene(soft_hard(tmp_path, 40, 60))[0])
    base = load_scene(soft_hard(tmp_path, 0, 60))[0]
    res = design((made.tip["x"], made.tip["y"]), base,  # the default variables: h, phi, then beta(s)
                 settings=DesignSettings(ramp_steps=6, tolerances=parse_tolerances("none")))
    assert res.success and res.vary == ("h", "phi"), res.message
    H = res.design["h"] / base.scales.h_per_field
    assert MU0 * H * 1e3 == pytest.approx(40.0, rel=1e-6)
    assert res.design["h_r"] == pytest.approx(dict(base.scales.per_field)["h_r"] * H, rel=1e-9)


def test_the_particles_saturation_bounds_the_design_and_is_warned_of(capsys):
    """Beyond the particles' saturation field the linear magnetisation overestimates the coupling
    (THEORY §11): a design stays below it (here the target needs more, so it is out of reach) and
    a field set beyond it is warned of, as the same field in the YAML is."""
    base = load_scene(CONFIGS / "micro_rod.yaml")[0]
    assert base.scales.field_limit == pytest.approx(400e3, rel=1e-12)  # saturation_field, uniform field
    res = design((0.3658522348, 0.9066888556), base, vary=("h", "phi"),
                 settings=DesignSettings(h_max=40.0, ramp_steps=6, tolerances=parse_tolerances("none")))
    assert not res.success and not res.reachable
    assert res.design["h"] / base.scales.h_per_field <= 400e3 * (1 + 1e-9)
    assert "linear magnetisation holds" in res.message
    assert main(["solve", str(CONFIGS / "micro_rod.yaml"), "--set", "h=1500 kA/m"]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "beyond 4e+05 A/m" in err
    assert lens.beyond_model(base) is None  # the YAML's own 50 mT is within


@pytest.mark.parametrize("value, message", [
    ("h=-2 mT", "--set h: the applied field must be >= 0, got '-2 mT'"),
    ("h=1e9 mT", "--set h: the field 1e9 mT gives h = "),
])
def test_a_field_out_of_range_is_one_line_naming_the_flag(tmp_path, capsys, value, message):
    assert main(["solve", str(soft_hard(tmp_path, 10)), "--set", value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_a_loading_path_from_zero_field_ramps_every_group_with_the_field(tmp_path):
    """A ramp of h from a scene at zero field (the ratio h_r/h is 0/0 there) follows the groups
    per unit field: its end is the rod at that field. Reference: the YAML written at 10 mT."""
    base = load_scene(soft_hard(tmp_path, 0))[0]
    ref = solve(load_scene(soft_hard(tmp_path, 10))[0])
    h10 = base.scales.h_per_field * 10e-3 / MU0
    path = follow_path(base, None, {"h": [0.0, h10]})
    assert path.success and path.final.scene.h_r == pytest.approx(ref.scene.h_r, rel=1e-12)
    assert (path.final.tip["x"], path.final.tip["y"]) == pytest.approx((ref.tip["x"], ref.tip["y"]), abs=1e-8)


def test_a_rod_without_soft_coupling_at_zero_field_has_no_field_to_design(tmp_path):
    """A hard-magnetic rod (χ̄ = 0) at zero field: its field acts through h_r alone at the scene's
    magnitude, which is 0 — there is nothing to design, and no soft coupling to invent."""
    path = tmp_path / "hard0.yaml"
    path.write_text(SOFT_HARD.format(mT=0, deg=90).replace("chi_bar: 0.2", "chi_bar: 0"))
    base = load_scene(path)[0]
    for vary in (None, ("h", "phi")):
        with pytest.raises(ValueError, match="field is 0 and this rod has no soft-magnetic coupling"):
            design((0.7, 0.6), base, vary=vary, settings=DesignSettings(tolerances=parse_tolerances("none")))


DIPOLE_FAR = """scene:
  type: physical
  rod: {length: 20 mm, width: 5 mm, thickness: 1 mm, youngs_modulus: 1 MPa}
  magnetics:
    particles: {axis_ratio: 4, chi_par: 1000, chi_perp: 1000, volume_fraction: 0.02, saturation_field: 100 kA/m}
  field: {type: dipole, moment: 0.05 A m^2, position: {x: 30 mm, y: -12 mm}, moment_angle: 0 deg}
solver: {transcription: lgl, elements: 8, degree: 10}
"""


def test_the_saturation_check_sees_the_field_on_the_bent_rod(tmp_path):
    """Near a magnet the bent rod meets a stronger field than the straight one. Reference: the
    point dipole's field |ĥ| = |3(m·r)r/r⁵ − m/r³| on the solved shape, by hand."""
    path = tmp_path / "dipole.yaml"
    path.write_text(DIPOLE_FAR)
    base = load_scene(path)[0]
    f = base.field
    x0, y0 = f.x0, f.y0

    def shape_max(x, y):
        rx, ry = np.asarray(x) - x0, np.asarray(y) - y0
        r = np.hypot(rx, ry)
        mx, my = math.cos(f.moment_angle), math.sin(f.moment_angle)
        md = (mx * rx + my * ry) / r
        return float(np.max(np.hypot((3 * md * rx / r - mx) / r**3, (3 * md * ry / r - my) / r**3)))

    straight = shape_max(np.linspace(0, 1, 201), np.zeros(201))
    H = 0.9 * base.scales.field_limit / straight  # within the limit on the straight rod
    sc = lens.set_field(base, H)
    r = solve(sc)
    assert r.success and lens.beyond_model(sc) is None
    bent = r.evaluate(np.linspace(0, 1, 201))
    assert H * shape_max(bent["x"], bent["y"]) > base.scales.field_limit  # the bent rod goes beyond it
    assert lens.beyond_model(sc, bent["x"], bent["y"]) is not None


def test_a_schedule_of_a_soft_and_hard_rod_moves_h_r_with_h_at_every_point():
    """The first waypoint's rows name h_r (∝ H like h); every later row must too, at the same
    ratio (before, the rows disagreed and the schedule was refused as malformed). Reference: the
    independent loading path through the rows reaches each waypoint (``verified``) and the ratio is
    the scene's own h_r/h."""
    sc = replace(default_scene(h=0.8), field=UniformField(phi=2.0), h_r=1.5, magnetization=constant_profile(0.4))
    res = field_schedule([(0.9, 0.4), (0.89, 0.42)], sc)
    assert res.success and res.verified, res.message
    for row in res.schedule[1:]:
        assert row["h_r"] == pytest.approx(row["h"] * 1.5 / 0.8, rel=1e-9)
