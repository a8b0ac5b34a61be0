"""A hostile file system (issue 22, items 1, 2 and 6): the output folder is the tool's and nothing
else, the journal proves its records, and every refused write is one line.

Every case runs the command line in-process (``main(argv)``). "Nothing outside changed" is checked
on the bytes and modification times of every file of a folder beside the output folder, which the
planted links point into. Read-only and full file systems are fakes (the machine that runs the
tests may be root, for whom permissions do not stop a write): the ``os`` functions that create,
write and rename raise ``EROFS`` or ``ENOSPC`` for paths under the faked folder, as the kernel
would. A resumed study's table is checked against a clean run of the same study, column by column
(``time_s`` aside, which is a wall time).
"""
import csv
import errno
import json
import os
import shutil
import signal
import stat
from pathlib import Path

import pytest

from actuator_design.cli.main import main
from actuator_design.study.journal import MAX_LINE_BYTES
from hostile_fs_fakes import FakeFS, Outside

pytestmark = pytest.mark.skipif(not Path("/proc/self/fd").is_dir() or not hasattr(os, "O_NOFOLLOW"),
                                reason="needs Linux (/proc/self/fd, O_NOFOLLOW)")

ROOT = Path(__file__).resolve().parents[1]
FIT = ["fit", str(ROOT / "configs" / "fit_transverse_buckling.yaml"), "--data",
       str(ROOT / "problems" / "data" / "synthetic_transverse_buckling.csv")]
FIT_FILES = ["fit.json", "fit_points.csv", "fit_data_vs_model.png", "fit_residuals.png"]

# four independent points (one per chunk: each solved from rest, the same in every run)
STUDY = {
    "name": "hostile fs sweep",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "45 deg", "p": 0.3},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "sweep": {"h": [0.3, 0.6, 0.9, 1.2]}, "analyses": ["solve"],
              "outputs": ["solve.tip.*", "solve.success"], "chunk_size": 1},
}
N = len(STUDY["study"]["sweep"]["h"])
STUDY_FILES = ["study.lock", "journal.jsonl", "manifest.json", "results.csv", "results.parquet"]


