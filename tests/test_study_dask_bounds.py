"""Studies on a Dask cluster end within stated bounds, with one line and a promised exit code:
a malformed address, a silent listener, an HTTP server, a port sending random bytes, a scheduler
without workers, and the only worker killed mid-study (issue 22, item 6).

The bounds are shortened through the environment variables the README documents.
"""
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from actuator_design.cli.main import main
from actuator_design.study import dask_cluster
from actuator_design.study.dask_cluster import ClusterError, check_address
from actuator_design.study.runner import run_study

distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")

STUDY = {
    "name": "dask bounds",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
    "study": {"type": "sweep", "sweep": {"h": [0.5, 1.2, 1.6, 2.2, 3.0]},
              "analyses": ["solve"], "chunk_size": 2},
}
ENV = {dask_cluster.CONNECT_TIMEOUT_ENV: "1", dask_cluster.WORKER_TIMEOUT_ENV: "1"}


class _Listener:
    """A TCP server on 127.0.0.1 that accepts and then stays silent, answers a request like an
    HTTP server, or sends random bytes at once."""

    def __init__(self, mode):
        self.mode = mode
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.conns = []
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.mode == "random":
                conn.sendall(os.urandom(64))
            elif self.mode == "http":
                threading.Thread(target=self._http, args=(conn,), daemon=True).start()

    @staticmethod
    def _http(conn):
        try:
            if conn.recv(4096):
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
        except OSError:
            pass

    def close(self):
        for c in self.conns + [self.sock]:
            c.close()


def _config(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(STUDY))
    return path


def _one_error_line(err, *words):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0].startswith("actuator-design: error: --scheduler")
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("address, why", [
    ("tcp://127.0.0.1:abc", "port"), ("tcp://127.0.0.1:0", "1-65535"),
    ("tcp://127.0.0.1:65536", "1-65535"), ("tcp://127.0.0.1", "port is missing"),
    ("tcp://:8786", "host is missing"), ("ftp://x:21", "scheme"),
    ("127.0.0.1:8786", "tcp://127.0.0.1:8786"), ("tcp://a b:8786", "host"),
    ("tcp://h:8786/x", "nothing may follow"),
])
def test_malformed_address_is_bad_input_before_any_work(tmp_path, capfd, address, why):
    out = tmp_path / "s"
    code = main(["study", str(_config(tmp_path)), "--out", str(out), "--scheduler", address])
    assert code == 2
    _one_error_line(capfd.readouterr().err, why)
    assert not out.exists()


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "tcp://[::1]:1", "tls://host:65535",
                                     "inproc://10.0.0.1/123/1", "ws://scheduler.example:80"])
def test_well_formed_addresses_pass(address):
    assert check_address(address) == address


def test_bad_timeout_variable_is_bad_input(tmp_path, capfd, monkeypatch):
    monkeypatch.setenv(dask_cluster.CONNECT_TIMEOUT_ENV, "soon")
    code = main(["study", str(_config(tmp_path)), "--out", str(tmp_path / "s"),
                 "--scheduler", "tcp://127.0.0.1:8786"])
    assert code == 2
    _one_error_line(capfd.readouterr().err, dask_cluster.CONNECT_TIMEOUT_ENV)


@pytest.mark.parametrize("mode, words", [
    ("silent", ("not a Dask scheduler", "no Dask handshake within 1 s")),
    ("http", ("not a Dask scheduler", "no Dask handshake within 1 s")),
    ("random", ("not a Dask scheduler", "no Dask handshake")),
])
def test_listener_that_is_no_scheduler_ends_within_the_bound(tmp_path, capfd, monkeypatch, mode,
                                                             words):
    for k, v in ENV.items():
        monkeypatch.setenv(k, v)
    server = _Listener(mode)
    try:
        t0 = time.monotonic()
        code = main(["study", str(_config(tmp_path)), "--out", str(tmp_path / "s"),
                     "--scheduler", server.address, "--no-progress"])
        elapsed = time.monotonic() - t0
    finally:
        server.close()
    assert code == 2
    # the 1 s bound, and the start of the command (with room for a second test process on the
    # same cores; the default bound, 10 s, is far beyond)
    assert elapsed < 1.0 + 5.0
    _one_error_line(capfd.readouterr().err, server.address, *words)


def test_refused_connection_is_one_line(tmp_path, capfd, monkeypatch):
    for k, v in ENV.items():
        monkeypatch.setenv(k, v)
    with socket.socket() as s:  # a port nobody listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code = main(["study", str(_config(tmp_path)), "--out", str(tmp_path / "s"),
                 "--scheduler", f"tcp://127.0.0.1:{port}"])
    assert code == 2
    _one_error_line(capfd.readouterr().err, "cannot connect")


@pytest.fixture(scope="module")
def lonely_scheduler():
    """A tcp scheduler in this process without any worker."""
    from distributed import LocalCluster
    with LocalCluster(n_workers=0, processes=False, protocol="tcp://",
                      dashboard_address=None) as c:
        yield c


