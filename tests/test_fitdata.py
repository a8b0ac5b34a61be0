"""Measured-data CSV files: units in the header, and bad data that gets one clear line.

Unit conversions are checked against hand-computed SI values (1 kA/m = 1000 A/m, 1 mT → 1e-3/μ0
A/m, 1 deg = π/180 rad, 1 mm = 1e-3 m); every bad file must fail with a message naming the
column and/or the row, from the API (DataError) and from the CLI (exit 2, one line, nothing
written).
"""
import math
from pathlib import Path

import numpy as np
import pytest

from actuator_design.cli.main import main
from actuator_design.calibration import DataError, parse_data

MU0 = 4e-7 * math.pi
ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "fit_transverse_buckling.yaml"


def test_units_are_converted_to_si():
    d = parse_data("# a comment, with a comma\n"
                   "field [mT], field_angle [deg], load [mN], tip_x [mm], tip_y [cm]\n"
                   "10, 90, 0.5, 20, 1\n"
                   "\n"
                   "20, 45, 1.0, 19, 2\n", source="x.csv")
    assert d.n == 2
    assert d.comments == ["a comment, with a comma"]
    np.testing.assert_allclose(d.columns["field"], [10e-3 / MU0, 20e-3 / MU0], rtol=1e-14)
    np.testing.assert_allclose(d.columns["field_angle"], [math.pi / 2, math.pi / 4], rtol=1e-14)
    np.testing.assert_allclose(d.columns["load"], [0.5e-3, 1.0e-3], rtol=1e-14)
    np.testing.assert_allclose(d.columns["tip_x"], [0.020, 0.019], rtol=1e-14)
    np.testing.assert_allclose(d.columns["tip_y"], [0.01, 0.02], rtol=1e-14)
    assert d.inputs == ["field", "field_angle", "load"] and d.outputs == ["tip_x", "tip_y"]
    np.testing.assert_allclose(d.as_given("tip_y"), [1.0, 2.0])
    assert list(d.lines) == [3, 5]


def test_dimensionless_scene_reads_lengths_in_rod_lengths():
    d = parse_data("load [1], tip_y [l]\n0, 0\n1, 0.3\n", dimensionless=True)
    np.testing.assert_allclose(d.columns["tip_y"], [0.0, 0.3])
    with pytest.raises(DataError, match=r"column 'tip_y'.*dimensionless.*\[l\]"):
        parse_data("load [1], tip_y [mm]\n0, 0\n1, 0.3\n", dimensionless=True)


@pytest.mark.parametrize("text, pattern", [
    ("field [kA/m]\n1\n2\n", r"no measured output column"),
    ("field [kA/m], tip_angle [mm]\n1, 2\n2, 3\n", r"column 'tip_angle': unit 'mm'"),
    ("field [deg], tip_angle [deg]\n1, 2\n2, 3\n", r"column 'field': unit 'deg'"),
    ("field, tip_angle [deg]\n1, 2\n2, 3\n", r"column 'field': give its unit"),
    ("field [kA/m], tip_angle\n1, 2\n2, 3\n", r"column 'tip_angle': give its unit"),
    ("field [kA/m], tip_angle [deg]\n1, 2\n2, nan\n3, 4\n", r"column 'tip_angle', row 2 \(line 3\): missing"),
    ("field [kA/m], tip_angle [deg]\n1, 2\n, 3\n", r"column 'field', row 2 \(line 3\): missing"),
    ("field [kA/m], tip_angle [deg]\n1, 2\n2, abc\n", r"column 'tip_angle', row 2 \(line 3\): not a number"),
    ("field [kA/m], tip_angle [deg]\n1, 2\n2, inf\n", r"row 2 \(line 3\): must be a finite"),
    ("field [kA/m], tip_angle [deg]\n1, 2, 3\n", r"row 1 \(line 2\): expected 2 values"),
    ("field [kA/m], tip_angle [deg]\n1, 2\n", r"1 data row: at least 2"),
    ("field [kA/m], tip_angel [deg]\n1, 2\n2, 3\n", r"column 'tip_angel': unknown column \(did you mean 'tip_angle'"),
    ("field [kA/m], field [mT], tip_angle [deg]\n1, 2, 3\n", r"column 'field': appears twice"),
    ("field [kA/m, tip_angle [deg]\n1, 2\n", r"cannot read column header"),
    ("# only a comment\n", r"no header line"),
])
def test_bad_data_is_one_clear_line(text, pattern):
    with pytest.raises(DataError, match=pattern) as info:
        parse_data(text, source="data.csv")
    assert "\n" not in str(info.value)
    assert str(info.value).startswith("data.csv")


def test_ignored_columns():
    d = parse_data("sample, field [kA/m], tip_angle [deg]\nA, 1, 2\nB, 2, 3\n",
                   ignore_columns=["sample"])
    assert list(d.columns) == ["field", "tip_angle"]


