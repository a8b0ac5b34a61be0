"""Inverse design with obstacles (issue 20 item 5): a tip target in a guide channel, the rod kept
clear of both walls at the design, over the tolerance box and along its schedule from zero field.

The references are independent of the design NLP and of :mod:`actuator_design.contact.clearance`: the
designed field and fibre layout are re-solved by scipy's ``solve_bvp`` (the contact-free
Euler–Lagrange BVP: a design that keeps clear of the walls has no contact force), and the clearance is measured
directly against the walls' lines, given in millimetres in the config.
"""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from actuator_design.inverse.design import design
from actuator_design.config.model import load_scene

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "contact_channel_design.yaml"
L_MM = 20.0  # rod length in the config
#: the centre line's admissible band: the walls (centre 2.4 mm, width 8 mm) less half the thickness
Y_LO, Y_HI = (2.4 - 4.0 + 0.25) / L_MM, (2.4 + 4.0 - 0.25) / L_MM
TARGET = (17.0 / L_MM, 3.0 / L_MM)
S = np.linspace(0.0, 1.0, 2001)


@pytest.fixture(scope="module")
def channel():
    scene, options, _ = load_scene(CONFIG)
    return scene, options, design(TARGET, scene=scene, options=options)


def test_the_channel_design_is_verified_from_rest_and_keeps_clear_all_the_way(channel):
    scene, _, r = channel
    assert r.success, r.message
    assert r.robustness is not None and r.robustness.holds
    # every state of the verified loading path from zero field lies inside the walls' band
    assert r.path is not None and len(r.path.states) > 5
    for st in r.path.states:
        y = st.evaluate(S)["y"]
        assert Y_LO - 1e-6 <= y.min() and y.max() <= Y_HI + 1e-6
    assert r.path.final.tip["x"] == pytest.approx(TARGET[0], abs=1e-6)
    assert r.path.final.tip["y"] == pytest.approx(TARGET[1], abs=1e-6)


def test_a_bvp_solve_at_the_designed_field_reaches_the_target_inside_the_channel(channel):
    """scipy's solve_bvp on θ'' = h² sin 2(θ + α − φ), x' = cos θ, y' = sin θ with θ(0) = x(0) = y(0)
    = 0, θ'(1) = 0 (THEORY §5; the χ̂ term is constant in a uniform field). Shooting is no
    reference here: at h = 10 the clamp layer amplifies an error in θ'(0) by ~e^(√2 h)."""
    from scipy.integrate import solve_bvp

    _, _, r = channel
    sc, final = r.design_scene, r.path.final
    assert sc.h_r == 0.0 and sc.tip_force is None and not sc.extra_terms

    def rhs(s, Y):
        return np.vstack([Y[1], sc.h ** 2 * np.sin(2 * (Y[0] + sc.fibres(s) - sc.phi)), np.cos(Y[0]), np.sin(Y[0])])

    def bc(a, b):
        return np.array([a[0], b[1], a[2], a[3]])

    mesh = np.linspace(0.0, 1.0, 81) ** 1.5  # finer at the clamp, where the layer is
    guess = final.evaluate(mesh)
    sol = solve_bvp(rhs, bc, mesh, np.vstack([guess["theta"], guess["dtheta"], guess["x"], guess["y"]]),
                    tol=1e-8, bc_tol=1e-12, max_nodes=50000)
    assert sol.success, sol.message
    assert (sol.sol(1.0)[2], sol.sol(1.0)[3]) == pytest.approx(TARGET, abs=1e-6)
    y = sol.sol(S)[3]
    assert Y_LO - 1e-6 <= y.min() and y.max() <= Y_HI + 1e-6


def test_the_walls_change_the_design(channel):
    """Without the walls the least-effort design dips through the lower one: the clearance rows
    are what moved the design (a design variable with an effect, not decoration)."""
    scene, options, r = channel
    free = design(TARGET, scene=replace(scene, obstacles=()), options=options)
    assert free.success
    assert free.path.final.evaluate(S)["y"].min() < Y_LO - 1e-3
    assert abs(free.design["h"] - r.design["h"]) > 0.1


def test_a_stiffness_target_with_obstacles_is_refused(channel):
    scene, options, _ = channel
    with pytest.raises(ValueError, match="design --target-stiffness: this scene has obstacles"):
        design(None, scene=scene, options=options, stiffness=1.5)


def test_the_mirrored_channel_gets_the_mirrored_design(channel):
    """The channel reflected in the rod's axis (walls 1.6 mm above and 6.4 mm below) and the target
    (17, −3) mm are the mirror problem: the design is the mirror one (φ, α → −φ, −α), found by
    symmetry, and verified on the reflected walls."""
    import actuator_design as ad

    scene, options, r = channel
    walls = tuple(ad.Wall((w.point[0], -w.point[1]), -w.normal_angle) for w in scene.obstacles)
    m = design((TARGET[0], -TARGET[1]), scene=replace(scene, obstacles=walls), options=options)
    assert m.success, m.message
    assert "found by symmetry" in m.message
    assert m.design["h"] == pytest.approx(r.design["h"], rel=1e-9)
    assert m.design["phi"] == pytest.approx(-r.design["phi"], abs=1e-9)
    assert np.allclose(m.design["alpha"]["legendre_coefficients"],
                       -np.asarray(r.design["alpha"]["legendre_coefficients"]), atol=1e-9)
    for st in m.path.states:
        y = -st.evaluate(S)["y"]
        assert Y_LO - 1e-6 <= y.min() and y.max() <= Y_HI + 1e-6