# -- helpers -------------------------------------------------------------------------------------
def run(argv, capsys):
    """``(exit code, stdout, stderr)`` of the command line run in-process."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err, captured.err
    return code, captured.out, captured.err


def study_argv(config: Path, out: Path, *extra):
    return ["study", config, "--out", out, "--workers", "1", "--no-progress", *extra]


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("actuator-design: error: "), err
    return lines[0]


def table(folder: Path):
    """The rows of results.csv without the wall-time column."""
    with open(folder / "results.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        row.pop("time_s")
    return rows


def journal_lines(folder: Path):
    return (folder / "journal.jsonl").read_text().splitlines()


@pytest.fixture(scope="module")
def config(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "study.yaml"
    path.write_text(json.dumps(STUDY))
    return path


@pytest.fixture(scope="module")
def clean(config, tmp_path_factory) -> Path:
    """A study folder of a clean, complete run."""
    out = tmp_path_factory.mktemp("clean") / "s"
    assert main([str(a) for a in study_argv(config, out)]) == 0
    return out


@pytest.fixture
def alarm():
    """Fail (instead of hanging) when an open blocks, e.g. on a FIFO."""
    def ring(*_):
        raise TimeoutError("blocked: an entry was opened as if it were a regular file")
    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


# -- 1. links and wrong entry types in a study folder --------------------------------------------
@pytest.mark.parametrize("resume", [False, True], ids=["fresh", "resume"])
@pytest.mark.parametrize("entry", STUDY_FILES + ["figures"])
def test_a_linked_study_entry_is_refused_and_nothing_outside_changes(entry, resume, config, clean,
                                                                     tmp_path, capsys):
    outside = Outside(tmp_path)
    out = tmp_path / "s"
    if resume:
        shutil.copytree(clean, out)
    else:
        out.mkdir()
    if os.path.lexists(out / entry):
        shutil.rmtree(out / entry) if (out / entry).is_dir() else (out / entry).unlink()
    target = outside.dir if entry == "figures" else outside.file
    os.symlink(target, out / entry)
    listing = sorted(os.listdir(out))
    code, _, err = run(study_argv(config, out, *(["--resume"] if resume else [])), capsys)
    assert code == 2
    line = one_error_line(err)
    assert f"{out / entry} is a symbolic link" in line and "choose another folder" in line
    outside.assert_unchanged()
    assert sorted(os.listdir(out)) == listing and os.path.islink(out / entry)


@pytest.mark.parametrize("entry, kind, wanted", [
    ("figures", "file", "is a regular file, expected a directory"),
    ("results.csv", "dir", "is a directory, expected a regular file"),
    ("manifest.json", "dir", "is a directory, expected a regular file"),
    ("journal.jsonl", "dir", "is a directory, expected a regular file"),
    ("study.lock", "dir", "is a directory, expected a regular file"),
    ("study.lock", "fifo", "is a FIFO, expected a regular file"),
    ("journal.jsonl", "fifo", "is a FIFO, expected a regular file"),
    ("manifest.json", "fifo", "is a FIFO, expected a regular file"),
    ("results.csv", "fifo", "is a FIFO, expected a regular file"),
])
def test_a_study_entry_of_the_wrong_kind_is_one_line(entry, kind, wanted, config, tmp_path,
                                                     capsys, alarm):
    outside = Outside(tmp_path)
    out = tmp_path / "s"
    out.mkdir()
    if kind == "file":
        (out / entry).write_text("not a folder")
    elif kind == "dir":
        (out / entry).mkdir()
    else:
        os.mkfifo(out / entry)
    code, _, err = run(study_argv(config, out), capsys)
    assert code == 2
    assert f"{out / entry} {wanted}" in one_error_line(err)
    assert os.listdir(out) == [entry]  # nothing written beside it
    mode = os.lstat(out / entry).st_mode
    assert {"file": stat.S_ISREG, "dir": stat.S_ISDIR, "fifo": stat.S_ISFIFO}[kind](mode)
    outside.assert_unchanged()


def test_a_linked_figure_file_is_refused(config, clean, tmp_path, capsys):
    """A link planted inside figures/ (names known only at the end): refused before any figure
    is written, outside untouched; once removed, a resume writes the outputs."""
    outside = Outside(tmp_path)
    out = tmp_path / "s"
    shutil.copytree(clean, out)
    figure = sorted((out / "figures").iterdir())[0]
    figure.unlink()
    os.symlink(outside.file, figure)
    code, _, err = run(study_argv(config, out, "--resume"), capsys)
    assert code == 2 and f"{figure} is a symbolic link" in one_error_line(err)
    outside.assert_unchanged()
    figure.unlink()
    code, _, err = run(study_argv(config, out, "--resume"), capsys)
    assert code == 0, err
    assert figure.is_file() and not figure.is_symlink()
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# -- 1. links and wrong entry types in a command's --out -----------------------------------------
def test_links_and_fifos_in_a_fit_out_are_replaced_never_followed(tmp_path, capsys, alarm):
    outside = Outside(tmp_path)
    out = tmp_path / "fit"
    out.mkdir()
    os.symlink(outside.file, out / "fit.json")
    os.symlink(outside.dir, out / "fit_points.csv")
    os.mkfifo(out / "fit_residuals.png")
    code, stdout, err = run(FIT + ["--json", "--out", out], capsys)
    assert code == 0, err
    outside.assert_unchanged()
    assert sorted(os.listdir(out)) == sorted(FIT_FILES)
    for name in FIT_FILES:
        assert stat.S_ISREG(os.lstat(out / name).st_mode), name
    assert json.loads((out / "fit.json").read_text())["success"] == json.loads(stdout)["success"]


def test_links_in_a_solve_out_are_replaced_never_followed(tmp_path, capsys):
    """The same writer as design's and every other command's --out (cli.common.write_out)."""
    outside = Outside(tmp_path)
    out = tmp_path / "solve"
    out.mkdir()
    names = ("result.json", "shape.csv", "shape.png")
    for name in names:
        os.symlink(outside.file, out / name)
    code, stdout, err = run(["solve", "--h", "1.2", "--json", "--out", out], capsys)
    assert code == 0, err
    outside.assert_unchanged()
    for name in names:
        assert stat.S_ISREG(os.lstat(out / name).st_mode), name
    assert json.loads((out / "result.json").read_text())["tip"] == json.loads(stdout)["tip"]


def test_a_directory_where_a_fit_file_goes_is_one_line(tmp_path, capsys):
    out = tmp_path / "fit"
    (out / "fit_points.csv").mkdir(parents=True)
    (out / "fit_points.csv" / "mine.txt").write_text("keep")
    code, stdout, err = run(FIT + ["--out", out], capsys)
    assert code == 2 and stdout == ""
    line = one_error_line(err)
    assert f"{out / 'fit_points.csv'} is a directory" in line
    assert os.listdir(out) == ["fit_points.csv"]
    assert (out / "fit_points.csv" / "mine.txt").read_text() == "keep"


# -- 3. read-only and full file systems ----------------------------------------------------------
@pytest.mark.parametrize("existing", [False, True], ids=["new-folder", "empty-folder"])
def test_a_study_on_a_read_only_file_system_is_one_line(existing, config, tmp_path, capsys,
                                                        monkeypatch):
    disk = tmp_path / "ro"
    disk.mkdir()
    out = disk / "s"
    if existing:
        out.mkdir()
    fake = FakeFS(monkeypatch, disk, "EROFS")
    code, stdout, err = run(study_argv(config, out), capsys)
    assert code == 2 and stdout == ""
    assert "Read-only file system" in one_error_line(err)
    assert fake.refused >= 1
    assert os.listdir(disk) == (["s"] if existing else [])
    if existing:
        assert os.listdir(out) == []


@pytest.mark.parametrize("kind", ["EROFS", "ENOSPC"])
def test_a_fit_out_on_a_refusing_file_system_is_one_line_and_leaves_nothing(kind, tmp_path, capsys,
                                                                            monkeypatch):
    out = tmp_path / "disk" / "fit"
    out.mkdir(parents=True)
    (out / "fit.json").write_text("earlier")
    FakeFS(monkeypatch, tmp_path / "disk", kind, full_after=1000)
    code, stdout, err = run(FIT + ["--json", "--out", out], capsys)
    assert code == 2 and stdout == ""
    line = one_error_line(err)
    assert os.strerror(errno.EROFS if kind == "EROFS" else errno.ENOSPC) in line
    assert "[Errno" not in line
    assert os.listdir(out) == ["fit.json"] and (out / "fit.json").read_text() == "earlier"


def test_a_study_that_fills_the_disk_resumes_to_the_clean_table(config, clean, tmp_path, capsys,
                                                                monkeypatch):
    """The disk fills during the third journal record (a cut line): exit 3 naming the journal,
    two points kept; once space is freed, --resume computes the others and the table is a clean
    run's."""
    out = tmp_path / "disk" / "s"
    header_and_two = sum(len(x) + 1 for x in journal_lines(clean)[:3])
    with monkeypatch.context() as m:
        FakeFS(m, tmp_path / "disk", "ENOSPC", full_after=header_and_two + 40, only="journal")
        code, stdout, err = run(study_argv(config, out), capsys)
    assert code == 3 and stdout == ""
    line = one_error_line(err)
    assert f"cannot write {out / 'journal.jsonl'}: No space left on device" in line
    assert f"2 of {N} points are journaled" in line and "--resume" in line
    assert not (out / "journal.jsonl").read_bytes().endswith(b"\n")  # the cut line is there
    assert not (out / "study.lock").exists() and not (out / "results.csv").exists()

    code, stdout, err = run(study_argv(config, out, "--resume", "--json"), capsys)
    assert code == 0, err
    report = json.loads(stdout)
    assert report["reused"] == 2 and report["computed"] == N - 2
    assert table(out) == table(clean)


