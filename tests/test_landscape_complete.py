"""Issue 10 item 3, "complete means complete": trusted scans only, each critical point once,
stability changes located where they are, stable counts on the map.

References are independent of the code: the pitchforks h_crit^(m) = (2m − 1)π/(2√2) of the straight
rod in a transverse field (closed form), the aligned rod's boundary layer
θ = φ + 2 arctan(tan(−φ/2) e^{−√2 h s}) (closed form, infinite length) and scipy's ``solve_bvp`` on
the Euler–Lagrange equation, and the NLP's Hessian inertia against Sturm's count of the scan.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad, solve_bvp

from actuator_design.continuation.branch import CriticalPoint
from actuator_design.continuation.follow import continue_branch
from actuator_design.continuation.critical import _dedupe, critical_points
from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.analysis.multiplicity import count_row
from actuator_design.analysis.shooting_scan import scan_validity
from actuator_design.model.scene import default_scene
from actuator_design.viz.landscape import _segments

ROOT = Path(__file__).resolve().parents[1]


def hcrit(m: int) -> float:
    """Closed form: the m-th pitchfork of the straight rod in a transverse field (THEORY §8)."""
    return (2 * m - 1) * math.pi / (2 * math.sqrt(2))


def cli(*args):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "actuator_design.cli", *args], capture_output=True,
                          text=True, env=env, timeout=600)


# -- never an empty complete set ------------------------------------------------------------------
def test_high_field_scan_is_not_called_complete():
    """h = 1e4: the shooting IVP overflows; the result says so instead of 'count 0, complete'."""
    r = find_equilibria(default_scene(h=1e4, phi=math.pi / 4))
    assert not r.complete and r.count == 0
    assert "not trustworthy" in r.incomplete_reason
    d = r.to_dict()
    assert d["complete"] is False and d["incomplete_reason"]


def test_high_field_cli_exits_3_and_says_why():
    p = cli("equilibria", "--h", "1e4", "--phi-deg", "45", "--json")
    assert p.returncode == 3, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is False and d["count"] == 0 and "not trustworthy" in d["incomplete_reason"]
    assert "not complete" in p.stderr


def test_critical_over_a_huge_window_is_not_complete():
    """An incomplete list exits 3 (it may miss critical points; it exited 0 with complete: false)."""
    p = cli("critical", "--param", "h", "--window", "0,1e6", "--json")
    assert p.returncode == 3, p.stderr
    d = json.loads(p.stdout)
    assert d["complete"] is False and d["incomplete_reasons"]
    assert all(not c["complete"] for c in d["counts"] if c["at"] > 100)


def test_aligned_rod_against_boundary_layer_and_solve_bvp():
    """h = 8, φ = 45° (a trusted scan, L = 11.3): the stable aligned state is found; its θ'(0) is
    the first integral's √2 h sin φ, and its tip that of an independent BVP (and, to the finite-
    length correction e^{−√2 h}, of the infinite-length boundary layer)."""
    h, phi = 8.0, math.pi / 4
    assert scan_validity(default_scene(h=h, phi=phi), h * 1.05)["valid"]
    k = math.sqrt(2) * h
    layer = lambda s: phi + 2 * np.arctan(math.tan(-phi / 2) * np.exp(-k * s))
    s = np.linspace(0.0, 1.0, 400)
    f = lambda s, y: np.vstack([y[1], h * h * np.sin(2 * (y[0] - phi)), np.cos(y[0]), np.sin(y[0])])
    bc = lambda a, b: np.array([a[0], b[1], a[2], a[3]])
    y0 = np.vstack([layer(s), np.gradient(layer(s), s), np.cumsum(np.cos(layer(s))) / 400,
                    np.cumsum(np.sin(layer(s))) / 400])
    bvp = solve_bvp(f, bc, s, y0, tol=1e-10, max_nodes=100000)
    assert bvp.status == 0
    x_layer = quad(lambda t: math.cos(layer(t)), 0, 1, epsabs=1e-13)[0]
    r = find_equilibria(default_scene(h=h, phi=phi))
    assert r.complete
    aligned = [e for e in r.equilibria if e.stable and abs(e.tip["angle"] - phi) < 1e-2]
    assert len(aligned) == 1
    e = aligned[0]
    assert e.gamma_shooting == pytest.approx(math.sqrt(2) * h * math.sin(phi), rel=1e-6)
    assert e.tip["x"] == pytest.approx(bvp.y[2, -1], abs=1e-8)
    assert e.tip["y"] == pytest.approx(bvp.y[3, -1], abs=1e-8)
    assert e.tip["x"] == pytest.approx(x_layer, abs=5 * math.exp(-k))


def test_closest_root_pairs_are_resolved():
    """h = 10, φ = 45°: both aligned states (θ(1) → φ and φ − π) sit within e^{-2√2 h} of the
    separatrix γ = ±√2 h sin φ and beside a partner root; the scan finds both (a 401-point grid
    stepped over them, reporting 3 roots as complete)."""
    h, phi = 10.0, math.pi / 4
    r = find_equilibria(default_scene(h=h, phi=phi))
    roots = {e.gamma_shooting for e in r.equilibria} | {f["gamma_shooting"] for f in r.failures}
    for target in (math.sqrt(2) * h * math.sin(phi), -math.sqrt(2) * h * math.sin(math.pi - phi)):
        assert min(abs(g - target) for g in roots) < 1e-6 * h
    assert len(roots) >= 7


# -- critical points once, stability changes where they are ---------------------------------------
def test_pitchforks_reported_once_each_at_the_closed_form():
    r = critical_points(default_scene(h=0.0, phi=math.pi / 2), "h", (0.2, 6.0))
    vals = sorted(d["value"] for d in r.branch_points)
    assert len(vals) == 3 and not r.folds
    assert vals == pytest.approx([hcrit(1), hcrit(2), hcrit(3)], abs=1e-7)
    assert [(d["equilibria_below"], d["equilibria_above"]) for d in r.branch_points] == [(1, 3), (3, 5), (5, 7)]
    assert r.complete


def test_dedupe_tolerance_follows_the_square_root_law():
    z = np.zeros(5)
    cp = lambda v, zz, ang: CriticalPoint("branch_point", "h", v, zz, {"angle": ang}, 0, 1)
    same = _dedupe([cp(1.11072073454, z, 0.0), cp(1.1107207412, z + 9e-5, 9e-5)])
    assert len(same) == 1 and same[0].value == 1.11072073454
    assert len(_dedupe([cp(1.1107207345, z, 0.0), cp(1.1107207345, z + 0.1, 0.1)])) == 2
    assert len(_dedupe([cp(1.0, z, 0.0), cp(1.0 + 1e-5, z, 0.0)])) == 2


def test_straight_rod_loses_stability_exactly_at_the_pitchfork():
    """The branch had 17 points on [0, 6] and was drawn stable up to the step's end at h ≈ 1.54."""
    res = continue_branch(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0, 6.0)
    br = res.branch
    for m in (1, 2, 3):
        k = int(np.argmin(np.abs(br.lam - hcrit(m))))
        assert br.lam[k] == pytest.approx(hcrit(m), abs=1e-7)
        assert br.morse_index[k] == m - 1 and br.morse_index[k + 1] == m
        assert np.all(br.morse_index[:k + 1] <= m - 1)
    runs = _segments(br.lam, br.tips[:, 0], br.stable)
    stable_runs = [lam for lam, _, st in runs if st]
    assert len(stable_runs) == 1 and stable_runs[0][0] == 0.0
    assert stable_runs[0][-1] == pytest.approx(hcrit(1), abs=1e-7)


