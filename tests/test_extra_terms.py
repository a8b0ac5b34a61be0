"""The terms shipped in actuator_design/physics/extra_terms (one file each): an elastic (Winkler)
foundation ½ k y² and a tapered dead load −((1 − s) q_root + s q_tip)·r.

Independent references, written out here:

* the foundation: scipy's solve_bvp on θ'' = N cos θ + fx sin θ − fy cos θ, N' = −k y, y' = sin θ,
  N(1) = 0 (the bed's resultant beyond s), and for a small load the linear beam on an elastic
  foundation y'''' + k y = 0 in closed form (exponentials with λ⁴ = −k);
* the tapered load: solve_bvp on θ'' = Qx sin θ − Qy cos θ with Q(s) = q_root (1 − s)²/2 +
  q_tip (1 − s²)/2, and the clamp reaction balancing the total load (a conservation law);
* scaling laws written out (k, q ∝ 1/E; a physical k in Pa is k ℓ⁴/B0).
"""
import json
import math

import numpy as np
import pytest

from actuator_design.physics import parameters as lens
from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import Scene
from rod_bvp import rod_bvp


def foundation_bvp(k, fx=0.0, fy=0.0):
    """The rod on a Winkler foundation k with a dead tip force (fx, fy)."""
    return rod_bvp(lambda s, th: fx * np.sin(th) - fy * np.cos(th), k)


def tapered_bvp(root, tip):
    """Under q(s) = (1 − s) root + s tip: Qx sin θ − Qy cos θ, Q(s) = ∫ₛ¹ q written out."""
    (ax, ay), (bx, by) = root, tip

    def torque(s, th):
        qx = ax * (1 - s) ** 2 / 2 + bx * (1 - s ** 2) / 2
        qy = ay * (1 - s) ** 2 / 2 + by * (1 - s ** 2) / 2
        return qx * np.sin(th) - qy * np.cos(th)

    return rod_bvp(torque)


def linear_foundation_tip(k, fy):
    """y(1) of y'''' + k y = 0, y(0) = y'(0) = 0, y''(1) = 0, y'''(1) = −fy (closed form)."""
    lam = (k ** 0.25) * np.exp(1j * np.pi * np.array([1, 3, 5, 7]) / 4)  # λ⁴ = −k
    e = np.exp(lam)
    A = np.array([np.ones(4), lam, lam ** 2 * e, lam ** 3 * e])
    c = np.linalg.solve(A, np.array([0, 0, 0, -fy], complex))
    return float(np.real(np.sum(c * e)))


def foundation_scene(k, fx=0.0, fy=0.0):
    return Scene(field=None, tip_force=(fx, fy)).with_term("foundation", k_foundation=k)


def tapered_scene(root, tip):
    return Scene(field=None, tip_force=None).with_term(
        "tapered_load", q_root_x=root[0], q_root_y=root[1], q_tip_x=tip[0], q_tip_y=tip[1])


@pytest.mark.parametrize("k, fx, fy", [(20.0, 0.0, 3.0), (300.0, -1.0, 20.0), (1.0, 0.5, -4.0)])
def test_foundation_matches_the_bvp(k, fx, fy):
    r = solve(foundation_scene(k, fx, fy))
    assert r.success and r.stable and r.el_residual < 1e-8
    x, y, angle = foundation_bvp(k, fx, fy)
    assert r.tip["x"] == pytest.approx(x, abs=1e-8)
    assert r.tip["y"] == pytest.approx(y, abs=1e-8)
    assert r.tip["angle"] == pytest.approx(angle, abs=1e-8)


@pytest.mark.parametrize("k", [0.5, 40.0, 2000.0])
def test_foundation_small_load_is_the_linear_closed_form(k):
    eps = 1e-5
    r = solve(foundation_scene(k, 0.0, eps))
    assert r.success
    assert r.tip["y"] / eps == pytest.approx(linear_foundation_tip(k, 1.0), rel=1e-6)


def test_foundation_clamp_reaction_balances_tip_force_and_bed():
    """Force balance: clamp force + tip force − ∫ k y ds = 0 (the bed pulls back along c2)."""
    k, fy = 30.0, 4.0
    r = solve(foundation_scene(k, 0.0, fy))
    from scipy.integrate import simpson

    s = np.linspace(0, 1, 4001)
    bed = simpson(k * r.evaluate(s)["y"], x=s)
    assert r.clamp_force[1] == pytest.approx(-(fy - bed), abs=1e-7)
    assert abs(r.clamp_force[0]) < 1e-9