def test_a_study_whose_outputs_fill_the_disk_resumes_without_recomputing(config, clean, tmp_path,
                                                                         capsys, monkeypatch):
    """Every point journaled, then results.csv does not fit: exit 3; the resume computes nothing
    and writes the clean run's table."""
    out = tmp_path / "disk" / "s"
    with monkeypatch.context() as m:
        FakeFS(m, tmp_path / "disk", "ENOSPC", full_after=0, only=".results.csv")
        code, _, err = run(study_argv(config, out), capsys)
    assert code == 3
    line = one_error_line(err)
    assert f"{N} of {N} points are journaled" in line and "--resume" in line
    assert not (out / "results.csv").exists()
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]  # no temporary file left
    code, stdout, err = run(study_argv(config, out, "--resume", "--json"), capsys)
    assert code == 0, err
    assert json.loads(stdout)["computed"] == 0
    assert table(out) == table(clean)


def test_a_full_disk_before_any_point_is_exit_2(config, tmp_path, capsys, monkeypatch):
    out = tmp_path / "disk" / "s"
    FakeFS(monkeypatch, tmp_path / "disk", "ENOSPC", full_after=0)
    code, _, err = run(study_argv(config, out), capsys)
    assert code == 2
    line = one_error_line(err)
    assert "No space left on device" in line and "nothing of the study is kept" in line


