"""The files of a design are the state its text reports (issue 17 item 4): on a design that is not
verified (no snap-free path from rest reaches it), shape.csv is never another equilibrium."""
import csv
import json

import pytest

from actuator_design.cli.main import main


def test_shape_csv_is_the_reported_state_or_absent(tmp_path, capsys):
    out = tmp_path / "d"
    code = main(["design", "--target-tip", "0.563816,0.205212", "--out", str(out), "--json"])
    d = json.loads(capsys.readouterr().out)
    assert code == (0 if d["success"] else 3 if d["reachable"] else 4)
    shape = out / "shape.csv"
    if shape.exists():
        last = list(csv.DictReader(line for line in shape.open() if not line.startswith("#")))[-1]
        assert float(last["x"]) == pytest.approx(d["achieved"]["x"], abs=1e-6)
        assert float(last["y"]) == pytest.approx(d["achieved"]["y"], abs=1e-6)
    else:
        assert not d["verified"]
