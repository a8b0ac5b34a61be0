"""Past a pitchfork in the field of real coils and magnets, ``solve`` finds the buckled rod (issue 19).

A soft strip across a Helmholtz pair's axis and a hard strip facing a magnet's pole: the straight
rod is an equilibrium by symmetry, unstable past a pitchfork. The path from rest leaves it along
its unstable mode by a minimisation (:func:`actuator_design.reduced.descent.trust_region_descent`).
Before, that minimisation was quasi-Newton IPOPT, which ran out of iterations in the stiff field,
so the unstable straight rod came back as the answer; and a Newton finish from its capped iterate
chose the side of the pitchfork by the cap. Checked against things outside the solver: shooting in
magpylib's own field and the energy of the straight rod.
"""
import math

import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from actuator_design.config.model import load_config
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from field_references import shooting_tip

MU0 = 4e-7 * math.pi

ROD_SOFT = """
    length: 20 mm
    width: 5 mm
    thickness: 0.5 mm
    youngs_modulus: 1 MPa
  magnetics:
    particles: {material: carbonyl_iron, axis_ratio: 5, volume_fraction: 0.1}
    body_demagnetization: false
"""


def _helmholtz_scene(tmp_path, current):
    """Two 200-turn windings of 50 mm radius, their axis across the rod (90°), centred 10 mm along it."""
    text = ("scene:\n  type: physical\n  rod:" + ROD_SOFT +
            "  field:\n    type: coils\n    coils:\n      - kind: helmholtz\n        radius: 50 mm\n"
            f"        turns: 200\n        current: {current} A\n        position: {{x: 10 mm, y: 0 mm}}\n"
            "        axis_angle: 90 deg\n")
    path = tmp_path / f"helmholtz_{current}.yaml"
    path.write_text(text)
    return load_config(path).to_scene()


def _helmholtz_coils(current):
    axis = Rotation.from_euler("z", 0.5 * math.pi) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])
    return [magpy.current.Circle(diameter=0.1, current=200 * current, orientation=axis,
                                 position=(10e-3, z, 0)) for z in (-25e-3, 25e-3)]


def _pole_scene(tmp_path):
    """A hard strip (remanence 10 mT along it) facing the pole of a cylinder magnet on its axis."""
    text = """scene:
  type: physical
  rod: {length: 20 mm, width: 5 mm, thickness: 1 mm, youngs_modulus: 1 MPa}
  magnetics: {remanent_flux_density: 0.01 T}
  magnetization: 0 deg
  field:
    type: magnet
    shape: cylinder
    position: {x: 32 mm, y: 0 mm}
    axis_angle: 180 deg
    remanence: 0.4 T
    diameter: 10 mm
    height: 10 mm
"""
    path = tmp_path / "pole.yaml"
    path.write_text(text)
    return load_config(path).to_scene()


def _pole_magnet():
    axis = Rotation.from_euler("z", math.pi) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])
    return [magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 0.4 / MU0),
                                  position=(32e-3, 0, 0), orientation=axis)]


def _tip(res):
    return np.array([res.tip["x"], res.tip["y"], res.tip["angle"]])


@pytest.mark.parametrize("case", ["helmholtz", "pole"])
def test_past_the_pitchfork_the_buckled_rod_is_found_and_agrees_with_shooting(tmp_path, case):
    scene = _helmholtz_scene(tmp_path, 5) if case == "helmholtz" else _pole_scene(tmp_path)
    objs = _helmholtz_coils(5) if case == "helmholtz" else _pole_magnet()
    res = solve(scene)
    assert res.success and res.stable, res.message
    assert "left an unstable equilibrium" in res.message  # the straight rod was passed, not returned
    ours = _tip(res)
    assert ours[1] > 0.1  # buckled, to the side of the kick's convention (tip angle up)
    ref = shooting_tip(scene, objs, res)
    assert np.max(np.abs(ours - ref)) <= 1e-6, ours - ref
    # the straight rod is an equilibrium (shooting from it stays) of higher energy, and unstable
    straight = solve(scene, options=SolverOptions(start="straight"))
    assert abs(straight.tip["y"]) <= 1e-9 and not straight.stable
    assert straight.energy > res.energy


def test_the_branch_taken_does_not_depend_on_the_iteration_cap(tmp_path):
    """IPOPT's cap (quasi-Newton here) decided the branch before; the descent's own cap only
    decides whether it finished (tests/test_descent.py)."""
    scene = _helmholtz_scene(tmp_path, 5)
    tips = [_tip(solve(scene, options=SolverOptions(max_iter=m))) for m in (200, 250, 3000)]
    assert all(np.max(np.abs(t - tips[0])) <= 1e-9 for t in tips), tips


def test_a_sweep_over_the_current_stays_on_one_branch(tmp_path):
    """Above the pitchfork every current buckles the rod to the same side, more the more current."""
    ys = []
    for current in (4, 6, 10, 20):
        res = solve(_helmholtz_scene(tmp_path, current))
        assert res.success and res.stable, (current, res.message)
        ys.append(res.tip["y"])
    assert all(y > 0.1 for y in ys) and np.all(np.diff(ys) > 0), ys


def test_a_rod_pulled_next_to_a_magnet_beside_it_is_refused_naming_the_source(tmp_path):
    """A cylinder magnet 7 mm beside the rod's middle (its body 2 mm away): the fit's sphere about its
    centre, which holds the whole body, reaches over the rod. The rod drawn towards the magnet stays
    within that sphere: the solve fails, saying where and which source, and says nothing of
    stability."""
    text = """scene:
  type: physical
  rod: {length: 20 mm, width: 5 mm, thickness: 1 mm, youngs_modulus: 1 MPa}
  magnetics: {remanent_flux_density: 0.01 T}
  magnetization: 0 deg
  field: {type: magnet, shape: cylinder, position: {x: 10 mm, y: 7 mm}, axis_angle: 90 deg,
          remanence: 1.2 T, diameter: 10 mm, height: 10 mm}
"""
    path = tmp_path / "beside.yaml"
    path.write_text(text)
    scene = load_config(path).to_scene()
    s = np.linspace(0.0, 1.0, 401)
    rest = (s * math.cos(scene.theta0), s * math.sin(scene.theta0))
    t = scene.field.placed_terms()[0]
    assert np.min(np.hypot(rest[0] - t.centre[0], rest[1] - t.centre[1])) < t.valid_radius  # by hand
    res = solve(scene)
    assert not res.success and res.status == "outside_field_region"
    assert "the rod comes closer to source 1's centre" in res.message, res.message


def test_an_unstable_straight_rod_is_not_a_success_when_the_path_from_rest_stops(tmp_path, monkeypatch):
    """Were the path from rest to stop before the pitchfork's load (simulated), the straight-rod start
    gives the straight rod, unstable past the pitchfork (a lower, buckled state exists: shooting
    above): it is no answer, and not a success."""
    import actuator_design.equilibrium.acceptance as acceptance
    from actuator_design.continuation.from_rest import RestPath

    def stopped(solver, params, **kwargs):
        return RestPath(solver.initial_guess(params), False, 0.5, 3, 3)

    monkeypatch.setattr(acceptance, "path_from_rest", stopped)
    res = solve(_helmholtz_scene(tmp_path, 5))
    assert abs(res.tip["y"]) <= 1e-9 and not res.stable
    assert not res.success and res.status == "not_reached_from_rest", res.message
