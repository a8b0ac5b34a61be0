"""Output sets are all or nothing (issue 10 item 6).

``--out DIR`` writes the whole set into a staging folder and moves it into place only when it is
complete; a set that cannot be written leaves nothing of itself (no file, no staging folder, no
parent created for it), an earlier set in DIR stays as it was, and nothing is printed on stdout.
"""
import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from actuator_design.io import save as adio
from actuator_design.cli.main import main

ROOT = Path(__file__).resolve().parents[1]


def _tree(path: Path):
    """Every entry under ``path`` (relative, sorted), hidden ones included."""
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


def _fail_on(monkeypatch, name: str):
    """Make writing the file ``name`` of any set fail as a full disk would."""
    real = adio._write_new_file

    def write(path, data):
        if Path(path).name == name:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real(path, data)
    monkeypatch.setattr(adio, "_write_new_file", write)


# -- the CLI ------------------------------------------------------------------------------------------
def test_blocked_file_of_the_set_exits_2_leaving_nothing_and_printing_no_json(tmp_path):
    """The case of the issue, through the installed entry point: DIR/shape.csv is a directory."""
    out = tmp_path / "out"
    (out / "shape.csv").mkdir(parents=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-m", "actuator_design.cli", "solve", "--h", "0.5", "--json",
                        "--out", str(out)], capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 2
    assert p.stdout == ""
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("actuator-design: error: --out:") and "shape.csv" in err[0]
    assert _tree(out) == ["shape.csv"]          # no result.json, no shape.png, no staging folder
    assert _tree(tmp_path) == ["out", "out/shape.csv"]


@pytest.mark.parametrize("argv, failing", [
    (["solve", "--h", "0.5"], "shape.png"),
    (["solve", "--h", "0.5", "--json"], "shape.csv"),
    (["stiffness", "--h", "1.3", "--json"], "stiffness.json"),
])
def test_a_write_failing_inside_the_staged_set_leaves_nothing(capsys, tmp_path, monkeypatch, argv, failing):
    _fail_on(monkeypatch, failing)
    out = tmp_path / "new" / "dir"
    code = main(argv + ["--out", str(out)])
    captured = capsys.readouterr()
    assert code == 2
    assert captured.out == ""                    # neither JSON nor summary before the set is written
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("actuator-design: error: --out:") and "No space" in err[0]
    assert _tree(tmp_path) == []                 # not even the parents made for the set


def test_a_failed_set_keeps_the_earlier_set(capsys, tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert main(["solve", "--h", "0.5", "--json", "--out", str(out)]) == 0
    first = json.loads(capsys.readouterr().out)
    before = {name: (out / name).read_bytes() for name in _tree(out)}
    assert sorted(before) == ["result.json", "shape.csv", "shape.png"]

    _fail_on(monkeypatch, "shape.png")
    assert main(["solve", "--h", "1.5", "--json", "--out", str(out)]) == 2
    assert capsys.readouterr().out == ""
    assert {name: (out / name).read_bytes() for name in _tree(out)} == before
    assert json.loads(before["result.json"])["h"] == first["h"] == 0.5


def test_a_complete_set_replaces_the_earlier_one_and_leaves_other_files(capsys, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["solve", "--h", "0.5", "--json", "--out", str(out)]) == 0
    assert main(["solve", "--h", "1.5", "--json", "--out", str(out)]) == 0
    second = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert _tree(out) == ["notes.txt", "result.json", "shape.csv", "shape.png"]
    assert (out / "notes.txt").read_text() == "mine"
    assert json.loads((out / "result.json").read_text())["h"] == second["h"] == 1.5


# -- io.write_output_set --------------------------------------------------------------------------------
def test_a_move_failing_mid_commit_restores_the_earlier_files(tmp_path, monkeypatch):
    out = tmp_path / "set"
    adio.write_output_set(out, {"a.txt": "old a", "b.txt": "old b", "c.txt": "old c"})
    real = os.replace
    calls = []

    def replace(src, dst):
        calls.append(Path(dst).name)
        if Path(src).parent.name.startswith(".partial") and Path(src).name == "c.txt":
            raise OSError(errno.EIO, "I/O error", str(dst))
        real(src, dst)
    monkeypatch.setattr(adio.os, "replace", replace)
    with pytest.raises(OSError, match="I/O error"):
        adio.write_output_set(out, {"a.txt": "new a", "b.txt": "new b", "c.txt": "new c"})
    assert "a.txt" in calls and "b.txt" in calls  # the failure came after two files had moved in
    assert {n: (out / n).read_text() for n in _tree(out)} == {"a.txt": "old a", "b.txt": "old b",
                                                              "c.txt": "old c"}


def test_content_kinds_and_returned_paths(tmp_path):
    class Drawn:  # anything with savefig is a figure to io (duck typing: io never imports matplotlib)
        def savefig(self, fh, format, dpi):
            fh.write(f"{format}@{dpi}".encode())

    paths = adio.write_output_set(tmp_path / "x", {"t.txt": "é\n", "b.bin": b"\x00\x01", "f.png": Drawn()},
                                  dpi=72)
    assert paths == [tmp_path / "x" / n for n in ("t.txt", "b.bin", "f.png")]
    assert (tmp_path / "x" / "t.txt").read_bytes() == "é\n".encode("utf-8")
    assert (tmp_path / "x" / "b.bin").read_bytes() == b"\x00\x01"
    assert (tmp_path / "x" / "f.png").read_bytes() == b"png@72"


@pytest.mark.parametrize("files, error", [
    ({"sub/x.txt": "a"}, ValueError),
    ({"..": "a"}, ValueError),
    ({"x.txt": 3.5}, TypeError),
])
def test_bad_sets_are_refused_before_anything_is_written(tmp_path, files, error):
    with pytest.raises(error):
        adio.write_output_set(tmp_path / "x", files)
    assert _tree(tmp_path) == []


def test_out_that_is_a_file_is_refused(tmp_path):
    f = tmp_path / "file"
    f.write_text("keep")
    with pytest.raises(NotADirectoryError):
        adio.write_output_set(f, {"x.txt": "a"})
    assert f.read_text() == "keep" and _tree(tmp_path) == ["file"]
