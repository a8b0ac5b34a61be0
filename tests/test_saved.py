"""Saved results read back (issue 18: io saves *and loads* a scene and a result): the scene of every
shipped config, and a hand-built scene with every kind of part, survive JSON unchanged field by field
(NaN as NaN: JSON writes it as null); a result written by ``solve --out`` is read back and its scene,
solved again, lands on the tip the file holds; bad files are one clear line."""
import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

import actuator_design as ad
from actuator_design.config import load_scene
from actuator_design.io.save import dumps_json, scene_to_dict
from actuator_design.contact.obstacles import Lumen, Peg, Polygon, Wall
from actuator_design.model.profiles import legendre_profile, table_profile
from actuator_design.io.saved import read_result, scene_from_dict
from actuator_design.model.scene import Scene, TermValues

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.yaml"))


def _same(a, b, where="scene"):
    """Field-by-field equality of (nested) dataclasses, tuples and numbers, NaN equal to NaN, the
    types kept (a tuple is not read back as a list)."""
    if dataclasses.is_dataclass(a):
        assert type(a) is type(b), (where, type(a), type(b))
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), (where, a, b)
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{k}]")
    elif isinstance(a, float) and math.isnan(a):
        assert isinstance(b, float) and math.isnan(b), (where, a, b)
    else:
        assert a == b, (where, a, b)


def _through_json(scene):
    return scene_from_dict(json.loads(dumps_json(scene_to_dict(scene))))


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.stem)
def test_every_shipped_scene_survives_json(path):
    scene = load_scene(path)[0]
    _same(scene, _through_json(scene))


def test_a_scene_with_every_kind_of_part_survives_json():
    scene = Scene(field=ad.DipoleField(x0=1.3, y0=-0.4, moment_angle=0.3), h=0.7, h_pos=0.2, h_r=1.1,
                  magnetization=table_profile([0, 0.5, 1], [0.1, 0.2, -0.3]), fibres=legendre_profile([0.1, -0.2]),
                  tip_force=None, tip_moment=0.25, distributed_load=(0.0, -1.5), theta0=0.1, name="every part",
                  extra_terms=(TermValues("foundation", (("k", 2.0),)),), fibres_given=True, fibres_physical=False,
                  obstacles=(Wall((0.0, -0.3), 1.5707963267948966), Peg((0.6, 0.2), 0.05),
                             Polygon(((0.2, -0.5), (0.4, -0.5), (0.3, -0.35))),
                             Lumen((0.0, 0.0), 0.0, 0.1, (("straight", 0.4), ("arc", 0.5, 0.7)))),
                  contact_gap=0.01)
    _same(scene, _through_json(scene))


def test_a_solved_result_read_back_solves_to_the_same_tip(tmp_path):
    from actuator_design.cli.main import main

    config = Path(__file__).resolve().parents[1] / "configs" / "helmholtz_soft_strip.yaml"
    assert main(["solve", str(config), "--out", str(tmp_path / "out")]) == 0
    saved = read_result(tmp_path / "out" / "result.json")
    assert saved.scene.field.kind == "sources" and math.isnan(saved.scene.field.sources[0].resistance)
    again = ad.solve(saved.scene)
    tip = saved.data["tip"]
    assert again.success and max(abs(again.tip[k] - tip[k]) for k in ("x", "y", "angle")) <= 1e-12
    assert "SavedResult(" in repr(saved) and "converged" in repr(saved)


def test_a_result_reads_back_with_its_solver_options_and_a_design_with_its_designed_scene(tmp_path):
    from actuator_design.cli.main import main

    assert main(["solve", "--h", "2", "--phi-deg", "60", "--elements", "6", "--degree", "8", "--tol", "1e-11",
                 "--out", str(tmp_path / "s")]) == 0
    saved = read_result(tmp_path / "s" / "result.json")
    opts = saved.options
    assert (opts.elements, opts.degree, opts.tol) == (6, 8, 1e-11)
    again = ad.solve(saved.scene, opts)
    assert max(abs(again.tip[k] - saved.data["tip"][k]) for k in ("x", "y", "angle")) <= 1e-13
    # design.json: its scene is the designed one (the field and the fibre layout the design reports)
    assert main(["design", "--target-tip", "0.6,0.6", "--out", str(tmp_path / "d")]) == 0
    designed = read_result(tmp_path / "d" / "design.json")
    d = designed.data["design"]
    assert designed.options is None and (designed.data["target"]["x"], designed.data["target"]["y"]) == (0.6, 0.6)
    assert designed.scene.h == d["h"] and designed.scene.field.phi == d["phi"]
    s = np.asarray(d["alpha"]["s"])
    assert np.max(np.abs(designed.scene.fibres(s) - np.asarray(d["alpha"]["value"]))) <= 1e-14


