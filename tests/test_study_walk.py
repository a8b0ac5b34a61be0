"""Solve sweeps that walk the grid (issue 13): the walk against a lone solve of every point, results
independent of workers, chunk size and resumes, the ray test, and the two kernels the walk rests on
(the stored balance operator and the numpy replay of pointwise SX functions), each against a
second method.
"""
import copy
import csv

import casadi as ca
import numpy as np
import pytest

from actuator_design.equilibrium.acceptance import graded_options
from actuator_design.equilibrium.balance import BalanceOperator, balance
from actuator_design.config import load_config
from actuator_design.equilibrium.dense_shape import DenseShape
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pointwise import NotVectorisable, VectorisedSX
from actuator_design.reference.closed_forms import critical_field_transverse
from actuator_design.equilibrium.solver import get_solver
from actuator_design.study.grid import substitute
from actuator_design.study.runner import plan_study, run_study
from actuator_design.study.walk import _is_ray, plan_chunks, wanted_keys

TIP = ["solve.tip.x", "solve.tip.y", "solve.tip.angle"]

RAYS = {
    "name": "walk test",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "grid": "cartesian",
              "sweep": {"phi": ["30 deg", "90 deg"], "h": {"from": 0.0, "to": 2.5, "n": 21}},
              "analyses": ["solve"],
              "outputs": ["solve.success", "solve.stable", "solve.tip.*", "solve.energy",
                          "solve.el_residual", "solve.solver.from_rest.walk"]},
}


def _rows(folder):
    with open(folder / "results.csv", newline="") as fh:
        return {int(r["point"]): r for r in csv.DictReader(fh)}


def _run(cfg, out, **kw):
    return run_study(plan_study(cfg, out, resume=kw.pop("resume", False)), progress=False, **kw)


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk") / "serial"
    report = _run(RAYS, out, workers=1)
    return out, report


def test_walk_equals_a_lone_solve_at_every_point(walked):
    """Second method: each point solved alone from rest by the public solve (mesh choice, path
    from rest, straight-rod start, IPOPT); past the pitchfork at φ = 90° both are on one branch."""
    out, report = walked
    assert report.status == "completed" and report.counts["ok"] == 42
    rows = _rows(out)
    plan = plan_study(RAYS, out.parent / "unused")
    worst = 0.0
    for i, r in rows.items():
        assert r["solve.solver.from_rest.walk"] == "true"
        config = load_config(substitute(plan.raw, plan.axes, plan.indices[i]))
        alone = solve(config.to_scene(), config.solver_options())
        assert alone.success and r["solve.success"] == "true"
        assert (r["solve.stable"] == "true") == alone.stable
        worst = max(worst, abs(alone.tip["x"] - float(r["solve.tip.x"])),
                    abs(alone.tip["y"] - float(r["solve.tip.y"])),
                    abs(alone.tip["angle"] - float(r["solve.tip.angle"])))
    assert worst < 1e-8


def test_walk_stays_on_one_branch_past_the_pitchfork(walked):
    """At φ = 90° the straight rod is the state up to h_c = π/(2√2) (THEORY §6) and one buckled
    branch beyond it: the tip deflection never changes sign along the ray."""
    out, _ = walked
    hc = critical_field_transverse()
    for r in _rows(out).values():
        if r["phi [deg]"] != "90.0":
            continue
        h, y = float(r["h"]), float(r["solve.tip.y"])
        if h < hc - 1e-9:
            assert abs(y) < 1e-9
        elif h > hc + 0.05:
            assert y > 0.05