# -- stable counts on the map ---------------------------------------------------------------------
@pytest.mark.parametrize("h, phi, p", [(8.0, math.pi / 4, 0.0), (math.sqrt(5.0), 0.0, 30.0),
                                       (2.0, math.pi / 2, 0.0), (1.0, 0.0, 5.0)])
def test_map_stable_counts_match_the_nlp_inertia(h, phi, p):
    """Sturm's count of the scan (map) against the reduced Hessian's inertia of each NLP solution."""
    sc = default_scene(h=h, phi=phi, p=p)
    counts, stable = count_row([sc])
    r = find_equilibria(sc)
    assert r.complete and not r.failures
    assert (int(counts[0]), int(stable[0])) == (r.count, r.stable_count)


def test_map_json_has_stable_counts_and_bistable_regions(tmp_path):
    p = cli("map", "--x-param", "h2", "--x-range", "0,20", "--y-param", "p", "--y-range", "0,40",
            "--n", "3", "--no-curves", "--quiet", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    stable, bistable = np.array(d["stable"]), np.array(d["bistable"])
    assert np.array_equal(bistable, stable >= 2) and bistable.any() and not bistable.all()
    assert d["complete"] is True and d["incomplete_points"] == 0
    p = cli("map", "--x-param", "h", "--x-range", "0,20", "--y-param", "p", "--y-range", "0,1",
            "--n", "3,2", "--no-curves", "--quiet", "--json")
    d = json.loads(p.stdout)
    assert d["complete"] is False and np.array(d["counts"])[:, -1].tolist() == [-1, -1]
    assert np.all(np.array(d["counts"])[:, 0] == 1)