@pytest.mark.parametrize("root, tip", [((0.0, -6.0), (0.0, 2.0)), ((1.0, 3.0), (-2.0, 9.0))])
def test_tapered_load_matches_the_bvp_and_balances_the_clamp(root, tip):
    r = solve(tapered_scene(root, tip))
    assert r.success and r.stable and r.el_residual < 1e-8
    x, y, angle = tapered_bvp(root, tip)
    assert (r.tip["x"], r.tip["y"], r.tip["angle"]) == pytest.approx((x, y, angle), abs=1e-8)
    total = 0.5 * (np.array(root) + np.array(tip))  # ∫₀¹ q ds
    assert r.clamp_force == pytest.approx(-total, abs=1e-8)


def test_uniform_tapered_load_is_the_builtin_distributed_load():
    """A second method: q_root = q_tip is the built-in uniform load (another term, same physics)."""
    a = solve(tapered_scene((0.5, -3.0), (0.5, -3.0)))
    b = solve(Scene(field=None, tip_force=None, distributed_load=(0.5, -3.0)))
    assert a.tip == pytest.approx(b.tip, abs=1e-10)


def test_terms_state_their_scales_for_the_mesh_and_memory_budget():
    from actuator_design.equilibrium.accuracy import scene_wavenumber
    from actuator_design.config.checks import _is_dense

    sc = foundation_scene(1e4, 0.0, 1.0)
    assert scene_wavenumber(sc) == pytest.approx(10.0)  # k^(1/4)
    assert _is_dense(sc)  # the bed couples every point with every other
    tl = tapered_scene((0.0, 0.0), (0.0, -1000.0))
    assert scene_wavenumber(tl) == pytest.approx(10.0) and not _is_dense(tl)


def test_lens_continuation_follows_the_bvp():
    from actuator_design.continuation.follow import continue_branch

    res = continue_branch(foundation_scene(1.0, 0.0, 3.0), "k_foundation", 1.0, 200.0, ds_max=2.0)
    br = res.branch
    assert br.lam.max() >= 200.0 - 1e-6 and np.all(br.stable) and not br.folds
    for i in np.linspace(0, len(br.lam) - 1, 4).astype(int):
        x, y, _ = foundation_bvp(float(br.lam[i]), 0.0, 3.0)
        assert br.tips[i, 1:3] == pytest.approx((x, y), abs=1e-7)


def test_a_youngs_modulus_change_scales_the_terms_like_the_loads():
    """E → 1.1 E: k and q ∝ 1/E, h ∝ E^-½ (THEORY §5), written out."""
    from actuator_design.robust.tolerances import apply_deltas

    sc = foundation_scene(8.0, 0.0, 2.0).with_term(
        "tapered_load", q_root_x=0.0, q_root_y=-3.0, q_tip_x=0.0, q_tip_y=1.0).with_values(h=2.0, phi=0.4)
    out = apply_deltas(sc, {"youngs_rel": 0.1, "field_rel": 0.05, "chi_rel": -0.02})
    assert out.term_values("foundation")["k_foundation"] == pytest.approx(8.0 / 1.1, rel=1e-15)
    assert out.term_values("tapered_load")["q_root_y"] == pytest.approx(-3.0 / 1.1, rel=1e-15)
    assert out.tip_force[1] == pytest.approx(2.0 / 1.1, rel=1e-15)
    assert out.h == 2.0 * 1.05 * math.sqrt(0.98 / 1.1)
    groups = dict(lens.stiffness_groups())
    assert groups["k_foundation"] == -1.0 and groups["q_tip_y"] == -1.0 and groups["h"] == -0.5


def test_yaml_terms_dimensionless_and_physical(tmp_path):
    from actuator_design.config.model import load_config

    (tmp_path / "d.yaml").write_text("scene:\n  type: dimensionless\n  p: 2.0\n  terms:\n"
                                     "    - {type: foundation, k_foundation: 50}\n")
    cfg = load_config(tmp_path / "d.yaml")
    assert cfg.to_scene().term_values("foundation") == {"k_foundation": 50.0}
    (tmp_path / "p.yaml").write_text(
        "scene:\n  type: physical\n  rod: {length: 20 mm, width: 5 mm, thickness: 1 mm, youngs_modulus: 1 MPa}\n"
        "  terms:\n    - {type: foundation, k_foundation: 2 kPa}\n"
        "    - {type: tapered_load, q_tip_y: -0.1 N/m}\n")
    sc = load_config(tmp_path / "p.yaml").to_scene()
    b0 = 1e6 * 5e-3 * 1e-3 ** 3 / 12  # E w t³/12
    assert sc.term_values("foundation")["k_foundation"] == pytest.approx(2e3 * 0.02 ** 4 / b0, rel=1e-12)
    assert sc.term_values("tapered_load")["q_tip_y"] == pytest.approx(-0.1 * 0.02 ** 3 / b0, rel=1e-12)