def _cli(args, env_extra, **kw):
    env = {**os.environ, **ENV, **env_extra, "MPLBACKEND": "Agg"}
    return subprocess.Popen([sys.executable, "-m", "actuator_design.cli", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def test_scheduler_without_workers_ends_within_the_bound(tmp_path, lonely_scheduler):
    out = tmp_path / "s"
    t0 = time.monotonic()
    proc = _cli(["study", str(_config(tmp_path)), "--out", str(out), "--no-progress",
                 "--scheduler", lonely_scheduler.scheduler_address], {})
    _, err = proc.communicate(timeout=30)
    elapsed = time.monotonic() - t0
    assert proc.returncode == 2
    _one_error_line(err, "no worker joined", "within 1 s", dask_cluster.WORKER_TIMEOUT_ENV)
    assert elapsed < 15  # 1 s of waiting; the rest is the start of a Python process
    assert not (out / "journal.jsonl").exists()


SLOW_CHUNKS = textwrap.dedent("""
    # dask worker preload: every chunk takes 0.6 s longer, so that the worker can be killed
    # while the study is still running
    # (distributed may run a preload file twice: wrap once)
    import time
    import actuator_design.study.worker as worker
    if not getattr(worker.run_chunk, "slowed", False):
        _run_chunk = worker.run_chunk
        def run_chunk(task):
            time.sleep(0.6)
            return _run_chunk(task)
        run_chunk.slowed = True
        worker.run_chunk = run_chunk
""")


def _journaled(path):
    try:
        return max(0, len(path.read_text().splitlines()) - 1)  # the first line is the header
    except OSError:
        return 0


def _start_study_until_journaled(tmp_path, address):
    """Start the study CLI on ``address``; return (process, folder, journal) once a point is
    journaled (or 120 s have passed: a busy machine took over 30 s to start the CLI and solve)."""
    out = tmp_path / "s"
    journal = out / "journal.jsonl"
    proc = _cli(["study", str(_config(tmp_path)), "--out", str(out), "--no-progress",
                 "--scheduler", address], {})
    deadline = time.monotonic() + 120
    while _journaled(journal) < 1 and time.monotonic() < deadline:
        time.sleep(0.02)
    return proc, out, journal


def test_only_worker_killed_mid_study_stops_resumably(tmp_path, lonely_scheduler):
    """The only worker dies after its first chunk: the study stops within the worker bound with
    exit 3, keeps the finished chunk, and a resume on a cluster with workers completes it."""
    address = lonely_scheduler.scheduler_address
    preload = tmp_path / "slow_chunks.py"
    preload.write_text(SLOW_CHUNKS)
    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                               "--nthreads", "1", "--no-nanny", "--no-dashboard",
                               "--preload", str(preload)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        with distributed.Client(address, set_as_default=False) as c:
            c.wait_for_workers(1, timeout=30)
        proc, out, journal = _start_study_until_journaled(tmp_path, address)
        assert _journaled(journal) >= 1
        worker.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        _, err = proc.communicate(timeout=30)
        after_kill = time.monotonic() - killed
    finally:
        if worker.poll() is None:
            worker.kill()
        worker.wait()
    assert proc.returncode == 3
    _one_error_line(err, "every worker", "left mid-study", "--resume")
    assert after_kill < 1.0 + 5.0  # the 1 s bound, a check every second, the close
    kept = _journaled(journal)
    assert 1 <= kept < 5
    assert json.loads((out / "manifest.json").read_text())["status"] != "completed"

    # resuming while the cluster still has no worker: the folder keeps its partial run (exit 3)
    again = _cli(["study", str(_config(tmp_path)), "--out", str(out), "--no-progress", "--resume",
                  "--scheduler", address], {})
    _, err = again.communicate(timeout=30)
    assert again.returncode == 3
    _one_error_line(err, "no worker joined", "--resume")
    assert _journaled(journal) == kept

    from distributed import LocalCluster
    with LocalCluster(processes=False, n_workers=1, threads_per_worker=1,
                      dashboard_address=None) as good:
        report = run_study(STUDY, out, scheduler=good.scheduler_address, resume=True,
                           progress=False)
    assert report.status == "completed" and report.counts["ok"] == 5
    assert report.reused == kept and report.computed == 5 - kept


def test_lost_workers_raise_a_resumable_error_in_the_api(lonely_scheduler, monkeypatch):
    """The watch of :func:`run_on_dask` on its own: no worker for the bound is resumable."""
    monkeypatch.setenv(dask_cluster.WORKER_TIMEOUT_ENV, "0.5")
    monkeypatch.setattr(dask_cluster, "_CHECK_S", 0.1)
    with distributed.Client(lonely_scheduler.scheduler_address, set_as_default=False) as client:
        gen = dask_cluster.run_on_dask([{"points": []}], client)
        t0 = time.monotonic()
        with pytest.raises(ClusterError, match="left mid-study") as info:
            next(gen)
        assert time.monotonic() - t0 < 5  # the 0.5 s bound (the default is 60 s), with room for a busy machine
    assert info.value.resumable


def test_scheduler_killed_mid_study_stops_resumably(tmp_path):
    """The scheduler dies mid-study: the study stops within the connect bound with exit 3, one
    line (none of distributed's own tracebacks), and the finished chunk journaled."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    preload = tmp_path / "slow_chunks.py"
    preload.write_text(SLOW_CHUNKS)
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                                  "--port", str(port), "--no-dashboard"], **quiet)
    worker = None
    try:
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                   "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                   "--preload", str(preload)], **quiet)
        with distributed.Client(address, timeout=30, set_as_default=False) as c:
            c.wait_for_workers(1, timeout=30)
        proc, out, journal = _start_study_until_journaled(tmp_path, address)
        scheduler.kill()
        killed = time.monotonic()
        _, err = proc.communicate(timeout=30)
        after_kill = time.monotonic() - killed
    finally:
        for p in (worker, scheduler):
            if p is not None:
                p.kill()
                p.wait()
    assert proc.returncode == 3
    _one_error_line(err, "lost the connection to the scheduler", "--resume")
    assert after_kill < 1.0 + 5.0
    assert 1 <= _journaled(journal) < 5
