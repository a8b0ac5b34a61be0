"""Design messages on a physical scene (issue 21 item 4, issue 17 item 5): the miss of an
unreachable target in the scene's length unit as well as in rod lengths, why robustness was not
checked, and each note once, without a nested 'note:'."""
import math
import re
from pathlib import Path

import pytest

from actuator_design.cli.main import main

CONFIG = str(Path(__file__).resolve().parents[1] / "configs/paper_actuator_physical.yaml")


def test_an_unreachable_physical_target_reports_its_miss_in_mm(capsys):
    assert main(["design", CONFIG, "--target-tip", "10,15", "--target-units", "mm"]) == 4  # unreachable
    out = capsys.readouterr().out
    tip = re.search(r"tip \[mm\]\s*: target \(([^,]+), ([^)]+)\), achieved \(([^,]+), ([^)]+)\)", out)
    tx, ty, ax, ay = map(float, tip.groups())
    miss_mm = math.hypot(ax - tx, ay - ty)
    err = re.search(r"error (\S+) rod lengths \((\S+) mm\)", out)
    assert float(err.group(2)) == pytest.approx(miss_mm, rel=1e-3)
    assert "NOT checked over the box" in out and "the target is not reached" in out
    note = next(ln for ln in out.splitlines() if ln.startswith("  note"))
    assert "note:" not in note.split(":", 1)[1]
    assert "misses by" in note and "rod lengths" in note