def test_results_do_not_depend_on_workers_chunks_or_resume(walked, tmp_path):
    out, _ = walked
    base = _rows(out)
    _run(RAYS, tmp_path / "two", workers=2)
    two = _rows(tmp_path / "two")
    for i, r in base.items():  # same chunks: bit for bit
        assert all(two[i][c] == r[c] for c in TIP + ["solve.energy", "status"])
    small = copy.deepcopy(RAYS)
    small["study"]["chunk_size"] = 5  # other chunks: each from rest, the same states
    _run(small, tmp_path / "small", workers=1)
    for i, r in _rows(tmp_path / "small").items():
        assert max(abs(float(r[c]) - float(base[i][c])) for c in TIP) < 1e-9

    # an interrupted run: the journal keeps 13 records (a chunk half done); the resume walks that
    # chunk again and records only the missing points, bit for bit the uninterrupted answer
    part = tmp_path / "part"
    _run(RAYS, part, workers=1)
    lines = (part / "journal.jsonl").read_text().splitlines(keepends=True)
    (part / "journal.jsonl").write_text("".join(lines[:14]))
    report = _run(RAYS, part, workers=2, resume=True)
    assert report.reused == 13 and report.computed == 42 - 13
    for i, r in _rows(part).items():
        assert all(r[c] == base[i][c] for c in TIP + ["solve.energy"])


def test_chunks_are_fixed_by_the_grid():
    plan = plan_study(RAYS, "/nonexistent/walk-plan")
    chunks = plan_chunks(plan.raw, plan.axes, plan.indices, "cartesian")
    assert sorted(i for c in chunks for i in c) == list(range(42))
    for c in chunks:  # one ray each, walked outwards in h
        assert len({plan.indices[i][0] for i in c}) == 1
        hs = [plan.axes[1].numbers[plan.indices[i][1]] for i in c]
        assert hs == sorted(hs)
    assert [len(c) for c in plan_chunks(plan.raw, plan.axes, plan.indices, "cartesian", 8)] == [8, 8, 5] * 2


def test_negative_loads_form_their_own_ray_and_a_non_ray_is_solved_alone(tmp_path):
    """p from −3 to 3 at h = 0: two rays (the tip load's sign); at h = 1 with p swept the line
    is not a ray (the field is not scaled with p) and every point is solved from rest alone."""
    cfg = {"scene": {"type": "dimensionless", "h": 0.0, "phi": "0 deg", "p": 0},
           "solver": {"elements": 2, "degree": 8},
           "study": {"type": "sweep", "sweep": {"h": [0.0, 1.0], "p": [-3.0, -1.5, 0.0, 1.5, 3.0]},
                     "analyses": ["solve"], "outputs": ["solve.tip.*", "solve.solver.from_rest.walk"]}}
    plan = plan_study(cfg, tmp_path / "x")
    chunks = plan_chunks(plan.raw, plan.axes, plan.indices, "cartesian")
    assert sorted(map(len, chunks)) == [2, 2, 3, 3]
    _run(cfg, tmp_path / "s", workers=1)
    for i, r in _rows(tmp_path / "s").items():
        h, p = (plan.axes[k].numbers[plan.indices[i][k]] for k in (0, 1))
        assert r["solve.solver.from_rest.walk"] == ("true" if h == 0.0 else "false")
        config = load_config(substitute(plan.raw, plan.axes, plan.indices[i]))
        alone = solve(config.to_scene(), config.solver_options())
        assert abs(alone.tip["y"] - float(r["solve.tip.y"])) < 1e-8
        assert abs(alone.tip["x"] - float(r["solve.tip.x"])) < 1e-8


def test_ray_test():
    ref = np.array([2.0, 5.0, 0.3, -4.0])  # slots 1 and 3 are loads
    on = [np.array([2.0, 5.0 * c, 0.3, -4.0 * c]) for c in (0.0, 0.25, 1.0)]
    assert np.allclose(_is_ray(on, [1, 3]), [0.0, 0.25, 1.0])
    off = on + [np.array([2.0, 2.5, 0.3, -1.0])]  # loads not proportional
    assert _is_ray(off, [1, 3]) is None
    moved = on + [np.array([2.1, 2.5, 0.3, -2.0])]  # a non-load slot differs
    assert _is_ray(moved, [1, 3]) is None
    assert _is_ray([ref * 0, ref * 0], [1, 3]) is None


