"""Coils known by a calibration map (issue 19 item 1: an electromagnetic navigation system given as
one field map per coil). The maps here are made by magpylib from eight coils built by hand
(problems/emns_map.py), so magpylib is the independent reference: the fitted field off the samples,
a solve against a shooting solver that calls magpylib, and (slow) an eight-current design. The
interior solid harmonics are checked against scipy's associated Legendre functions; bad maps end
in one line naming the file, the column or the coil."""
import math
import sys
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
import yaml
from scipy.special import lpmv
from scipy.spatial.transform import Rotation

from actuator_design.cli.main import main
from actuator_design.model.coil_map import parse_coil_map
from actuator_design.config import load_config
from actuator_design.config.errors import ConfigError
from actuator_design.equilibrium.pipeline import solve
from actuator_design.physics.harmonic import field_function
from actuator_design.physics.tesseral import (TesseralTerm, interior_modes, tesseral_in_plane,
                                              tesseral_potentials)
from actuator_design.reference.shooting_field import (FieldRod, field_from_function, guess_from_shape,
                                                      solve_field_shooting)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "problems"))
import emns_map  # noqa: E402

CURRENTS = (5.0, 2.0, 4.0, 2.0, -5.0, -2.0, -4.0, -2.0)


def _loops(currents):
    """The eight coils as single loops of 500 turns, built here with magpylib (not the package's)."""
    objs = []
    for k, i in enumerate(currents):
        a = k * math.pi / 4
        centre = (1e-3 * (10.0 + 60.0 * math.cos(a)), 1e-3 * 60.0 * math.sin(a), 0.0)
        turn = Rotation.from_euler("z", a + math.pi) * Rotation.from_rotvec([0, 0.5 * math.pi, 0])
        objs.append(magpy.current.Circle(diameter=0.05, current=500 * i, orientation=turn, position=centre))
    return objs


def _config(tmp_path, text=None, currents=CURRENTS, **field):
    path = tmp_path / "map.csv"
    path.write_text(emns_map.map_text(kind="loop") if text is None else text)
    data = yaml.safe_load((ROOT / "configs" / "emns_8coil_map.yaml").read_text())
    data["scene"]["field"]["file"] = "map.csv"
    for c, i in zip(data["scene"]["field"]["coils"], currents):
        c["current"] = f"{i} A"
    data["scene"]["field"].update(field)
    cfg = tmp_path / "scene.yaml"
    cfg.write_text(yaml.safe_dump(data))
    return cfg


def test_interior_harmonics_are_the_regular_solid_harmonics_of_scipys_legendre_functions():
    rng = np.random.default_rng(7)
    x, y, z = rng.uniform(-0.6, 0.6, (3, 9))
    centre, axis, radius = (0.2, -0.1), 0.4, 0.8
    modes = interior_modes(7)
    assert len(modes) == 7 * 10 // 2
    ours = np.array(tesseral_potentials(centre, axis, radius, modes, x, y, z, kind="interior"))
    u = (math.cos(axis) * (x - centre[0]) + math.sin(axis) * (y - centre[1])) / radius
    v = (-math.sin(axis) * (x - centre[0]) + math.cos(axis) * (y - centre[1])) / radius
    r = np.sqrt(u * u + v * v + (z / radius) ** 2)
    phi = np.arctan2(v, u)
    for k, (l, m) in enumerate(modes):
        norm = math.sqrt(math.factorial(l - abs(m)) / math.factorial(l + abs(m))) * (-1) ** abs(m)  # no Condon-Shortley
        ref = r ** l * norm * lpmv(abs(m), l, z / radius / r) * (np.cos(m * phi) if m >= 0 else np.sin(-m * phi))
        assert np.max(np.abs(ours[k] - ref)) < 1e-14, (l, m)
    # the nested in-plane form is the 3-D form at z = 0
    term = TesseralTerm("interior", centre, axis, radius, tuple(rng.normal(size=len(modes))), 0.5, modes)
    flat = sum(a * b for a, b in zip(term.coefficients,
                                     tesseral_potentials(centre, axis, radius, modes, x, y, 0.0, kind="interior")))
    assert np.max(np.abs(tesseral_in_plane(term, x, y) - flat)) < 1e-14


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    cfg = _config(tmp_path_factory.mktemp("map"))
    return load_config(cfg).to_scene()


