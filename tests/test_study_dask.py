"""The same study on a Dask distributed cluster (a LocalCluster in this process).

Checked against THEORY §6's closed form (transverse buckling angle) and against the local run:
chunks are fixed by the grid (each walked from rest, :mod:`actuator_design.study.walk`), so the
cluster must give the same table.
"""
import copy
import csv
import json

import pytest

from actuator_design.cli.main import main
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.study.runner import run_study

distributed = pytest.importorskip(
    "distributed", reason="dask.distributed is not installed (pip install 'dask[distributed]'); "
                          "the local study path needs no Dask")

STUDY = {
    "name": "dask test sweep",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
    "study": {"type": "sweep", "sweep": {"h": [0.5, 1.2, 1.6, 2.2, 3.0]},
              "analyses": ["solve"], "chunk_size": 2},
}


@pytest.fixture(scope="module")
def cluster():
    from distributed import LocalCluster
    # threads in this process: cheap to start; chunks of one process run one at a time
    with LocalCluster(processes=False, n_workers=2, threads_per_worker=1,
                      dashboard_address=None) as c:
        yield c


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _check_closed_form(rows):
    assert len(rows) == 5
    for r in rows:
        h, angle = float(r["h"]), abs(float(r["solve.tip.angle"]))
        assert r["status"] == "ok"
        expected = 0.0 if h < critical_field_transverse() else transverse_mode(h).beta
        assert angle == pytest.approx(expected, abs=1e-8)


def test_study_on_a_dask_cluster(tmp_path, cluster):
    report = run_study(STUDY, tmp_path / "dask", scheduler=cluster.scheduler_address,
                       progress=False)
    assert report.backend == "dask" and report.workers == 2
    assert report.status == "completed" and report.counts["ok"] == 5
    m = json.loads((tmp_path / "dask" / "manifest.json").read_text())
    assert m["runs"][-1]["backend"] == "dask"
    assert m["runs"][-1]["scheduler"] == cluster.scheduler_address
    assert m["versions"]["distributed"] == distributed.__version__
    dask_rows = _rows(tmp_path / "dask" / "results.csv")
    _check_closed_form(dask_rows)
    run_study(STUDY, tmp_path / "local", workers=1, progress=False)
    local_rows = _rows(tmp_path / "local" / "results.csv")
    assert [r["solve.tip.angle"] for r in dask_rows] == [r["solve.tip.angle"] for r in local_rows]


def test_cli_scheduler_flag(tmp_path, cluster, capsys):
    cfg = copy.deepcopy(STUDY)
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(cfg))
    code = main(["study", str(path), "--out", str(tmp_path / "s"), "--scheduler",
                 cluster.scheduler_address, "--no-progress", "--json"])
    out = capsys.readouterr().out
    assert code == 0
    assert json.loads(out)["backend"] == "dask"
    _check_closed_form(_rows(tmp_path / "s" / "results.csv"))


def test_cli_bad_scheduler_address_is_bad_input(tmp_path, capsys):
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(STUDY))
    code = main(["study", str(path), "--out", str(tmp_path / "s"), "--scheduler", "ftp://x"])
    assert code == 2 and "--scheduler" in capsys.readouterr().err