def test_wanted_keys_keep_every_column_a_pattern_can_match():
    assert wanted_keys(None) is None
    assert wanted_keys(["solve.tip.*"]) == ["tip"]
    assert set(wanted_keys(["solve.s*"])) >= {"success", "status", "stable", "stationarity",
                                              "self_intersecting", "scales", "solver", "shape"}
    assert wanted_keys(["solve.clamp_reaction.force.0", "solve.h"]) == ["h", "clamp_reaction"]
    assert wanted_keys(["*"]) == list(wanted_keys(["solve.*"]))


@pytest.mark.parametrize("config", ["configs/study_sweep_transverse_field.yaml",
                                    "configs/permanent_magnet_dipole.yaml",
                                    "configs/combined_soft_hard_rod.yaml",
                                    "configs/varying_fibres.yaml"])
@pytest.mark.parametrize("transcription", ["lgl", "midpoint"])
def test_balance_operator_against_the_dense_shape(config, transcription):
    """Two evaluations of the moment balance: stored linear maps with exactly integrated Gauss
    interpolants, and the dense shape of the result (per-point quadrature from the breakpoints)."""
    import actuator_design.equilibrium.balance as B

    cfg = load_config(config)
    scene = cfg.to_scene()
    opts = cfg.solver_options() if transcription == "lgl" else SolverOptions(transcription="midpoint",
                                                                             elements=60)
    result = solve(scene, opts)
    solver = get_solver(scene, graded_options(scene, opts))
    if solver.transcription.nodes.size != result.z.size:
        pytest.skip("the solve chose another mesh")
    params = solver.parameter_vector(scene)
    dense = DenseShape(solver.transcription, result.z)
    stored = balance(solver, params, dense, scene, result.z)
    saved, B.MAX_NODES_STORED = B.MAX_NODES_STORED, 0
    try:
        plain = balance(solver, params, dense, scene, result.z)
    finally:
        B.MAX_NODES_STORED = saved
    scale = max(1.0, float(np.max(np.abs(plain[0]))), abs(plain[1]))
    assert np.max(np.abs(stored[0] - plain[0])) < 1e-12 * scale
    assert abs(stored[1] - plain[1]) < 1e-12 * scale
    assert abs(stored[2] - plain[2]) < 1e-12 * scale
    assert isinstance(B.operator_for(solver), BalanceOperator)


def test_vectorised_sx_replays_casadi():
    """Every replayed operation against CasADi's own evaluation at random points."""
    x, y, p = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("p", 3)
    exprs = [ca.sin(x) * p[0] + ca.cos(y) ** 2 - ca.exp(-x * x), ca.atan2(y, x) / (1 + ca.fabs(p[1])),
             ca.sqrt(x * x + y * y) + ca.log(1 + x * x) + ca.tanh(y) * ca.sign(x - 0.3),
             ca.if_else(x > y, x - y, 2 * (y - x)) + ca.fmin(x, p[2]) * ca.fmax(y, -p[2]) + x ** 3.5,
             ca.constpow(x, 2) + 1 / (2 + y) + ca.asin(0.5 * ca.tanh(x)) + 4.0]
    f = ca.Function("f", [x, y, p], exprs)
    v = VectorisedSX(f, shared=[2])
    rng = np.random.default_rng(7)
    xs, ys, ps = rng.uniform(0.05, 2, 300), rng.uniform(-2, 2, 300), rng.uniform(-1, 1, 3)
    ref = [np.asarray(o).ravel() for o in f(xs.reshape(1, -1), ys.reshape(1, -1), ps)]
    for a, b in zip(v(xs, ys, ps), ref):
        assert np.allclose(a, b, rtol=1e-14, atol=1e-14)
    a, b = ca.MX.sym("a"), ca.SX.sym("b", 2)
    with pytest.raises(NotVectorisable):
        VectorisedSX(ca.Function("m", [a], [a * 2]))
    with pytest.raises(NotVectorisable):
        VectorisedSX(ca.Function("v", [b], [b[0]]))


def test_every_builtin_analysis_name_is_registered_by_its_module():
    """The registry lists built-in names without importing them; each module registers its name."""
    from actuator_design.analysis import registry

    for name in registry.BUILTIN:
        assert callable(registry.get(name))
    assert set(registry.BUILTIN) <= set(registry.names())