def test_a_file_without_a_whole_scene_is_refused_in_one_line(tmp_path):
    old = tmp_path / "old.json"
    data = json.loads(dumps_json({"status": "converged", "scene": scene_to_dict(Scene())}))
    del data["scene"]["scales_fields"]
    old.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="scales_fields missing .*older version"):
        read_result(old)
    other = tmp_path / "other.json"
    other.write_text("[1, 2]")
    with pytest.raises(ValueError, match="not a result.json with a scene"):
        read_result(other)


def _hostile(data, path, value):
    """``data`` with the entry at ``path`` (keys and indices) set to ``value`` (or deleted: ...)."""
    data = json.loads(json.dumps(data))
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is Ellipsis:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


@pytest.mark.parametrize("path, value", [
    (("field", "terms"), ...),                      # a fitted field without its fit
    (("field",), [1, 2]),                           # a list for the field
    (("field", "terms", 0, "coefficients"), ...),  # a term without its coefficients
    (("field", "weights"), {"a": 1}),               # an object where numbers belong
    (("field", "sources"), []),                     # a term without its source
    (("h",), "abc"),                                 # text for a number
    (("obstacles",), "wall"),                       # not a list of obstacles
    (("fibres",), {"type": "spline"}),              # an unknown profile
    (("fibres",), ...),                             # a profile every scene has, missing
    (("stiffness",), None),                         # ... or null
    (("tip_force",), [0.0]),                        # a term's pair of the wrong length
    (("tip_force",), "oops"),                       # ... or text
    (("h_r",), "zz"),                               # text for a term's number
    (("h_r",), True),                               # ... or a truth value
    (("tip_moment",), [1.0, 2.0]),                  # a list for a term's number
    (("h",), 10**400),                              # an integer no float holds
    (("scales_fields", "length"), 10**400),          # ... in the scales
])
def test_hostile_scene_data_is_one_value_error(path, value):
    scene = load_scene(Path(__file__).resolve().parents[1] / "configs" / "magnet_cylinder_hard_strip.yaml")[0]
    data = json.loads(dumps_json(scene_to_dict(scene)))
    with pytest.raises(ValueError) as err:
        scene_from_dict(_hostile(data, path, value))
    assert str(err.value).startswith("scene") and "\n" not in str(err.value)


def test_a_stray_values_key_is_not_read():
    """A term's value is read from its own key: a ``values`` entry (the scene's store, which
    ``scene_to_dict`` does not write) cannot put text where a number belongs."""
    data = json.loads(dumps_json(scene_to_dict(Scene(h=1.0, h_r=0.5))))
    data["values"] = [["h_r", "zz"], ["tip_force", "oops"], [1, 2, 3]]
    scene = scene_from_dict(data)
    assert scene == Scene(h=1.0, h_r=0.5)


def test_a_saved_scene_says_each_terms_si_scale_by_hand():
    """``scene.scales`` of a result gives, beside the rod's scales, what each term declares of its
    own units; a reader of older versions finds ``scales_fields.h_r_per_field``. Checked against
    THEORY §9 by hand for configs/hard_magnetic_cantilever.yaml: dh_r/dH = μ0 M_r A ℓ² / B0 with
    μ0 M_r = 0.1 T, A = 5 mm × 1 mm, ℓ = 20 mm, B0 = E w t³/12 (E = 1 MPa)."""
    from actuator_design.config import load_config

    root = Path(__file__).resolve().parents[1]
    data = scene_to_dict(load_config(root / "configs" / "hard_magnetic_cantilever.yaml").to_scene())
    area, length, b0 = 5e-3 * 1e-3, 20e-3, 1e6 * 5e-3 * (1e-3) ** 3 / 12
    expected = 0.1 * area * length**2 / b0
    assert data["scales"]["h_r_per_field_per_A_per_m"] == pytest.approx(expected, rel=1e-12)
    assert data["scales_fields"]["h_r_per_field"] == data["scales"]["h_r_per_field_per_A_per_m"]
    assert data["scales"]["distributed_load_N_per_m"] == pytest.approx(b0 / length**3, rel=1e-12)
    assert data["scales"]["stiffness_N_per_m"] == pytest.approx(b0 / length**3, rel=1e-12)