def test_the_maps_fit_is_magpylibs_field_off_the_samples_and_is_div_and_curl_free(mapped):
    f, h0 = mapped.field, mapped.scales.field
    assert f.kind == "sources" and len(f.terms) == 8 and 0 < f.fit_error < 1e-2
    assert math.isnan(f.gradient_error) and "not measured" in f.describe()
    rng = np.random.default_rng(11)
    t = f.terms[0]
    p = rng.uniform(-1, 1, (4000, 2))
    p = (p[np.hypot(p[:, 0], p[:, 1]) <= 1][:400] * t.valid_radius) + t.centre
    truth = magpy.getH(_loops(CURRENTS), np.column_stack([p * 0.02, np.zeros(len(p))]), sumup=True)[:, :2] / h0
    hx, hy = field_function(f.terms).map(len(p))(p[:, 0], p[:, 1])
    miss = np.hypot(np.asarray(hx).ravel() - truth[:, 0], np.asarray(hy).ravel() - truth[:, 1])
    assert miss.max() <= f.fit_error  # the reported (held-out) error bounds the error between samples
    import casadi as ca
    xs = [ca.SX.sym(n) for n in "xyz"]
    h = ca.vertcat(*field_function(f.terms, with_z=True)(*xs))
    jac = ca.Function("J", xs, [ca.jacobian(h, ca.vertcat(*xs)), h])
    for q in rng.uniform(-0.6, 0.6, (12, 3)) * (1, 1, 0.3) + (0.5, 0, 0):
        J, hq = (np.asarray(v, float) for v in jac(*q))
        assert abs(np.trace(J)) < 1e-12 and np.max(np.abs(J - J.T)) < 1e-12  # div, curl
    assert float(field_function(f.terms, with_z=True)(0.3, 0.2, 0.0)[2]) == 0.0  # no field normal to the plane


@pytest.mark.slow
def test_solve_in_the_maps_field_agrees_with_shooting_in_magpylibs(mapped):
    res = solve(mapped)
    assert res.success and res.stable
    length, h0 = mapped.scales.length, mapped.scales.field
    rod = FieldRod(field_from_function(lambda q: magpy.getH(_loops(CURRENTS), q, sumup=True), length, h0),
                   h=mapped.h, h_pos=mapped.h_pos)
    s = np.linspace(0, 1, 201)
    d = res.evaluate(s)
    shot = solve_field_shooting(rod, guess_from_shape(rod, s, d["theta"], d["dtheta"][0], d["x"], d["y"]))
    tip = np.array([res.tip["x"], res.tip["y"], res.tip["angle"]])
    # the map's fit error (≤ 4e-3 of H0, reported; ~4e-4 measured) moves the tip by far less
    assert np.max(np.abs(tip - np.array(shot.tip))) < 1e-4, (tip, shot.tip)


def test_the_same_map_in_other_units_gives_the_same_scene(tmp_path, mapped):
    text = emns_map.map_text(kind="loop")
    lines = text.splitlines()
    head = lines[1].replace("[mm]", "[m]").replace("[mT/A]", "[T/A]")
    rows = [", ".join(repr(float(v) * 1e-3) for v in line.split(",")) for line in lines[2:]]
    other = load_config(_config(tmp_path, "\n".join([head] + rows) + "\n")).to_scene()
    assert other.scales.field == pytest.approx(mapped.scales.field, rel=1e-12)
    for a, b in zip(other.field.terms, mapped.field.terms):
        assert a.modes == b.modes
        assert np.max(np.abs(np.subtract(a.coefficients, b.coefficients))) < 1e-9 * np.max(np.abs(b.coefficients))


def test_a_map_in_its_own_frame_placed_by_frame_is_the_same_field(tmp_path, mapped):
    """The map written in a frame turned by 30° and moved by (7, -4) mm, placed back by ``frame``."""
    a, origin = math.radians(30.0), np.array([7.0, -4.0])
    back = np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]])  # rod frame → the map's
    lines = emns_map.map_text(kind="loop").splitlines()
    rows = []
    for line in lines[2:]:
        v = np.array([float(c) for c in line.split(",")])
        v[:2] = back @ (v[:2] - origin)
        for k in range(3, len(v), 3):
            v[k:k + 2] = back @ v[k:k + 2]
        rows.append(", ".join(repr(float(c)) for c in v))
    cfg = _config(tmp_path, "\n".join(lines[:2] + rows) + "\n",
                  frame={"x": "7 mm", "y": "-4 mm", "angle": "30 deg"})
    placed = load_config(cfg).to_scene()
    assert placed.scales.field == pytest.approx(mapped.scales.field, rel=1e-9)
    x, y = np.array([0.2, 0.5, 0.9]), np.array([0.0, 0.3, -0.2])
    ours = field_function(placed.field.terms).map(3)(x, y)
    theirs = field_function(mapped.field.terms).map(3)(x, y)
    assert max(float(np.max(np.abs(np.asarray(p) - np.asarray(q)))) for p, q in zip(ours, theirs)) < 1e-9