# -- 2. a journal that proves its records --------------------------------------------------------
# each edit of the journal's lines (0: header, k: point k - 1) returns
# (points computed again, lines rejected, words of the warning)
def _fabricate(lines):
    rec = json.loads(lines[2])
    rec["results"]["solve.tip.angle"] += 0.25  # plausible, wrong, index and values intact
    lines[2] = json.dumps(rec)
    return 1, 1, "checksum does not match its content"


def _relabel(lines):
    rec = json.loads(lines[2])
    rec["index"], rec["values"] = 3, {"h": STUDY["study"]["sweep"]["h"][3]}
    lines[2] = json.dumps(rec)
    del lines[4]
    return 2, 1, "checksum does not match its content"


def _other_inputs(lines):
    """A record computed from other inputs (another version), checksum made consistent."""
    from actuator_design.study.journal import record_checksum
    rec = json.loads(lines[3])
    rec["inputs"] = "0" * 64
    rec["checksum"] = record_checksum(rec)
    lines[3] = json.dumps(rec)
    return 1, 1, "computed from other inputs"


def _truncate_last(lines):
    lines[-1] = lines[-1][: len(lines[-1]) // 2] + "<no newline>"
    return 1, 0, None  # a cut last line is an interrupted write: ignored, not a rejection


def _truncate_middle(lines):
    lines[2] = lines[2][: len(lines[2]) // 2]
    return 1, 1, "not a JSON record"


def _deep(lines):
    lines[2] = "[" * 100_000 + "]" * 100_000
    lines[3] = '{"index": 2, "values": ' + "[" * 100_000 + "]" * 100_000 + "}"
    return 2, 2, "nested too deeply"


def _overlong(lines):
    rec = json.loads(lines[1])
    rec["message"] = "x" * (MAX_LINE_BYTES + 10)
    lines[1] = json.dumps(rec)
    return 1, 1, f"longer than {MAX_LINE_BYTES} bytes"


def _old_version(lines):
    for k in range(1, len(lines)):
        rec = json.loads(lines[k])
        del rec["checksum"], rec["inputs"]
        lines[k] = json.dumps(rec)
    return N, N, f"{N} of them without a checksum"


@pytest.mark.parametrize("tamper", [_fabricate, _relabel, _other_inputs, _truncate_last,
                                    _truncate_middle, _deep, _overlong, _old_version])
def test_a_tampered_journal_is_detected_and_resumes_to_the_clean_table(tamper, config, clean,
                                                                       tmp_path, capsys):
    out = tmp_path / "s"
    shutil.copytree(clean, out)
    lines = journal_lines(out)
    assert all("checksum" in json.loads(x) and "inputs" in json.loads(x) for x in lines[1:])
    recomputed, rejected, reason = tamper(lines)
    text = "\n".join(lines) + "\n"
    (out / "journal.jsonl").write_text(text.replace("<no newline>\n", ""))
    code, stdout, err = run(study_argv(config, out, "--resume", "--json"), capsys)
    assert code == 0, err
    report = json.loads(stdout)
    assert report["computed"] == recomputed and report["reused"] == N - recomputed
    warnings = [x for x in err.splitlines() if "warning: journal:" in x]
    assert len(warnings) == (1 if rejected else 0), err
    if rejected:
        assert reason in warnings[0] and f"journal: {rejected} line(s) rejected" in warnings[0]
    assert table(out) == table(clean)


def test_a_deeply_nested_manifest_does_not_stop_a_resume(config, clean, tmp_path, capsys):
    out = tmp_path / "s"
    shutil.copytree(clean, out)
    (out / "manifest.json").write_text("[" * 100_000 + "]" * 100_000)
    code, stdout, err = run(study_argv(config, out, "--resume", "--json"), capsys)
    assert code == 0, err
    assert json.loads(stdout)["computed"] == 0
    assert json.loads((out / "manifest.json").read_text())["status"] == "completed"
    assert table(out) == table(clean)


def test_the_records_of_a_run_prove_their_points(clean):
    """Independent check of the stamp: sha256 of the canonical JSON without the checksum, and
    an inputs digest that differs between points (it covers the swept values)."""
    import hashlib
    recs = [json.loads(x) for x in journal_lines(clean)[1:]]
    for rec in recs:
        body = {k: v for k, v in rec.items() if k != "checksum"}
        text = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
        assert rec["checksum"] == hashlib.sha256(text.encode()).hexdigest()
    assert len({r["inputs"] for r in recs}) == N
