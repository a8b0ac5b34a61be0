"""results.nc (issue 21, item 6): a study's results as a labelled N-dimensional array.

Every check reads the dataset back with ``xarray.open_dataset(..., engine="scipy")`` and compares
it with results.csv parsed here with the csv module (not with the code that wrote either file): the
dimensions and coordinates are the swept values, each CSV row's cells equal the dataset at that
point, units are the ones the table states. A partial study (interrupted in-process after one
walked chunk) has NaN and ``not_run`` where no point was computed and writes no results.nc; its
resume writes the clean run's dataset.
"""
import csv
import io
import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import actuator_design
from actuator_design.analysis import registry
from actuator_design.cli.main import main
from actuator_design.io.safe_files import OutputFolderError
from actuator_design.study import worker
from actuator_design.study.dataset import build_dataset, column_units, dataset_bytes
from actuator_design.study.outputs import build_table
from actuator_design.study.plan import journal_records
from actuator_design.study.runner import StudyInterrupted, plan_study, run_study

# a 2 × 3 grid of forward solves in three chunks of two points
GRID = {
    "name": "dataset test sweep",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "grid": "cartesian",
              "sweep": {"h": [0.5, 1.5], "phi": ["30 deg", "60 deg", "90 deg"]},
              "analyses": ["solve"], "chunk_size": 2},
}
H, PHI = [0.5, 1.5], [30.0, 60.0, 90.0]

ZIP = {
    "name": "dataset zip sweep",
    "scene": {"type": "physical",
              "rod": {"length": "20 mm", "width": "5 mm", "thickness": "0.5 mm",
                      "youngs_modulus": "1 MPa"},
              "magnetics": {"chi_bar": 0.5},
              "field": {"type": "uniform", "magnitude": "1 kA/m", "angle": "0 deg"}},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "grid": "zip",
              "sweep": {"field.magnitude": ["2 kA/m", "4 kA/m", "6 kA/m"],
                        "field.angle": ["10 deg", "30 deg", "60 deg"]},
              "analyses": ["solve"], "outputs": ["solve.tip.*", "solve.success"]},
}

#: every timing (wall time) differs between runs; everything else of a resumed study is the clean
#: run's, bit for bit
TIMINGS = ("time_s", "solve.solver.solve_time_s", "solve.solver.build_time_s")


def _write_config(folder: Path, cfg: dict) -> Path:
    path = folder / "study.yaml"
    path.write_text(json.dumps(cfg))
    return path


def _rows(folder: Path):
    with open(folder / "results.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _open(folder: Path, **kw):
    with xr.open_dataset(folder / "results.nc", engine="scipy", **kw) as ds:
        return ds.load()


def _kinds(rows):
    """Column → "bool", "number" or "text" from the CSV's cells (empty columns left out)."""
    out = {}
    for col in rows[0]:
        cells = [r[col] for r in rows if r[col] != ""]
        if not cells:
            continue
        if all(c in ("true", "false") for c in cells):
            out[col] = "bool"
            continue
        try:
            [float(c) for c in cells]
            out[col] = "number"
        except ValueError:
            out[col] = "text"
    return out


def _status_words(var):
    meanings = var.attrs["flag_meanings"].split()
    assert list(var.attrs["flag_values"]) == list(range(len(meanings)))
    return np.vectorize(lambda c: meanings[int(c)])(var.values)


def _cli(argv, capsys):
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """A clean, complete run of GRID from a config file: (folder, config path, stdout)."""
    root = tmp_path_factory.mktemp("clean")
    path = _write_config(root, GRID)
    out = root / "s"
    code = main(["study", str(path), "--out", str(out), "--workers", "1", "--no-progress"])
    assert code == 0
    return out, path


# -- layout --------------------------------------------------------------------------------------
def test_dims_coordinates_units_and_attributes(clean):
    out, path = clean
    ds = _open(out)
    rows = _rows(out)
    assert dict(ds.sizes) == {"h": 2, "phi": 3} and list(ds["solve.tip.angle"].dims) == ["h", "phi"]
    assert ds.h.values.tolist() == H and ds.phi.values.tolist() == PHI
    assert ds.h.attrs["units"] == "1" and ds.phi.attrs["units"] == "deg"  # as written in the YAML
    assert ds.phi.attrs["csv_column"] == "phi [deg]"
    # units: the table's own labels (solve.units.*) and name endings, nothing else
    r = rows[0]
    assert ds["solve.tip.angle"].attrs["units"] == r["solve.units.angle"] == "rad"
    assert ds["solve.tip.x"].attrs["units"] == ds["solve.tip.y"].attrs["units"] \
        == r["solve.units.length"]
    assert ds["solve.energy"].attrs["units"] == r["solve.units.energy"]
    assert ds["solve.clamp_reaction.force.1"].attrs["units"] == r["solve.units.force"]
    assert ds["solve.clamp_reaction.moment"].attrs["units"] == r["solve.units.moment"]
    assert ds["time_s"].attrs["units"] == "s" and ds["solve.solver.solve_time_s"].attrs["units"] == "s"
    for name in ("solve.h", "solve.gamma", "solve.morse_index", "point", "status"):
        assert "units" not in ds[name].attrs, name
    assert ds.attrs["config_path"] == str(path.resolve())
    assert ds.attrs["config_name"] == GRID["name"]
    assert ds.attrs["actuator_design_version"] == actuator_design.__version__
    assert ds.attrs["grid"] == "cartesian" and ds.attrs["n_points"] == 6 == ds.attrs["n_run"]
    # the study's summary and manifest name the file; no temporary file is left
    m = json.loads((out / "manifest.json").read_text())
    assert m["files"]["netcdf"] == "results.nc"
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]