@pytest.mark.parametrize("terms, message", [
    ("[{type: foundation, k_foundation: -5}]", r"scene\.terms\[0\]\.k_foundation: must be >= 0, got -5"),
    ("[{type: foundation, k: 5}]", r"scene\.terms\[0\]\.k: unknown key \(allowed: k_foundation\)"),
    ("[{type: bogus}]", r"scene\.terms\[0\]\.type: unknown term 'bogus' \(allowed: .*foundation"),
    ("[{k_foundation: 5}]", r"scene\.terms\[0\]\.type: each entry needs a 'type'"),
    ("[{type: foundation, k_foundation: .nan}]", r"scene\.terms\[0\]\.k_foundation: must be a finite number"),
    ("[{type: foundation, k_foundation: 2 kPa}]", r"scene\.terms\[0\]\.k_foundation: .*physical unit"),
    ("[{type: foundation, k_foundation: 1}, {type: foundation, k_foundation: 2}]",
     r"scene\.terms\[1\]\.type: the term 'foundation' is listed twice"),
    ("{foundation: {type: tapered_load, q_tip_y: 1}}", r"scene\.terms\.foundation\.type: the mapping form"),
    ("[{type: foundation, k_foundation: true}]", r"scene\.terms\[0\]\.k_foundation: must be a number, got True"),
    ("{foundation: 5}", r"scene\.terms\.foundation: expected a mapping"),
    ("7", r"scene\.terms: expected a list"),
])
def test_bad_term_entries_are_one_line_naming_the_field(tmp_path, terms, message):
    from actuator_design.config import ConfigError
    from actuator_design.config.model import load_config

    (tmp_path / "c.yaml").write_text(f"scene:\n  type: dimensionless\n  terms: {terms}\n")
    with pytest.raises(ConfigError, match=message):
        load_config(tmp_path / "c.yaml")


def test_cli_set_solves_and_round_trips_through_result_json(tmp_path, capsys):
    from actuator_design.cli.main import main
    from actuator_design.io.saved import read_result

    out = tmp_path / "out"
    assert main(["solve", "--h", "0", "--p", "3", "--set", "k_foundation=20", "--json", "--out", str(out)]) == 0
    payload = json.loads(capsys.readouterr().out)
    x, y, _ = foundation_bvp(20.0, 0.0, 3.0)
    assert (payload["tip"]["x"], payload["tip"]["y"]) == pytest.approx((x, y), abs=1e-8)
    saved = read_result(out / "result.json")
    assert saved.scene.term_values("foundation") == {"k_foundation": 20.0}
    again = solve(saved.scene, saved.options)
    assert again.tip["y"] == pytest.approx(payload["tip"]["y"], abs=1e-12)