def test_every_obstacle_reflects_into_its_mirror_image():
    """d'(x, −y) = d(x, y) at random points for the reflection of a wall, a peg, a polygon and a lumen."""
    import math

    import actuator_design as ad

    obstacles = (ad.Wall((0.1, -0.2), 1.1), ad.Peg((0.6, 0.3), 0.1), ad.Polygon(((0.2, 0.1), (0.5, 0.15), (0.3, 0.4))),
                 ad.Lumen((0.0, 0.0), 0.2, 0.1, (("straight", 0.3), ("arc", 0.4, math.radians(70)), ("straight", 0.2))))
    rng = np.random.default_rng(7)
    x, y = rng.uniform(-1, 1, 500), rng.uniform(-1, 1, 500)
    for ob in obstacles:
        m = ob.mirrored()
        assert type(m) is type(ob)
        assert np.allclose(np.asarray(m.distance(x, -y), float), np.asarray(ob.distance(x, y), float), atol=1e-12)


def test_the_cli_reports_the_clearance_in_the_users_units(capsys):
    import json

    from actuator_design.cli.main import main

    assert main(["design", str(CONFIG), "--target-tip", "17,3", "--target-units", "mm", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["success"] and len(d["clearance"]) == 2
    for c, p in zip(d["clearance"], d["physical"]["clearance"]):
        assert c["min_distance"] >= -1e-6 and p["min_distance_mm"] == pytest.approx(L_MM * c["min_distance"])
    # the walls as the config gives them: 4 mm either side of y = 2.4 mm
    assert sorted(p["obstacle_text"].split(",")[1].strip() for p in d["physical"]["clearance"]) == \
        ["-1.6) mm", "6.4) mm"]


def test_the_text_names_the_walls_and_the_arc_length_in_the_users_unit(capsys):
    from actuator_design.cli.main import main

    assert main(["design", str(CONFIG), "--target-tip", "17,3", "--target-units", "mm"]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if "clearance" in ln]
    assert len(lines) == 2
    for ln in lines:  # no rod lengths ("l") beside millimetres
        assert ln.count(" mm") == 3 and " l," not in ln and ln.rstrip().endswith("mm)"), ln


def test_a_rod_held_in_contact_at_rest_is_refused_in_one_line(capsys):
    """A curved lumen holds the straight rod in contact at rest: no design keeps it clear, and the
    request is refused before any solve (it used to search for minutes)."""
    from actuator_design.cli.main import main

    cfg = CONFIG.parent / "contact_guidewire_bend.yaml"
    assert main(["design", str(cfg), "--target-tip", "12,8", "--target-units", "mm"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the straight rod at rest enters the lumen" in err[0] and "free rest state" in err[0]


def test_a_clearance_keeps_the_design_that_far_from_the_walls(capsys):
    """--clearance '0.25 mm' (a wall's position tolerance): the designed rod keeps 0.25 mm more from
    both walls than half its thickness — checked on the verified shape against the wall lines."""
    import json

    from actuator_design.cli.main import main

    assert main(["design", str(CONFIG), "--target-tip", "17,3", "--target-units", "mm", "--clearance", "0.25 mm",
                 "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["success"]
    assert all(c["min_distance"] >= 0.25 / L_MM - 1e-6 for c in d["clearance"])
    scene, options, _ = load_scene(CONFIG)
    from actuator_design.inverse.settings import DesignSettings

    r = design(TARGET, scene=scene, options=options, settings=DesignSettings(clearance=0.25 / L_MM))
    assert r.success and r.design["h"] == pytest.approx(d["design"]["h"], rel=1e-9)
    y = r.path.final.evaluate(S)["y"]
    assert Y_LO + 0.25 / L_MM - 1e-6 <= y.min() and y.max() <= Y_HI - 0.25 / L_MM + 1e-6


def test_a_clearance_is_checked_in_one_line(capsys):
    from actuator_design.cli.main import main

    for value, words in (("2 s", "--clearance: expected a length"), ("-1", "--clearance: must be a finite number > 0"),
                         ("30 mm", "clearance must lie in [0, 1) rod lengths")):
        assert main(["design", str(CONFIG), "--target-tip", "17,3", "--target-units", "mm", "--clearance", value]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0]


def test_the_design_figure_shows_the_walls_and_the_box_error_in_mm(channel):
    """The verified path of a design kept clear runs without the obstacles (no contact on it); the
    figure draws the walls all the same, and the box panel gives the worst-case error in mm."""
    from actuator_design.io.user_units import user_units
    from actuator_design.viz.design import design_figure

    scene, _, res = channel
    _, _, raw = load_scene(CONFIG)
    fig = design_figure(res, units=user_units(scene, raw))
    shape_ax = fig.axes[0]
    (box_ax,) = [ax for ax in fig.axes if ax.get_title().startswith("tip over the box")]
    assert "obstacle" in shape_ax.get_legend_handles_labels()[1]
    # the walls' lines, in rod lengths (the axes' data): y = -0.08 and y = 0.32
    walls = sorted({round(float(ln.get_ydata()[0]), 12) for ln in shape_ax.get_lines()
                    if len(ln.get_ydata()) == 2 and abs(ln.get_ydata()[0] - ln.get_ydata()[1]) <= 1e-12
                    and ln.get_color() == "0.3"})
    assert walls == [-0.08, 0.32]
    err_mm = L_MM * res.robustness.robustness.worst_tip_error
    assert f"worst-case error {err_mm:.3g} mm" in box_ax.get_legend_handles_labels()[1]