def test_the_summary_names_the_dataset(clean, tmp_path, capsys):
    out, path = clean
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    code, stdout, _ = _cli(["study", path, "--out", copy, "--workers", "1", "--no-progress",
                            "--resume"], capsys)
    assert code == 0
    assert any(line.split() == ["netcdf", ":", "results.nc"] for line in stdout.splitlines()), stdout


def test_every_csv_cell_equals_the_dataset_at_its_point(clean):
    out, _ = clean
    ds = _open(out)
    rows = _rows(out)
    kinds = _kinds(rows)
    axes_cols = {"h", "phi [deg]"}
    wanted = {c for c, k in kinds.items() if k in ("bool", "number")} - axes_cols - {"point"}
    assert set(ds.data_vars) == wanted | {"point", "status"}
    assert len(rows) == 6
    seen = set()
    for r in rows:
        at = ds.sel(h=float(r["h"]), phi=float(r["phi [deg]"]))
        seen.add((float(r["h"]), float(r["phi [deg]"])))
        assert int(at["point"]) == int(r["point"])
        assert _status_words(at["status"]) == r["status"] == "ok"
        for col in wanted:
            value = float(at[col])
            cell = r[col]
            if cell == "":
                assert math.isnan(value), col
            elif kinds[col] == "bool":
                assert ds[col].dtype == np.int8 and value == (1.0 if cell == "true" else 0.0), col
            else:
                assert value == float(cell), (col, value, cell)
    assert seen == {(h, p) for h in H for p in PHI}


def test_a_zipped_sweep_has_one_point_dimension(tmp_path):
    run_study(ZIP, tmp_path / "z", workers=1, progress=False)
    ds = _open(tmp_path / "z")
    rows = _rows(tmp_path / "z")
    assert dict(ds.sizes) == {"point": 3}
    assert ds.point.values.tolist() == [0, 1, 2]
    mag, ang = ds["field.magnitude"], ds["field.angle"]
    assert mag.dims == ("point",) and mag.attrs["units"] == "kA/m" and ang.attrs["units"] == "deg"
    assert mag.values.tolist() == [float(r["field.magnitude [kA/m]"]) for r in rows] == [2, 4, 6]
    assert ang.values.tolist() == [float(r["field.angle [deg]"]) for r in rows] == [10, 30, 60]
    assert ds["solve.success"].dtype == np.int8 and ds["solve.success"].values.tolist() == [1, 1, 1]
    for r in rows:
        i = int(r["point"])
        for col in ("solve.tip.x", "solve.tip.y", "solve.tip.angle"):
            assert float(ds[col][i]) == float(r[col])
            assert "units" not in ds[col].attrs  # the outputs kept no unit labels: none is guessed
    assert "config_path" not in ds.attrs and ds.attrs["grid"] == "zip"


# -- failed and missing points --------------------------------------------------------------------
@pytest.fixture
def flaky():
    """An analysis that raises for h > 1 (its points are 'error') and labels its unit."""
    name = "dataset_test_flaky"

    @registry.register(name)
    def _flaky(scene, options):
        if scene.h > 1.0:
            raise RuntimeError("refused")
        return {"value": 2.0 * scene.h, "ok": True, "units": {"value": "mm"}}

    yield name
    registry._ANALYSES.pop(name, None)


def test_a_failed_point_is_nan_with_status_error(tmp_path, flaky):
    cfg = json.loads(json.dumps(GRID))
    cfg["study"]["sweep"] = {"h": [0.5, 1.5], "phi": ["30 deg", "90 deg"]}
    cfg["study"]["analyses"] = ["solve", flaky]
    run_study(cfg, tmp_path / "f", workers=1, progress=False)
    ds = _open(tmp_path / "f")
    raw = _open(tmp_path / "f", mask_and_scale=False)
    rows = {(float(r["h"]), float(r["phi [deg]"])): r for r in _rows(tmp_path / "f")}
    assert ds[f"{flaky}.value"].attrs["units"] == "mm"
    assert raw[f"{flaky}.ok"].dtype == np.int8 and raw[f"{flaky}.ok"].attrs["_FillValue"] == -1
    for (h, phi), r in rows.items():
        at = ds.sel(h=h, phi=phi)
        assert _status_words(at["status"]) == r["status"] == ("error" if h > 1 else "ok")
        value, ok = float(at[f"{flaky}.value"]), float(at[f"{flaky}.ok"])
        if h > 1:
            assert r[f"{flaky}.value"] == "" and math.isnan(value) and math.isnan(ok)
            assert int(raw[f"{flaky}.ok"].sel(h=h, phi=phi)) == -1
        else:
            assert value == float(r[f"{flaky}.value"]) == 2 * h and ok == 1.0
        assert float(at["solve.tip.angle"]) == float(r["solve.tip.angle"])  # solve ran there


