"""Studies are safe (issue 10, items 4–5): a bounded grid, one writer per folder, workers that die
with their parent, a journal checked against the grid, a manifest that is true after a crash.

Every case runs for real: subprocesses killed with SIGKILL, two writers at once, a journal edited
by hand. Point values are checked against an independent forward solve (shooting on THEORY §5's
Euler–Lagrange equation with scipy, written here) and point counts against the built grid.
"""
import copy
import json
import os
import re
import resource
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from actuator_design.cli.main import main
from actuator_design.config import ConfigError
from actuator_design.study.errors import StudyError
from actuator_design.study.grid import DEFAULT_MAX_POINTS, grid_indices, grid_size, resolve_axes
from actuator_design.study.journal import Journal
from actuator_design.study.lock import LOCK_NAME, FolderLock, holder_of
from actuator_design.study.manifest import read_manifest
from actuator_design.study.runner import plan_study
from actuator_design.config.studies.sweep import SweepSpec
from actuator_design.config.studies.validation import validate_spec

ROOT = Path(__file__).resolve().parents[1]

# φ = 45°, p = 0.3: no closed form; the reference is the shooting solve below
OBLIQUE = {
    "name": "oblique test sweep",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "45 deg", "p": 0.3},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "sweep": {"h": [0.3, 0.6, 0.9, 1.2]}, "analyses": ["solve"],
              "outputs": ["solve.tip.*", "solve.success"]},
}


def _slow_study(tmp_path, n: int) -> Path:
    """A configuration file of an n-point sweep, one point per chunk (journaled one by one)."""
    cfg = copy.deepcopy(OBLIQUE)
    cfg["study"]["sweep"] = {"h": {"from": 0.1, "to": 1.5, "n": n}}
    cfg["study"]["chunk_size"] = 1
    path = tmp_path / "slow.yaml"
    path.write_text(json.dumps(cfg))
    return path


def _cli(config, out, *extra, **popen):
    popen = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, **popen}
    return subprocess.Popen([sys.executable, "-m", "actuator_design.cli.main", "study", str(config),
                             "--out", str(out), "--no-progress", *extra], text=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT)}, **popen)


def _wait_for_records(proc, journal: Path, count: int, timeout: float = 180.0) -> None:
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        if journal.exists() and len(journal.read_text().splitlines()) > count:
            return
        time.sleep(0.05)
    raise AssertionError(f"no {count} journal records in time (exit {proc.poll()})")


def _stop(proc) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()


# -- an independent forward solve ------------------------------------------------------------------
def _shoot_tip(h: float, phi: float, p: float):
    """Tip (x, y, θ) of θ'' = h² sin 2(θ − φ) − p cos θ, θ(0) = 0, θ'(1) = 0 (THEORY §5, α = 0)
    by shooting on γ = θ'(0); the root must be unique in a wide bracket (else no reference)."""
    def rhs(s, u):
        th, dth, _, _ = u
        return [dth, h * h * np.sin(2 * (th - phi)) - p * np.cos(th), np.cos(th), np.sin(th)]

    def end(gamma, rtol=1e-12):
        return solve_ivp(rhs, (0, 1), [0.0, gamma, 0.0, 0.0], rtol=rtol, atol=rtol / 10).y[:, -1]

    gammas = np.linspace(-8, 8, 65)
    miss = [end(g, 1e-8)[1] for g in gammas]
    roots = [brentq(lambda g: end(g)[1], a, b, xtol=1e-14)
             for a, b, fa, fb in zip(gammas, gammas[1:], miss, miss[1:]) if fa * fb < 0]
    assert len(roots) == 1, f"h={h}: {len(roots)} equilibria, the reference is ambiguous"
    th, _, x, y = end(roots[0])
    return x, y, th


# -- (a) the grid's size is checked before any work ------------------------------------------------
@pytest.mark.parametrize("grid, sweep", [
    ("cartesian", {"h": [1, 2, 3], "phi": {"from": 0, "to": 1, "n": 4}, "p": [0, 1]}),
    ("zip", {"h": [1, 2, 3], "phi": {"from": 0, "to": 1, "n": 3}}),
    ("cartesian", {"h": {"from": 0.01, "to": 1, "n": 5, "spacing": "log"}}),
])
def test_grid_size_counts_the_grid_it_does_not_build(grid, sweep):
    spec = validate_spec(SweepSpec, {"type": "sweep", "grid": grid, "sweep": sweep})
    total, sizes = grid_size(spec)
    axes = resolve_axes(spec)
    assert total == len(grid_indices(axes, grid))
    assert sizes == [len(a.values) for a in axes]


