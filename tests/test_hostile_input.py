"""Hostile input is bounded (issue 10 item 4): every case exits 2 with one line naming the field,
writes nothing, and finishes in seconds.

The cases that hung or exhausted memory before (alias bomb, deep nesting, huge expressions,
``10**10**10``, huge meshes) run the command line in a subprocess whose timeout is the guard against
a hang (no timing assertion); the others call ``main`` in-process. References are independent of the code under test: the LGL node of the
NaN-near-a-node case comes from the roots of P'_d (numpy's Legendre module), the overflow cases
from IEEE float64 limits.
"""
import contextlib
import io
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import legendre

from actuator_design.cli.main import main
from cli_checks import assert_rejected

ROOT = Path(__file__).resolve().parents[1]
GUARD_S = 120  # a hostile case must not hang: the subprocess is killed after this many seconds

PHYSICAL = """\
scene:
  type: physical
  rod: {{length: "{length}", width: 10 mm, thickness: 1 mm, youngs_modulus: "{modulus}"}}
  magnetics: {{chi_bar: 0.5}}
  field: {{type: uniform, magnitude: "{magnitude}", angle: 90 deg}}
"""


def physical(length="0.1 m", modulus="1 MPa", magnitude="10 kA/m") -> str:
    return PHYSICAL.format(length=length, modulus=modulus, magnitude=magnitude)


def cli(tmp_path, *argv, config_text=None, config_bytes=None, command="solve", isolated=False):
    """Run ``actuator-design <command> [CONFIG] argv --out <tmp>/out``; (exit code, stdout, stderr).

    ``isolated``: in a subprocess killed after :data:`GUARD_S` seconds; otherwise ``main`` in-process
    (stdout and stderr captured)."""
    args = [command]
    if config_text is not None or config_bytes is not None:
        path = tmp_path / "hostile.yaml"
        if config_bytes is not None:
            path.write_bytes(config_bytes)
        else:
            path.write_text(config_text, encoding="utf-8")
        args.append(str(path))
    args += [str(a) for a in argv]
    if command == "solve":
        args += ["--out", str(tmp_path / "out")]
    if not isolated:
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(args)
        return code, out.getvalue(), err.getvalue()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    p = subprocess.run([sys.executable, "-m", "actuator_design.cli.main", *args], capture_output=True,
                       text=True, env=env, cwd=tmp_path, timeout=GUARD_S)
    return p.returncode, p.stdout, p.stderr


# -- derived groups after unit conversion ------------------------------------------------------------
@pytest.mark.parametrize("kwargs, names", [
    ({"length": "1e308 m"}, ["scene.h", "rod.length = 1e+308"]),
    ({"magnitude": "1e308 A/m"}, ["scene.h", "field.magnitude = 1e+308"]),
    ({"modulus": "1e-308 Pa"}, ["scene.h", "rod.youngs_modulus = 1e-308"]),
    ({"length": "1e-300 m"}, ["rod.length", "B0/l^2"]),  # ℓ² underflows (issue 22)
])
def test_extreme_physical_values_name_the_field(tmp_path, kwargs, names):
    # 1e308² overflows float64 (max ≈ 1.8e308); 1e-308 Pa × (10 mm)(1 mm)³/12 ≈ 8e-321 N m² is
    # subnormal, so h² ∝ 1/B0 overflows
    assert_rejected(cli(tmp_path, config_text=physical(**kwargs)), tmp_path, *names)


@pytest.mark.parametrize("length", ["10**10**10 m", "(10**9)**9 m", "2**10000 m", "1e308 km"])
def test_quantity_towers_and_conversion_overflow(tmp_path, length):
    # pint evaluates "10**10**10" with Python integers (minutes); 1e308 km is 1e311 m > 1.8e308
    assert 1e308 * 1e3 == math.inf
    assert_rejected(cli(tmp_path, config_text=physical(length=length), isolated="**" in length),
                    tmp_path, "scene.rod.length")


def test_in_range_physical_scene_still_solves(tmp_path):
    code, out, err = cli(tmp_path, "--json", config_text=physical())
    assert code == 0, err
    # h² = μ0 χ̄ H0² A ℓ² / (2 E w t³/12), THEORY §5, by hand
    mu0, chi, H0, A, ell = 4e-7 * math.pi, 0.5, 1e4, 1e-5, 0.1
    B0 = 1e6 * 1e-2 * 1e-9 / 12
    assert json.loads(out)["h"] == pytest.approx(math.sqrt(mu0 * chi * H0**2 * A * ell**2 / (2 * B0)))