@pytest.mark.parametrize("text, pattern", [
    ("field [kA/m]\n1\n2\n", "no measured output column"),
    ("field [kA/m], tip_angle [mm]\n1, 2\n2, 3\n", "column 'tip_angle'"),
    ("field [kA/m], tip_angle [deg]\n1, 2\nnan, 2\n3, 4\n", "column 'field', row 2"),
    ("field [kA/m], tip_angle [deg]\n1, 2\n", "1 data row"),
    # two rows, two parameters (chi_bar, clamp_angle): more measurements than parameters needed
    ("field [kA/m], tip_angle [deg]\n1, 2\n2, 3\n", "cannot determine 2 parameter"),
])
def test_cli_bad_data_exit_2_one_line_nothing_written(tmp_path, capsys, text, pattern):
    data = tmp_path / "data.csv"
    data.write_text(text)
    out = tmp_path / "out"
    code = main(["fit", str(CONFIG), "--data", str(data), "--out", str(out)])
    _, err = capsys.readouterr()
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("actuator-design: error: ")
    assert pattern in lines[0]
    assert not out.exists()


def test_cli_field_scale_needs_field_column(tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(CONFIG.read_text().replace("clamp_angle: {initial: 0 deg, bounds: [-5 deg, 5 deg]}",
                                              "field_scale: {initial: 1, bounds: [0.5, 2]}"))
    data = tmp_path / "data.csv"
    data.write_text("field_angle [deg], tip_angle [deg]\n80, 2\n85, 3\n90, 4\n")
    code = main(["fit", str(cfg), "--data", str(data)])
    err = capsys.readouterr().err
    assert code == 2 and "column 'field' missing" in err and "field_scale" in err


@pytest.mark.parametrize("edit, field", [
    (("chi_bar: {initial: 0.3, bounds: [0.01, 5]}", "chi_bar: {initial: 0.3, bounds: [0, 5]}"),
     "study.parameters.chi_bar.bounds"),
    (("chi_bar: {initial: 0.3, bounds: [0.01, 5]}", "chi_bar: {initial: 9, bounds: [0.01, 5]}"),
     "study.parameters.chi_bar.initial"),
    (("chi_bar: {initial: 0.3, bounds: [0.01, 5]}", "chi: {initial: 0.3}"),
     "study.parameters.chi"),
    (("clamp_angle: {initial: 0 deg, bounds: [-5 deg, 5 deg]}",
      "clamp_angle: {initial: 0 deg, bounds: [-5 mm, 5 deg]}"), "study.parameters.clamp_angle.bounds"),
    (("confidence: 0.95", "confidence: 1.5"), "study.confidence"),
    (("confidence: 0.95", "confidnce: 0.95"), "study.confidnce"),
    (("uncertainty: {tip_angle: 0.5 deg}", "uncertainty: {tip_angle: 0.5 mm}"), "study.uncertainty.tip_angle"),
])
def test_cli_bad_fit_spec_names_the_field(tmp_path, capsys, edit, field):
    cfg = tmp_path / "c.yaml"
    text = CONFIG.read_text()
    assert edit[0] in text
    cfg.write_text(text.replace(edit[0], edit[1]))
    code = main(["fit", str(cfg), "--data", str(ROOT / "problems/data/synthetic_transverse_buckling.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert err.startswith(f"actuator-design: error: {field}:"), err


# -- files that are not data files, and data the model cannot explain (issue 22) -------------------
def _fit_cli(tmp_path, capsys, data):
    out = tmp_path / "out"
    code = main(["fit", str(CONFIG), "--data", str(data), "--out", str(out)])
    printed, err = capsys.readouterr()
    return code, [ln for ln in err.splitlines() if ln.strip()], out, printed


def test_a_fifo_or_a_device_is_one_line_not_a_hang(tmp_path, capsys):
    """A FIFO with no writer blocked the read forever; /dev/zero was read until memory ran out."""
    import os
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    for data in (fifo, Path("/dev/zero"), tmp_path):
        code, lines, out, _ = _fit_cli(tmp_path, capsys, data)
        assert code == 2 and len(lines) == 1 and "regular file" in lines[0], lines
        assert not out.exists()


def test_data_the_model_cannot_explain_is_not_a_success(tmp_path, capsys):
    """170° tip angles at 0.1–1 kA/m (the transverse rod barely bends there: |angle| < 1° for any
    admissible chi_bar by the low-field linearisation) with σ = 0.5°: a non-zero exit naming the
    parameters at their bounds and the failed χ² test, where it said success (issue 22)."""
    data = tmp_path / "data.csv"
    rows = "\n".join(f"{0.1 * k:.1f}, 170" for k in range(1, 11))
    data.write_text("field [kA/m], tip_angle [deg]\n" + rows + "\n")
    code, lines, _, printed = _fit_cli(tmp_path, capsys, data)
    assert code == 3
    text = printed + " ".join(lines)
    assert "bound" in text and "chi-square" in text, text
    if "clamp_angle = " in text:  # an angle bound is echoed in the degrees the config gave it in
        assert "bound 0.0872665 rad (5 deg)" in text, text