def test_a_huge_grid_exits_2_before_allocating(tmp_path):
    """1000 × 1000 × 1000 points under a 1 GiB address-space limit: a built grid of 10⁹ index
    tuples needs tens of GB, so only a check made before building it can exit 2 cleanly."""
    cfg = {"scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg"},
           "study": {"type": "sweep", "sweep": {"h": {"from": 0, "to": 2, "n": 1000},
                                                "phi": {"from": "0 deg", "to": "90 deg", "n": 1000},
                                                "p": {"from": 0, "to": 1, "n": 1000}}}}
    path = tmp_path / "huge.yaml"
    path.write_text(json.dumps(cfg))

    def guard():
        resource.setrlimit(resource.RLIMIT_AS, (2 ** 30, 2 ** 30))

    proc = _cli(path, tmp_path / "out", preexec_fn=guard)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("actuator-design: error: study.sweep:"), err
    assert "1000 × 1000 × 1000 = 1000000000 points" in err
    assert f"limit of {DEFAULT_MAX_POINTS}" in err
    assert "--max-points" in err
    assert not (tmp_path / "out").exists()


def test_the_point_limit_is_raised_by_flag_or_yaml(tmp_path):
    cfg = copy.deepcopy(OBLIQUE)
    cfg["study"]["sweep"] = {"h": [0.3, 0.6], "p": [0.0, 0.1, 0.2]}  # 6 points
    with pytest.raises(ConfigError) as info:
        plan_study(cfg, tmp_path / "a", max_points=5)
    assert info.value.field == "study.sweep" and "2 × 3 = 6 points" in str(info.value)
    assert "limit of 5" in str(info.value)
    assert plan_study(cfg, tmp_path / "a", max_points=6).n_points == 6
    cfg["study"]["max_points"] = 5
    with pytest.raises(ConfigError, match="limit of 5"):
        plan_study(cfg, tmp_path / "a")
    assert plan_study(cfg, tmp_path / "a", max_points=6).n_points == 6  # the flag wins
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(cfg))
    assert main(["study", str(path), "--out", str(tmp_path / "b"), "--max-points", "0"]) == 2
    cfg["study"]["max_points"] = 0
    with pytest.raises(ConfigError) as info:
        plan_study(cfg, tmp_path / "a")
    assert info.value.field == "study.max_points"


# -- (b) one writer per folder ---------------------------------------------------------------------
def test_a_second_writer_exits_2_naming_the_holder(tmp_path):
    path = _slow_study(tmp_path, 3000)
    out = tmp_path / "s"
    first = _cli(path, out, "--workers", "1")
    try:
        _wait_for_records(first, out / "journal.jsonl", 2)
        holder = f"pid {first.pid} on host {socket.gethostname()}, started "
        second = _cli(path, out, "--workers", "1")
        _, err = second.communicate(timeout=120)
        assert second.returncode == 2, err
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert holder in lines[0] and "in use by another study run" in lines[0], err
        with pytest.raises(StudyError, match=re.escape(holder)):  # resuming it is refused as well
            plan_study(path, out, resume=True)
        assert first.poll() is None  # the holder runs on, undisturbed
    finally:
        _stop(first)
    # every point in the journal once: the second writer wrote nothing
    indices = [json.loads(x)["index"] for x in (out / "journal.jsonl").read_text().splitlines()[1:]]
    assert len(indices) == len(set(indices))


def test_lock_in_one_process_and_a_stale_lock_is_taken_over(tmp_path):
    with FolderLock(tmp_path):
        assert holder_of(tmp_path).pid == os.getpid()
        with pytest.raises(StudyError, match=f"pid {os.getpid()} on host"):
            FolderLock(tmp_path).acquire()
    assert holder_of(tmp_path) is None and not (tmp_path / LOCK_NAME).exists()
    # a lock file left by a process that is gone (killed before it could remove it)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK_NAME).write_text(json.dumps(
        {"pid": dead.pid, "host": socket.gethostname(), "started": "2026-01-01T00:00:00+00:00"}))
    assert holder_of(tmp_path) is None
    lock = FolderLock(tmp_path)
    note = lock.acquire()
    try:
        assert f"pid {dead.pid}" in note and "that process is gone" in note
        assert holder_of(tmp_path).pid == os.getpid()
    finally:
        lock.release()