def test_a_term_declares_its_own_flag_and_every_scene_command_has_it(capsys):
    """Issue 18: a term carries its CLI flag (``Parameter.flag_help``); the scene commands build
    their flags from the registered terms, so ``--k-foundation`` is the foundation's own flag."""
    from actuator_design.cli.main import main

    assert main(["solve", "--h", "0", "--p", "3", "--k-foundation", "20", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    x, y, _ = foundation_bvp(20.0, 0.0, 3.0)
    assert (payload["tip"]["x"], payload["tip"]["y"]) == pytest.approx((x, y), abs=1e-8)
    assert main(["equilibria", "--help"]) == 0
    assert "--k-foundation" in capsys.readouterr().out
    assert main(["solve", "--k-foundation", "2e10"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--k-foundation" in err[0] and "1e+10" in err[0], err


@pytest.mark.parametrize("flag, message", [
    ("k_foundation=-1", "--set k_foundation: must be >= 0, got -1"),
    ("nope=1", "--set: unknown parameter 'nope' (allowed: "),
    ("k_foundation", "--set: expected NAME=VALUE, got 'k_foundation'"),
    ("k_foundation=nan", "--set k_foundation: must be finite, got 'nan'"),
])
def test_cli_set_bad_input_exit_2(capsys, flag, message):
    from actuator_design.cli.main import main

    assert main(["solve", "--set", flag]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_continuation_study_in_a_terms_parameter(tmp_path, capsys):
    """A YAML continuation study in the foundation's stiffness (CLI); its points are the BVP's."""
    from actuator_design.cli.main import main

    (tmp_path / "s.yaml").write_text(
        "scene:\n  type: dimensionless\n  p: 2.0\n  terms:\n    - {type: foundation, k_foundation: 1}\n"
        "study:\n  type: continuation\n  param: k_foundation\n  from: 1\n  to: 60\n  ds_max: 5\n")
    assert main(["continue", str(tmp_path / "s.yaml"), "--json"]) == 0
    pts = json.loads(capsys.readouterr().out)["branch"]
    assert max(p["k_foundation"] for p in pts) >= 60 - 1e-6
    for p in pts[::max(1, len(pts) // 3)]:
        x, y, _ = foundation_bvp(p["k_foundation"], 0.0, 2.0)
        assert (p["tip_x"], p["tip_y"]) == pytest.approx((x, y), abs=1e-7)


def test_sweep_study_over_a_terms_parameter(tmp_path):
    """A sweep addresses a term's value by its path in the mapping form of ``terms:``."""
    from actuator_design.study.runner import run_study

    cfg = {"scene": {"type": "dimensionless", "p": 2.0, "terms": {"foundation": {"k_foundation": 1.0}}},
           "study": {"type": "sweep", "sweep": {"terms.foundation.k_foundation": [5.0, 80.0]},
                     "analyses": ["solve"], "outputs": ["solve.tip.x", "solve.tip.y"]}}
    run_study(cfg, tmp_path / "out", workers=1, progress=False)
    rows = (tmp_path / "out" / "results.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert len(rows) == 3
    for row in rows[1:]:
        v = dict(zip(header, row.split(",")))
        k = float(v["terms.foundation.k_foundation"])
        x, y, _ = foundation_bvp(k, 0.0, 2.0)
        assert (float(v["solve.tip.x"]), float(v["solve.tip.y"])) == pytest.approx((x, y), abs=1e-8)


def test_each_shipped_extra_term_is_named_only_in_its_own_file():
    """Adding a term is one file: no other module of the package names it or its parameters."""
    from pathlib import Path

    import actuator_design
    from actuator_design.physics.registry import registered_terms

    root = Path(actuator_design.__file__).parent
    own = {c.name: Path(__import__(c.__module__, fromlist=["_"]).__file__) for c in registered_terms()
           if c.__module__.startswith("actuator_design.physics.extra_terms.")}
    assert {"foundation", "tapered_load"} <= set(own)
    words = {name: {name} | {p.name for p in term.parameters}
             for name, term in ((c.name, c) for c in registered_terms() if c.name in own)}
    for path in root.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for name, names in words.items():
            if path != own[name]:
                hits = sorted(w for w in names if w in text)
                assert not hits, f"{path.relative_to(root)} names {hits} of the term {name!r}"


def test_tolerance_scaling_is_the_written_out_formulas_to_the_last_bit():
    """THEORY §5 written out (h ∝ H √(χ/E), h_r ∝ H/E, loads ∝ 1/E), evaluated as the tolerance box
    always has: a corner scene must not move by round-off when the scaling became generic."""
    import random
    from dataclasses import replace

    from actuator_design.robust.tolerances import apply_deltas
    from actuator_design.model.profiles import constant_profile
    from actuator_design.model.scene import default_scene

    rng = random.Random(7)
    for _ in range(300):
        sc = replace(default_scene(h=rng.uniform(0, 3), phi=0.3, p=rng.uniform(-5, 5)), h_r=rng.uniform(0, 3),
                     magnetization=constant_profile(0.0), tip_moment=rng.uniform(-2, 2),
                     distributed_load=(rng.uniform(-3, 3), rng.uniform(-3, 3)))
        f, e, c = (rng.uniform(-0.1, 0.1) for _ in range(3))
        out = apply_deltas(sc, {"field_rel": f, "youngs_rel": e, "chi_rel": c})
        load = 1.0 / (1 + e)
        assert out.h == sc.h * ((1 + f) * math.sqrt((1 + c) / (1 + e)))
        assert out.h_r == sc.h_r * (1 + f) / (1 + e)
        assert out.tip_force[1] == load * sc.tip_force[1] and out.tip_moment == load * sc.tip_moment
        assert out.distributed_load == (load * sc.distributed_load[0], load * sc.distributed_load[1])


def test_a_term_without_declared_scaling_is_refused_by_a_material_tolerance():
    from actuator_design.robust.tolerances import apply_deltas
    from actuator_design.physics.parameters import plugin_parameter
    from actuator_design.physics.registry import register_term, unregister_term
    from actuator_design.physics.terms import EnergyTerm

    @register_term(replace=True)
    class Undeclared(EnergyTerm):
        name = "toy_undeclared"
        scalar_params = ("k_undeclared",)
        parameters = (plugin_parameter("toy_undeclared", "k_undeclared", "a spring", "B0/l^2"),)

        def density(self, kin, P):
            return 0.5 * P["k_undeclared"] * kin.theta ** 2

    try:
        sc = Scene(field=None, tip_force=(0.0, 1.0)).with_term("toy_undeclared", k_undeclared=1.0)
        with pytest.raises(ValueError, match="tolerance youngs_modulus: the scene's energy term 'toy_undeclared' "
                                             "does not declare"):
            apply_deltas(sc, {"youngs_rel": 0.1})
        assert apply_deltas(sc, {"clamp_angle": 0.1}).theta0 == 0.1  # geometry needs no declaration
    finally:
        unregister_term("toy_undeclared")


def test_a_dense_term_gets_the_dense_memory_budget_in_a_config_and_on_the_command_line(tmp_path, capsys):
    from actuator_design.cli.main import main
    from actuator_design.config import ConfigError
    from actuator_design.config.model import load_config

    (tmp_path / "c.yaml").write_text("scene:\n  type: dimensionless\n  terms: {foundation: {k_foundation: 5}}\n"
                                     "solver: {elements: 100}\n")
    with pytest.raises(ConfigError, match=r"solver\.elements: must be <= 20 for lgl of degree 10 with a dense"):
        load_config(tmp_path / "c.yaml")
    assert main(["design", "--target-tip", "0.5,0.5", "--set", "k_foundation=3", "--elements", "100"]) == 2
    assert main(["design", "--target-tip", "0.5,0.5", "--set", "p=1e9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "dense Hessian" in err[0] and "p: must be a finite number in" in err[1]


def test_the_term_order_does_not_depend_on_what_was_imported_first():
    """The lens and the NLP slots follow it: built-ins, then the shipped extra terms by module (a
    fresh process that imports an extra term's module before anything else)."""
    import subprocess
    import sys

    code = ("import actuator_design.physics.extra_terms.tapered_load\n"
            "from actuator_design.physics.registry import registered_terms\n"
            "print(','.join(c.name for c in registered_terms()))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    names = out.strip().split(",")
    assert names[0] == "bending"
    assert names.index("hard_magnetic") < names.index("foundation") < names.index("tapered_load")


def test_physical_continuation_in_pascal_reports_pascal(tmp_path, capsys):
    """--from/--to in Pa on a physical scene: k = k_SI ℓ⁴/B0; each point carries value_Pa."""
    from actuator_design.cli.main import main

    (tmp_path / "p.yaml").write_text(
        "scene:\n  type: physical\n  rod: {length: 20 mm, width: 5 mm, thickness: 1 mm, youngs_modulus: 1 MPa}\n"
        "  loads:\n    tip_force: {x: 0 N, y: 1 mN}\n  terms: {foundation: {k_foundation: 0 Pa}}\n")
    assert main(["continue", str(tmp_path / "p.yaml"), "--param", "k_foundation", "--from", "0 Pa", "--to", "100 Pa",
                 "--json"]) == 0
    pts = json.loads(capsys.readouterr().out)["branch"]
    b0, length = 1e6 * 5e-3 * 1e-3 ** 3 / 12, 0.02
    assert pts[-1]["value_Pa"] == pytest.approx(100.0, rel=1e-12)
    assert pts[-1]["k_foundation"] == pytest.approx(100.0 * length ** 4 / b0, rel=1e-12)
    fy = 1e-3 * length ** 2 / b0
    x, y, _ = foundation_bvp(pts[-1]["k_foundation"], 0.0, fy)
    assert (pts[-1]["tip_x"], pts[-1]["tip_y"]) == pytest.approx((x, y), abs=1e-7)
    assert main(["continue", str(tmp_path / "p.yaml"), "--param", "k_foundation", "--from", "0 N", "--to", "1 Pa"]) == 2
    assert "expected a pressure" in capsys.readouterr().err
    # the written tables carry the unit too (continue and a loading path)
    for command, name in (("continue", "branch.csv"), ("path", "path.csv")):
        out = tmp_path / command
        assert main([command, str(tmp_path / "p.yaml"), "--param", "k_foundation", "--from", "0 Pa", "--to",
                     "100 Pa", "--out", str(out)]) == 0
        header = [ln for ln in (out / name).read_text().splitlines() if not ln.startswith("#")][0]
        assert "_Pa" in header, header
    assert "k_foundation [Pa]" in capsys.readouterr().out


def test_a_plug_in_value_the_field_drives_moves_with_a_designed_h():
    """design_field_groups reads the lens: a toy slot with field power 2 follows (h/h0)², in the
    design NLP's parameter map (CasADi) and in the forward scene alike; h_r, h_pos ∝ h exactly."""
    import casadi as ca

    from actuator_design.inverse.design_map import couple_field_groups, coupled_scene
    from actuator_design.equilibrium.options import SolverOptions
    from actuator_design.physics.parameters import plugin_parameter
    from actuator_design.physics.registry import register_term, unregister_term
    from actuator_design.physics.terms import EnergyTerm
    from actuator_design.model.profiles import constant_profile
    from actuator_design.model.scene import DipoleField
    from actuator_design.equilibrium.solver import get_solver

    @register_term(replace=True)
    class FieldSquared(EnergyTerm):
        name = "toy_field_squared"
        scaling_declared = True
        scalar_params = ("g_field",)
        parameters = (plugin_parameter("toy_field_squared", "g_field", "a group ∝ H²", field_power=2),)

        def density(self, kin, P):
            return -P["g_field"] * ca.cos(kin.theta)

    try:
        from dataclasses import replace

        base = replace(Scene(field=DipoleField(), h=1.5, h_pos=0.4, h_r=0.7, tip_force=None,
                             magnetization=constant_profile(0.0)).with_term("toy_field_squared", g_field=3.0))
        designed = base.with_values(h=2.1)
        sc = coupled_scene(base, designed)
        k = 2.1 / 1.5
        assert sc.term_values("toy_field_squared")["g_field"] == pytest.approx(3.0 * k ** 2, rel=1e-15)
        assert (sc.h_r, sc.h_pos) == (0.7 * k, 0.4 * k)
        sv = get_solver(base, SolverOptions())
        sl = sv.layout.slices
        P0 = ca.DM(sv.parameter_vector(base))
        h = ca.SX.sym("h")
        P = ca.SX(P0)
        couple_field_groups(P, P0, h, sl)
        f = ca.Function("f", [h], [P[sl["g_field"]], P[sl["h_r"]], P[sl["h_pos"]]])
        g, h_r, h_pos = (float(v) for v in f(2.1))
        assert g == pytest.approx(3.0 * k ** 2, rel=1e-14)
        assert (h_r, h_pos) == pytest.approx((0.7 * k, 0.4 * k), rel=1e-15)
    finally:
        unregister_term("toy_field_squared")


def test_schedule_sets_a_plugin_value_and_lands_on_the_bvps_fields(capsys):
    """``schedule --set k_foundation=20``: waypoints made by the BVP reference with the bed (h = 1.5,
    φ = 0.6 then 1.0; tip position fixes (h, φ)) are reached at exactly those fields."""
    from actuator_design.cli.main import main

    h, k, phis = 1.5, 20.0, (0.6, 1.0)
    wps = [rod_bvp(lambda s, th, phi=phi: h ** 2 * np.sin(2.0 * (th - phi)), k, lambda s, phi=phi: phi * s * (2 - s))
           for phi in phis]
    argv = ["schedule", "--waypoints", ";".join(f"{float(x)!r},{float(y)!r}" for x, y, _ in wps),
            "--set", f"k_foundation={k}", "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["verified"] and out["snap_free"] and out["all_stable"]
    for row, phi in zip(out["rows"], phis):
        assert row["h"] == pytest.approx(h, abs=1e-6) and row["phi"] == pytest.approx(phi, abs=1e-6)
        assert row["error"] < 1e-8


def test_schedule_refuses_an_unknown_set_name_in_one_line(capsys):
    from actuator_design.cli.main import main

    assert main(["schedule", "--waypoints", "0.9,0.3;0.8,0.5", "--set", "k_fondation=2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--set" in err[0] and "k_fondation" in err[0], err