def test_a_map_not_symmetric_about_the_rods_plane_or_too_noisy_is_refused(tmp_path):
    with pytest.raises(ConfigError, match=r"scene\.field: coil 'c1': its map is not represented .* symmetric about "
                                          r"the rod's plane"):
        load_config(_config(tmp_path, emns_map.map_text(kind="loop", z_shift_mm=3.0))).to_scene()
    noisy = emns_map.map_text(kind="loop", noise_mT_per_A=0.005, seed=4)
    with pytest.raises(ConfigError, match=r"raise fit_tolerance to at least"):
        load_config(_config(tmp_path, noisy)).to_scene()
    scene = load_config(_config(tmp_path, noisy, fit_tolerance=0.05)).to_scene()
    # the reported error is not below the noise (0.005 mT/A on each component, ~0.5 % of a coil's field)
    noise = 0.005e-3 * 5.0 * math.sqrt(2) / (4e-7 * math.pi) / scene.scales.field  # the 5 A coil's, per H0
    assert scene.field.fit_error > noise


def test_a_map_with_a_hole_holds_only_inside_it_and_repeated_rows_do_not_leak_into_the_held_out_points(tmp_path):
    lines = emns_map.map_text(kind="loop").splitlines()
    rows = [r for r in lines[2:] if not (float(r.split(",")[0]) > 20.0 and float(r.split(",")[1]) > 10.0)]
    holed = load_config(_config(tmp_path, "\n".join(lines[:2] + rows) + "\n")).to_scene()
    t = holed.field.terms[0]
    hole = math.hypot(27.5e-3 - 10e-3, 17.5e-3) / 0.02  # the middle of the hole, from the map's centre
    assert t.valid_radius < hole < 25e-3 / 0.02
    # inside the region left, magpylib agrees with the fit to the reported error
    rng = np.random.default_rng(5)
    p = rng.uniform(-1, 1, (4000, 2))
    p = p[np.hypot(p[:, 0], p[:, 1]) <= 1][:300] * t.valid_radius + t.centre
    truth = magpy.getH(_loops(CURRENTS), np.column_stack([p * 0.02, np.zeros(len(p))]), sumup=True)[:, :2]
    hx, hy = field_function(holed.field.terms).map(len(p))(p[:, 0], p[:, 1])
    miss = np.hypot(np.asarray(hx).ravel() - truth[:, 0] / holed.scales.field,
                    np.asarray(hy).ravel() - truth[:, 1] / holed.scales.field)
    assert miss.max() <= holed.field.fit_error
    # a noisy map is refused at a tolerance below its noise, whether or not every row is listed twice
    noisy = emns_map.map_text(kind="loop", noise_mT_per_A=0.005, seed=4).splitlines()
    twice = "\n".join(noisy[:2] + [r for r in noisy[2:] for _ in range(2)]) + "\n"
    for text in ("\n".join(noisy) + "\n", twice):
        with pytest.raises(ConfigError, match=r"raise fit_tolerance to at least"):
            load_config(_config(tmp_path, text, fit_tolerance=3e-3)).to_scene()


def test_a_coil_switched_off_carries_no_field_and_the_others_fit_as_before(tmp_path, mapped):
    off = load_config(_config(tmp_path, currents=(5.0, 0.0) + CURRENTS[2:])).to_scene()
    assert not any(off.field.terms[1].coefficients)
    for a, b in zip(off.field.terms, mapped.field.terms):
        assert a.modes == b.modes  # fitted per ampere: the order does not depend on the current