# -- (c) workers die with their parent; (e) the manifest is true after a crash ---------------------
def _descendants(pid: int):
    """{pid: start time} of every descendant of pid, from /proc."""
    parent = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2:].split()
            parent[int(entry)] = (int(fields[1]), fields[19])
    found, frontier = {}, [pid]
    while frontier:
        p = frontier.pop()
        for child, (ppid, start) in parent.items():
            if ppid == p and child not in found:
                found[child] = start
                frontier.append(child)
    return found


def _alive(pid: int, start: str) -> bool:
    """The same process (same start time) still exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    fields = stat[stat.rindex(")") + 2:].split()
    return fields[0] != "Z" and fields[19] == start


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc (Linux)")
def test_kill_9_leaves_no_worker_and_an_interrupted_resumable_study(tmp_path):
    n = 120
    path = _slow_study(tmp_path, n)
    out = tmp_path / "s"
    # no pipes: a surviving worker would hold them open
    proc = _cli(path, out, "--workers", "2", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait_for_records(proc, out / "journal.jsonl", 4)
        workers = _descendants(proc.pid)
        assert len(workers) >= 2, workers
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    deadline = time.time() + 15
    while time.time() < deadline and any(_alive(p, s) for p, s in workers.items()):
        time.sleep(0.1)
    survivors = [p for p, s in workers.items() if _alive(p, s)]
    for p in survivors:  # do not leave them behind for the next tests
        os.kill(p, signal.SIGKILL)
    assert not survivors, f"workers {survivors} outlived their killed parent"

    raw = json.loads((out / "manifest.json").read_text())
    assert raw["status"] == "running"  # as the killed run left it ...
    m = read_manifest(out)  # ... and as it is told
    assert m["status"] == "interrupted" and m["runs"][-1]["status"] == "interrupted"
    assert "--resume" in m["note"]
    done = len((out / "journal.jsonl").read_text().splitlines()) - 1
    assert 4 <= done < n

    resumed = _cli(path, out, "--workers", "2", "--resume")
    _, err = resumed.communicate(timeout=600)
    assert resumed.returncode == 0, err
    assert "took over the lock" in err and f"pid {proc.pid}" in err
    m = read_manifest(out)
    assert m["status"] == "completed" and m["counts"]["ok"] == n
    assert [r["status"] for r in m["runs"]] == ["interrupted", "completed"]
    assert m["runs"][1]["computed"] == n - done
    indices = sorted(json.loads(x)["index"]
                     for x in (out / "journal.jsonl").read_text().splitlines()[1:])
    assert indices == list(range(n))


def test_a_running_manifest_is_running_while_its_lock_is_held(tmp_path):
    (tmp_path / "manifest.json").write_text(json.dumps(
        {"status": "running", "runs": [{"status": "completed"}, {"status": "running"}]}))
    with FolderLock(tmp_path):
        assert read_manifest(tmp_path)["status"] == "running"
    m = read_manifest(tmp_path)
    assert m["status"] == "interrupted"
    assert [r["status"] for r in m["runs"]] == ["completed", "interrupted"]


# -- (d) journal records are checked against the grid ----------------------------------------------
def test_an_edited_journal_record_is_recomputed(tmp_path, capsys):
    """Point 1's record relabelled as point 3 (whose record is removed) would give point 3 the
    values of point 1: it is rejected, both points are computed again and match the shooting."""
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(OBLIQUE))
    out = tmp_path / "s"
    assert main(["study", str(path), "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    lines = (out / "journal.jsonl").read_text().splitlines()
    recs = [json.loads(x) for x in lines[1:]]
    by_index = {r["index"]: r for r in recs}
    moved = dict(by_index[1], index=3)
    journal = [lines[0]] + [json.dumps(by_index[0]), json.dumps(moved), json.dumps(by_index[2])]
    (out / "journal.jsonl").write_text("\n".join(journal) + "\n")
    capsys.readouterr()
    assert main(["study", str(path), "--out", str(out), "--workers", "1", "--no-progress",
                 "--resume", "--json"]) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    assert report["computed"] == 2 and report["reused"] == 2
    warning = [x for x in captured.err.splitlines() if "warning: journal:" in x]
    assert len(warning) == 1 and "1 line(s) rejected" in warning[0]
    assert "line 3: point 3 has the values" in warning[0]
    m = read_manifest(out)
    assert m["runs"][-1]["rejected_records"] == 1 and len(m["warnings"]) == 1
    final = {}
    for x in (out / "journal.jsonl").read_text().splitlines()[1:]:
        r = json.loads(x)
        final[r["index"]] = r  # the last record of a point is the one used
    phi = np.pi / 4
    for i, h in enumerate(OBLIQUE["study"]["sweep"]["h"]):
        x, y, th = _shoot_tip(h, phi, 0.3)
        res = final[i]["results"]
        assert final[i]["values"] == {"h": h}
        assert res["solve.tip.x"] == pytest.approx(x, abs=1e-8)
        assert res["solve.tip.y"] == pytest.approx(y, abs=1e-8)
        assert res["solve.tip.angle"] == pytest.approx(th, abs=1e-8)
    assert final[3]["results"]["solve.tip.angle"] != moved["results"]["solve.tip.angle"]


def test_journal_rejects_records_that_do_not_match_the_grid(tmp_path):
    grid = {0: {"h": 0.5}, 1: {"h": 1.0}, 2: {"h": "90.0 deg"}}
    path = tmp_path / "journal.jsonl"
    lines = [{"journal": "actuator-design study", "study_id": "x", "n_points": 3},
             {"index": 0, "values": {"h": 0.5}, "status": "ok"},
             {"index": 1, "values": {"h": 0.5}, "status": "ok"},  # values of point 0
             {"index": 2, "status": "ok"},  # no values to check
             {"index": 7, "values": {"h": 1.0}, "status": "ok"},  # not a point
             {"index": True, "values": {"h": 1.0}, "status": "ok"},
             {"index": 2, "values": {"h": "90.0 deg"}, "status": "ok"}]
    journal = Journal(path, "x", 3)  # every record checksummed: the grid check comes on top
    text = [json.dumps(lines[0])] + [json.dumps(journal.stamp(x)) for x in lines[1:]]
    path.write_text("\n".join(text) + "\n{not json\n" + '{"index": 1')
    found = journal.records(grid.__getitem__)
    assert sorted(found.records) == [0, 2]
    assert [r.split(":")[0] for r in found.rejected] == ["line 3", "line 4", "line 5", "line 6",
                                                          "line 8"]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc (Linux)")
def test_the_portable_watchdog_alone_ends_an_orphan(tmp_path):
    """die_with_parent without prctl (sys.platform faked): the watchdog thread notices the
    reparenting and ends the child."""
    child_code = ("import os, sys, time; sys.platform = 'other'; "
                  "from actuator_design.parallel import die_with_parent; "
                  "die_with_parent(os.getppid(), poll_s=0.1); print(os.getpid(), flush=True); "
                  "time.sleep(120)")
    parent_code = (f"import subprocess, sys, time; "
                   f"subprocess.Popen([sys.executable, '-c', {child_code!r}]); time.sleep(120)")
    pid_file = tmp_path / "child.pid"
    with open(pid_file, "w") as fh:
        parent = subprocess.Popen([sys.executable, "-c", parent_code], stdout=fh,
                                  env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        deadline = time.time() + 60
        while time.time() < deadline and not pid_file.read_text().strip():
            time.sleep(0.05)
        child = int(pid_file.read_text())
        start = _descendants(parent.pid)[child]
        assert _alive(child, start)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(timeout=30)
        deadline = time.time() + 10
        while time.time() < deadline and _alive(child, start):
            time.sleep(0.05)
        gone = not _alive(child, start)
        if not gone:
            os.kill(child, signal.SIGKILL)
        assert gone, "the orphan outlived its parent"
    finally:
        if parent.poll() is None:
            parent.kill()


@pytest.mark.parametrize("section,field", [
    ({"type": "sweep", "sweep": {"str": {"from": 0, "to": 1, "n": 0}}}, "study.sweep.str.n"),
    ({"type": "sweep", "sweep": {"RangeSpec": {"from": 0, "to": 1, "n": 0}}}, "study.sweep.RangeSpec.n"),
    ({"type": "sweep", "sweep": {"h": {"from": 0, "to": 1, "n": 0}}}, "study.sweep.h.n"),
    ({"type": "sweep", "sweep": {"h": [1]}, "chunk_size": "x"}, "study.chunk_size"),
])
def test_an_error_names_a_key_spelled_like_a_type_and_drops_the_types_pydantic_adds(section, field):
    """Pydantic puts the member type of a union in an error's location (``RangeSpec``, ``str``): it is
    dropped, but a swept key spelled like one is the user's and stays in the path."""
    with pytest.raises(ConfigError) as err:
        validate_spec(SweepSpec, section)
    assert err.value.field == field