def test_bending_stiffness_that_underflows_to_zero(tmp_path):
    # 1e-320 Pa × 1e-2 m × (1e-3 m)³ / 12 is below the smallest subnormal (4.9e-324): B0 = 0
    assert 1e-320 * 1e-2 * 1e-3**3 / 12 == 0.0
    assert_rejected(cli(tmp_path, config_text=physical(modulus="1e-320 Pa")), tmp_path,
                    "scene.rod.youngs_modulus", "B0")


@pytest.mark.parametrize("scene, field", [
    ("h: 1.0e5", "scene.h"),
    ("h: 1\n  h_pos: 2.0e4", "scene.h_pos"),
    ("p: -2.0e5", "scene.p"),
    ("tip_force: {x: 1.0e6, y: 0}", "scene.tip_force.x"),
    ("tip_moment: 1.0e300", "scene.tip_moment"),
    ("distributed_load: {x: 0, y: -1.0e9}", "scene.distributed_load.y"),
    ("h: " + "9" * 400, "scene.h"),  # YAML reads it as an int beyond the float range
    ("terms: {foundation: {k_foundation: -" + "9" * 400 + "}}", "scene.terms.foundation.k_foundation"),
    ("terms: {foundation: {k_foundation: 2.0e10}}", "scene.terms.foundation.k_foundation"),
])
def test_dimensionless_groups_out_of_range(tmp_path, scene, field):
    text = f"scene:\n  type: dimensionless\n  {scene}\n"
    assert_rejected(cli(tmp_path, config_text=text), tmp_path, field)


# -- flags -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("argv, flag", [
    (["--h", "1e155"], "--h"),
    (["--p", "-1e300"], "--p"),
    (["--elements", "10000000"], "--elements"),
    (["--transcription", "midpoint", "--elements", "1000000"], "--elements"),
    (["--phi-deg", "1e30"], "--phi-deg"),  # issue 22: an angle whose reduction mod 360° is noise
    (["--alpha-deg", "-2e6"], "--alpha-deg"),
])
def test_flags_out_of_range(tmp_path, argv, flag):
    assert_rejected(cli(tmp_path, *argv, isolated="--elements" in argv), tmp_path, flag)


def test_negative_numbers_are_flag_values(tmp_path):
    """``--p -1e3`` reads as ``--p=-1e3`` (argparse's own pattern took it for an option)."""
    results = []
    for argv in (["--p", "-1e3"], ["--p=-1e3"], ["--p", "-1000.0"]):
        code, out, err = cli(tmp_path, *argv, "--h", "0", "--json", command="solve")
        assert code in (0, 3), err
        results.append(json.loads(out))
    assert all(r["p"] == -1000.0 for r in results)
    assert results[0]["tip"] == results[1]["tip"] == results[2]["tip"]


def test_negative_exponent_values_for_every_numeric_flag(tmp_path):
    code, out, err = cli(tmp_path, "--phi-deg", "-4.5e1", "--alpha-deg", "-1e-3", "--h", "5e-1",
                         "--json", command="solve")
    assert code == 0, err
    d = json.loads(out)
    assert d["phi"] == pytest.approx(math.radians(-45.0))


# -- YAML ----------------------------------------------------------------------------------------------
def test_alias_bomb_is_rejected_quickly(tmp_path):
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for k in range(1, 10):  # 9 levels of 9 aliases: 9^10 ≈ 3.5e9 values once expanded
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 9) + "]")
    text = "scene: {type: dimensionless, h: 1}\nstudy:\n  type: sweep\n" + "".join(
        f"  {ln}\n" for ln in lines)
    for command in ("solve", "validate"):
        assert_rejected(cli(tmp_path, config_text=text, command=command, isolated=True), tmp_path,
                        "expands to more than")


def test_too_many_aliases(tmp_path):
    text = "scene: {type: dimensionless, h: 1}\nstudy:\n  x: &x 1\n  y: [" + ", ".join(["*x"] * 150) + "]\n"
    assert_rejected(cli(tmp_path, config_text=text), tmp_path, "aliases", "hostile.yaml")


def test_deep_yaml_nesting(tmp_path):
    text = "scene: {type: dimensionless, h: 1}\nstudy: " + "[" * 20000 + "]" * 20000 + "\n"
    assert_rejected(cli(tmp_path, config_text=text, isolated=True), tmp_path, "nesting", "hostile.yaml")


def test_duplicate_keys_name_the_key_and_lines(tmp_path):
    text = "scene:\n  type: dimensionless\n  h: 1\n  h: 2\n"
    assert_rejected(cli(tmp_path, config_text=text), tmp_path, "duplicate key 'h'", "line 4",
                    "line 3")