def test_mixed_sign_load_sweep_walks_both_rays_and_mirrors(tmp_path):
    """p from −300 to 300 at h = 0: both rays are walked (the walk axis is found on the side of
    the largest load), each point equals a lone solve, and p ↦ −p mirrors the tip (y, θ ↦ −y, −θ)."""
    loads = [-300.0, -30.0, -3.0, 0.0, 3.0, 30.0, 300.0]
    cfg = {"scene": {"type": "dimensionless", "h": 0.0, "phi": "0 deg", "p": 0},
           "study": {"type": "sweep", "sweep": {"p": loads}, "analyses": ["solve"],
                     "outputs": ["solve.tip.*", "solve.success", "solve.solver.from_rest.walk"]}}
    _run(cfg, tmp_path / "s", workers=1)
    rows = {float(r["p"]): r for r in _rows(tmp_path / "s").values()}
    plan = plan_study(cfg, tmp_path / "x")
    for i, p in enumerate(loads):
        r = rows[p]
        assert r["solve.success"] == "true" and r["solve.solver.from_rest.walk"] == "true"
        config = load_config(substitute(plan.raw, plan.axes, plan.indices[i]))
        alone = solve(config.to_scene(), config.solver_options())
        assert max(abs(alone.tip[k] - float(r[f"solve.tip.{k}"])) for k in ("x", "y", "angle")) < 1e-8
        m = rows[-p]
        assert abs(float(r["solve.tip.x"]) - float(m["solve.tip.x"])) < 1e-9
        assert abs(float(r["solve.tip.y"]) + float(m["solve.tip.y"])) < 1e-9


REVIEW_CASES = {
    # boundary layers: each point on the mesh a lone solve grades for it (h = 5 is inaccurate on
    # the ungraded degree-5 mesh, as alone)
    "graded meshes": ({"type": "dimensionless", "h": 1.0, "phi": "60 deg", "p": 0},
                      {"elements": 4, "degree": 5}, {"h": [1.0, 5.0, 20.0, 100.0, 400.0]}),
    # just past the pitchfork h_c = 1.1107207: the branch-point kick's IPOPT answer is polished
    "near the pitchfork": ({"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
                           {"elements": 4, "degree": 10}, {"h": [1.1107, 1.110721, 1.110725, 1.11075, 1.12]}),
    # no stability checks: every point alone (a path's branch would depend on its steps)
    "no stability checks": ({"type": "dimensionless", "h": 0.0, "h_r": 1.0, "magnetization": "0 deg",
                             "phi": "179 deg", "p": 0},
                            {"elements": 4, "degree": 10, "ensure_stable": False},
                            {"h_r": [0.5, 2.4, 2.6, 3.0, 10.0]}),
}


@pytest.mark.parametrize("case", sorted(REVIEW_CASES))
def test_walk_equals_a_lone_solve_in_the_reviewed_cases(case, tmp_path):
    """Cases an independent review found to differ from a lone solve (mesh, polish, branch), each
    at the default chunks and at chunks of 2: success, stability and tip equal the lone solve's."""
    scene, solver, sweep = REVIEW_CASES[case]
    cfg = {"scene": scene, "solver": solver,
           "study": {"type": "sweep", "sweep": sweep, "analyses": ["solve"],
                     "outputs": ["solve.success", "solve.stable", "solve.tip.*"]}}
    plan = plan_study(cfg, tmp_path / "x")
    alone = []
    for idx in plan.indices:
        config = load_config(substitute(plan.raw, plan.axes, idx))
        alone.append(solve(config.to_scene(), config.solver_options()))
    for chunk in (None, 2):
        if chunk:
            cfg["study"]["chunk_size"] = chunk
        out = tmp_path / f"chunk{chunk}"
        _run(cfg, out, workers=1)
        for i, r in _rows(out).items():
            a = alone[i]
            assert (r["solve.success"] == "true") == a.success, (case, chunk, i)
            assert (r["solve.stable"] == "true") == a.stable, (case, chunk, i)
            assert max(abs(a.tip[k] - float(r[f"solve.tip.{k}"])) for k in ("x", "y", "angle")) < 1e-8