@pytest.mark.parametrize("text, message", [
    ("", r"no header line"),
    ("x [mm], y [mm], c1_bx [mT], c1_by [mT]\n", r"column 'c1_bx': unit 'mT' is not a field per ampere"),
    ("x [mm], y [mm], c1_bx [mT/A]\n" + "0, 0, 1\n" * 12, r"coil 'c1' has no column 'c1_by'"),
    ("x [mm], y [mm], z [mm], c1_bx [mT/A], c1_by [mT/A]\n", r"coil 'c1' has no column 'c1_bz' \(z is given\)"),
    ("x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "0, 0, 1, nan\n", r"column 'c1_by', line 2: not a finite"),
    ("x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "0, 0, 1, one\n", r"column 'c1_by', line 2: not a finite"),
    ("x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "0, 0, 1\n", r"line 2: expected 4 values"),
    ("x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "0, 0, 1, 0\n" * 3, r"3 points; a map needs at least 12"),
    ("x [mm], y [mm], temp [K]\n", r"column 'temp': unknown column"),
    ("x [mm], x [mm], c1_bx [mT/A], c1_by [mT/A]\n", r"column 'x' appears twice"),
    ("x, y, c1_bx, c1_by\n", r"cannot read column header 'x'"),
    ("x [s], y [mm], c1_bx [mT/A], c1_by [mT/A]\n", r"column 'x': "),
    ("x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "".join(f"{i}, 0, 1, 0\n" for i in range(20)),
     r"the points span no area in the rod's plane"),
    ("x [mm], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "".join(f"{i}, {i % 3}, 1e300, 0\n" for i in range(20)),
     r"coil 'c1': a field of 7.96e\+302 A/m per A; at most 1e\+09"),
    ("x [km], y [mm], c1_bx [mT/A], c1_by [mT/A]\n" + "".join(f"{i}, {i % 3}, 1, 0\n" for i in range(20)),
     r"a point lies 1.9e\+04 m from the clamp"),
    ("x [mm], y [mm], c1_bx [s/A], c1_by [mT/A]\n", r"column 'c1_bx': "),
])
def test_a_bad_map_file_is_one_line(text, message):
    with pytest.raises(ValueError, match=message):
        parse_coil_map(text, source="m.csv")


def test_bad_map_configs_name_the_field_and_the_cli_exits_2(tmp_path, capsys):
    with pytest.raises(ConfigError, match=r"scene\.field\.coils\[1\]\.name: no coil 'c9' in map\.csv \(its coils: c1, c2"):
        load_config(_renamed(tmp_path, 1, "c9"))
    with pytest.raises(ConfigError, match=r"scene\.field\.coils\[2\]\.name: coil 'c1' is listed twice"):
        load_config(_renamed(tmp_path, 2, "c1"))
    cfg = _config(tmp_path)
    data = yaml.safe_load(cfg.read_text())
    del data["scene"]["field"]["coils"][2]["resistance"]
    cfg.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"scene\.field\.max_power: max_power needs every coil's resistance \(coil 'c3'"):
        load_config(cfg)
    (tmp_path / "gone").mkdir()
    for file, message in (("missing.csv", "map file not found"), ("gone", "a data file must be a regular file")):
        cfg = _config(tmp_path, file=file)
        with pytest.raises(ConfigError, match=rf"scene\.field\.file: .*{message}"):
            load_config(cfg)
        assert main(["validate", str(cfg)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0]


def _renamed(tmp_path, k, name):
    cfg = _config(tmp_path)
    data = yaml.safe_load(cfg.read_text())
    data["scene"]["field"]["coils"][k]["name"] = name
    cfg.write_text(yaml.safe_dump(data))
    return cfg


def test_the_coils_of_a_map_move_as_one_rig(mapped):
    from actuator_design.physics.parameters import parameter

    with pytest.raises(ValueError, match=r"source_dx_1: the coils of a calibration map move as one rig"):
        parameter("source_dx_1").require(mapped)
    moved = parameter("source_dx_0").write(mapped, 0.05)
    assert {t.centre for t in moved.field.placed_terms()} == {(mapped.field.terms[0].centre[0] + 0.05, 0.0)}
    x, y = np.array([0.3, 0.6]), np.array([0.1, -0.2])
    from actuator_design.physics.fields import field_model
    model = field_model(moved.field)
    rig = model.evaluate(x, y, model.parameter_values(moved.field))
    one_by_one = sum(np.array([np.asarray(v, float).ravel() for v in field_function([t]).map(2)(x, y)])
                     for t in moved.field.placed_terms())
    assert np.max(np.abs(rig - one_by_one)) < 1e-12


def test_the_scene_is_built_from_the_map_that_was_validated(tmp_path, mapped):
    cfg = load_config(_config(tmp_path))
    (tmp_path / "map.csv").write_text("x [mm], y [mm], q1_bx [mT/A], q1_by [mT/A]\n" + "0, 0, 1, 0\n" * 12)
    assert cfg.to_scene().scales.field == mapped.scales.field  # not the file as it is now


def test_the_map_file_is_read_beside_the_yaml_file_from_any_working_directory(tmp_path, monkeypatch):
    cfg = _config(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert load_config(cfg).scene.field.file == str(tmp_path / "map.csv")


@pytest.mark.slow
def test_eight_currents_designed_from_the_map_put_the_tip_on_target_in_magpylibs_field(mapped):
    from actuator_design.hardware.current_design import design_currents

    target = (0.88, 0.43)
    d = design_currents(mapped, target)
    assert d.success and d.verified, d.message
    assert all(abs(i) <= 15 for i in d.currents) and d.coils == tuple(f"c{k}" for k in range(1, 9))
    length, h0 = mapped.scales.length, mapped.scales.field
    rod = FieldRod(field_from_function(lambda q: magpy.getH(_loops(d.currents), q, sumup=True), length, h0),
                   h=mapped.h, h_pos=mapped.h_pos)
    s = np.linspace(0, 1, 201)
    st = d.state.evaluate(s)
    shot = solve_field_shooting(rod, guess_from_shape(rod, s, st["theta"], st["dtheta"][0], st["x"], st["y"]))
    assert np.max(np.abs(np.array(shot.tip[:2]) - target)) < 1e-4, shot.tip