def test_not_utf8_names_the_file(tmp_path):
    data = "scene:\n  type: dimensionless\n  h: 1\nname: caf\u00e9\n".encode("latin-1")
    assert_rejected(cli(tmp_path, config_bytes=data), tmp_path, "hostile.yaml", "UTF-8")


def test_oversized_file(tmp_path):
    text = "scene: {type: dimensionless, h: 1}\n" + "# padding\n" * 120_000  # > 1 MiB
    assert len(text.encode()) > 1 << 20
    assert_rejected(cli(tmp_path, config_text=text), tmp_path, "hostile.yaml", "1 MiB")


# -- expressions ---------------------------------------------------------------------------------------
FIELD = """\
scene:
  type: dimensionless
  h: 1
  field: {{type: expression, hx: "{hx}", hy: "0"}}
"""


@pytest.mark.parametrize("hx", ["1/0", "10**10**10", "log(0)*x", "exp(1e6) + x"])
def test_non_finite_field_expressions(tmp_path, hx):
    assert_rejected(cli(tmp_path, config_text=FIELD.format(hx=hx), isolated=hx == "10**10**10"),
                    tmp_path, "scene.field.hx")


@pytest.mark.parametrize("hx, what", [
    ("(" * 20000 + "x" + ")" * 20000, "too long"),
    ("+".join(["x"] * 200000), "too long"),
    ("-" * 5000 + "x", "nested deeper"),
])
def test_huge_and_deep_expressions(tmp_path, hx, what):
    assert_rejected(cli(tmp_path, config_text=FIELD.format(hx=hx), isolated=True), tmp_path,
                    "scene.field.hx", what)


def _first_interior_lgl_node(elements: int, degree: int) -> float:
    """The first interior LGL node of element 0: a root of P'_degree mapped to [0, 1/elements]."""
    c = np.zeros(degree + 1)
    c[-1] = 1.0
    tau = np.sort(legendre.legroots(legendre.legder(c)))[0]
    return (tau + 1.0) / 2.0 / elements


def test_fibre_expression_nan_only_near_a_collocation_node(tmp_path):
    s_node = _first_interior_lgl_node(4, 10)
    expr = f"0.1 + 0*sqrt(abs(s - {s_node!r}) - 1e-9)"
    grid = np.linspace(0.0, 1.0, 201)  # the old check's grid: finite there, so it passed before
    with np.errstate(invalid="ignore"):
        assert np.all(np.isfinite(0.1 + 0 * np.sqrt(np.abs(grid - s_node) - 1e-9)))
        assert np.isnan(0.1 + 0 * np.sqrt(np.abs(s_node - s_node) - 1e-9))
    text = (f"scene:\n  type: dimensionless\n  h: 1\n  fibres: {{type: expression, expression: "
            f"\"{expr}\"}}\nsolver: {{transcription: lgl, elements: 4, degree: 10}}\n")
    assert_rejected(cli(tmp_path, config_text=text), tmp_path, "scene.fibres.expression")


def test_dense_mesh_in_a_non_uniform_field(tmp_path):
    text = ("scene:\n  type: dimensionless\n  h: 1\n  field: {type: dipole, position: {x: 0.5, y: 0.5}}\n"
            "solver: {transcription: midpoint, elements: 1000}\n")
    assert_rejected(cli(tmp_path, config_text=text), tmp_path, "solver.elements", "200")


def test_a_tolerance_given_twice_is_refused(tmp_path):
    """``--tolerance field=5%,field=10%`` (issue 22): the later value silently won; now one line
    naming the key, exit 2, before any work."""
    code, out, err = cli(tmp_path, "--target-tip=0.3,0.5", "--tolerance", "field=5%,field=10%",
                         command="design")
    assert code == 2 and out == "" and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and "'field'" in err and "twice" in err


def test_an_empty_out_folder_is_refused(tmp_path, monkeypatch):
    """``--out ''`` wrote result.json, shape.csv and shape.png into the current directory."""
    monkeypatch.chdir(tmp_path)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["solve", "--out", ""])
    assert code == 2 and out.getvalue() == "" and "--out" in err.getvalue()
    assert list(tmp_path.iterdir()) == []


def test_a_map_range_beyond_a_group_range_is_refused(tmp_path):
    """``map --y-param p --y-range 0,1e9`` overflowed (OverflowError) sizing the γ scan; the map's
    corners are now checked against the group ranges of ``config.limits`` before any work."""
    code, out, err = cli(tmp_path, "--y-param", "p", "--y-range", "0,1e9", command="map")
    assert code == 2 and out == "" and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and "p = 1e+09" in err and "100000" in err