def test_an_interrupted_study_writes_no_dataset_and_its_resume_the_clean_one(clean, tmp_path,
                                                                            monkeypatch, capsys):
    done, path = clean
    out = tmp_path / "part"
    real, calls = worker.run_chunk, []

    def interrupted_after_one_chunk(task):
        calls.append(task)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(task)

    with monkeypatch.context() as m:
        m.setattr(worker, "run_chunk", interrupted_after_one_chunk)
        with pytest.raises(StudyInterrupted):
            run_study(plan_study(path, out), workers=1, progress=False)
    assert not (out / "results.nc").exists() and not (out / "results.csv").exists()
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]

    # the partial table on the grid: the journaled ray, NaN and not_run elsewhere
    plan = plan_study(path, out, resume=True)
    records = journal_records(plan).records
    assert len(records) == 2
    table = build_table(plan.axes, plan.indices, records, plan.spec.outputs)
    part = xr.open_dataset(io.BytesIO(dataset_bytes(
        build_dataset(plan.axes, plan.indices, plan.spec.grid, table))), engine="scipy").load()
    full = _open(done)
    words = _status_words(part["status"])
    run_cells = {(plan.indices[i][0], plan.indices[i][1]) for i in records}
    assert part.attrs["n_run"] == 2 and part.attrs["n_points"] == 6
    for a in range(2):
        for b in range(3):
            at, ref = part.isel(h=a, phi=b), full.isel(h=a, phi=b)
            if (a, b) in run_cells:
                assert words[a, b] == "ok"
                assert float(at["solve.tip.angle"]) == float(ref["solve.tip.angle"])
                assert float(at["solve.success"]) == 1.0
            else:
                assert words[a, b] == "not_run"
                assert int(at["point"]) == int(ref["point"])  # the grid index is known
                assert all(math.isnan(float(at[v])) for v in part.data_vars
                           if v not in ("point", "status")), (a, b)

    code, _, err = _cli(["study", path, "--out", out, "--workers", "1", "--no-progress", "--resume"],
                        capsys)
    assert code == 0, err
    resumed = _open(out)
    assert set(resumed.data_vars) == set(full.data_vars)
    for name in resumed.variables:
        if name in TIMINGS:
            continue
        xr.testing.assert_identical(resumed[name].variable, full[name].variable)  # values, attrs
    assert resumed.attrs == full.attrs
    assert xr.Dataset.identical(resumed.drop_vars(TIMINGS), full.drop_vars(TIMINGS))


# -- files ----------------------------------------------------------------------------------------
@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="the fake file system needs Linux")
def test_a_refused_write_leaves_no_half_dataset_and_resume_writes_it(clean, tmp_path, monkeypatch,
                                                                    capsys):
    from hostile_fs_fakes import FakeFS

    done, path = clean
    out = tmp_path / "disk" / "s"
    with monkeypatch.context() as m:
        FakeFS(m, tmp_path / "disk", "ENOSPC", full_after=100, only=".results.nc")
        code, _, err = _cli(["study", path, "--out", out, "--workers", "1", "--no-progress"], capsys)
    assert code == 3 and "--resume" in err
    assert not (out / "results.nc").exists()
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]
    code, stdout, err = _cli(["study", path, "--out", out, "--workers", "1", "--no-progress",
                              "--resume", "--json"], capsys)
    assert code == 0, err
    assert json.loads(stdout)["computed"] == 0 and json.loads(stdout)["files"]["netcdf"] == "results.nc"
    assert _open(out)["solve.tip.angle"].equals(_open(done)["solve.tip.angle"])


def test_a_linked_results_nc_is_refused(tmp_path):
    out = tmp_path / "s"
    out.mkdir()
    (tmp_path / "elsewhere.nc").write_text("not the study's")
    os.symlink(tmp_path / "elsewhere.nc", out / "results.nc")
    with pytest.raises(OutputFolderError, match="results.nc is a symbolic link"):
        plan_study(GRID, out)
    assert (tmp_path / "elsewhere.nc").read_text() == "not the study's"


def test_units_are_read_from_the_names_and_labels_only():
    table = {"point": [0], "time_s": [0.1], "solve.physical.clamp_force_N.0": [1.0],
             "solve.physical.field_A_per_m": [1.0], "x.throughput_points_per_s": [3.0],
             "solve.tip.x": [0.5], "solve.tip.angle": [0.1], "solve.units.length": ["rod length"],
             "solve.units.angle": ["rad"], "solve.h": [1.0], "other.tip.x": [0.2]}
    assert column_units(table) == {"time_s": "s", "solve.physical.clamp_force_N.0": "N",
                                   "solve.physical.field_A_per_m": "A/m",
                                   "solve.tip.x": "rod length", "solve.tip.angle": "rad"}
