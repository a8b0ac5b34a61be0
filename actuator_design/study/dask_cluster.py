"""A study on a Dask cluster with every wait bounded: the address checked before any work, the
connection, the wait for workers and the loss of the workers or of the scheduler mid-study.

Bounds (seconds; environment variables override them, e.g. for tests):

``ACTUATOR_DESIGN_DASK_TIMEOUT`` (default :data:`CONNECT_TIMEOUT_S`)
    to connect to the scheduler and receive its handshake, and how long the scheduler may stay
    unreachable mid-study;
``ACTUATOR_DESIGN_DASK_WORKER_TIMEOUT`` (default :data:`WORKER_TIMEOUT_S`)
    for a first worker to join, and for one to join again once every worker has left mid-study.

Before distributed opens its own connection to a ``tcp://`` address, :func:`probe_scheduler`
reads the scheduler's greeting with a bounded, small read: a Dask scheduler speaks first (a
length-prefixed handshake of some 60 bytes), so a silent listener, an HTTP server or a port sending
other bytes is named at once — distributed itself would wait on a silent listener without end and
try to allocate whatever frame length the first 8 bytes of another protocol announce.

Every failure is a :class:`ClusterError`: one line naming ``--scheduler``.
"""
from __future__ import annotations

import ipaddress
import logging
import math
import os
import re
import socket
import struct
import threading
import time
from concurrent.futures import CancelledError
from typing import Dict, Iterator, List, Optional, Tuple
from urllib.parse import urlsplit

from actuator_design.study import worker  # called as worker.run_chunk: the seam a test replaces
from actuator_design.study.errors import StudyError

__all__ = ["ClusterError", "CONNECT_TIMEOUT_S", "WORKER_TIMEOUT_S", "CONNECT_TIMEOUT_ENV",
           "WORKER_TIMEOUT_ENV", "SCHEMES", "check_address", "timeouts", "quiet_distributed_logs",
           "probe_scheduler", "connect", "run_on_dask"]

#: Seconds to connect and receive the scheduler's handshake (also: the scheduler unreachable).
CONNECT_TIMEOUT_S = 10.0
#: Seconds to wait for a worker: before the study and after the last one left mid-study.
WORKER_TIMEOUT_S = 60.0
CONNECT_TIMEOUT_ENV = "ACTUATOR_DESIGN_DASK_TIMEOUT"
WORKER_TIMEOUT_ENV = "ACTUATOR_DESIGN_DASK_WORKER_TIMEOUT"
#: Largest bound an environment variable may set (one day).
_MAX_TIMEOUT_S = 86400.0

#: Address schemes of distributed's comm layer.
SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")
#: Largest greeting a Dask scheduler sends (its handshake is about 60 bytes) and its frame count.
_MAX_GREETING_BYTES = 1 << 16
_MAX_GREETING_FRAMES = 64
#: Seconds between two looks at the cluster while waiting for chunks.
_CHECK_S = 1.0
_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9._-]*[A-Za-z0-9])?")
_EXAMPLE = "tcp://127.0.0.1:8786"


class ClusterError(StudyError):
    """The Dask cluster cannot run the study: unreachable, not a scheduler, no workers, workers
    or scheduler lost mid-study. One line.

    Attributes
    ----------
    resumable : bool
        The run had started (journal open): the study folder holds a run that ``--resume``
        continues (exit 3 at the command line, else 2).
    """

    def __init__(self, message: str, resumable: bool = False):
        super().__init__(message)
        self.resumable = resumable


def check_address(text) -> str:
    """The scheduler address ``text`` if it is well formed: a known scheme and, except for
    ``inproc://``, a host and a port in 1-65535 with nothing after them.

    Raises
    ------
    ClusterError
        ``--scheduler: invalid address 'tcp://127.0.0.1:abc': the port must be an integer in
        1-65535 (e.g. tcp://127.0.0.1:8786)``.
    """
    def bad(why: str) -> ClusterError:
        return ClusterError(f"--scheduler: invalid address {text!r}: {why} (e.g. {_EXAMPLE})")

    if not isinstance(text, str) or "://" not in text:
        hint = f"; did you mean tcp://{text}?" if isinstance(text, str) and ":" in text else ""
        raise bad(f"expected SCHEME://HOST:PORT with a scheme among {', '.join(SCHEMES)}{hint}")
    scheme, rest = text.split("://", 1)
    if scheme not in SCHEMES:
        known = ", ".join(s + "://" for s in SCHEMES)
        raise bad(f"unknown scheme {scheme + '://'!r} (one of {known})")
    if scheme == "inproc":
        if not rest or any(c.isspace() for c in rest):
            raise bad("an inproc address names this process's scheduler (inproc://IP/PID/N)")
        return text
    parts = urlsplit(text)
    if parts.path or parts.query or parts.fragment or "@" in parts.netloc:
        raise bad("nothing may follow HOST:PORT")
    host = parts.hostname or ""
    if not host or not _valid_host(host, parts.netloc):
        raise bad(f"the host {host!r} is not a host name or IP address" if host
                  else "the host is missing")
    try:
        port = parts.port
    except ValueError:
        port = -1
    if port is None:
        raise bad("the port is missing")
    if not 1 <= port <= 65535:
        raise bad(f"the port {rest.rsplit(':', 1)[-1]!r} must be an integer in 1-65535")
    return text


def _valid_host(host: str, netloc: str) -> bool:
    if netloc.startswith("["):  # [IPv6]:PORT
        try:
            return isinstance(ipaddress.ip_address(host), ipaddress.IPv6Address)
        except ValueError:
            return False
    return len(host) <= 253 and _HOST.fullmatch(host) is not None


def quiet_distributed_logs() -> None:
    """Keep distributed's own log records (info, and the tracebacks it logs when a client gives
    up on a lost scheduler) off stderr: at the command line a failure is the one line of a
    :class:`ClusterError`. Imports distributed."""
    import distributed  # noqa: F401 - its import configures the loggers set here

    names = [n for n in logging.root.manager.loggerDict if n.split(".")[0] == "distributed"]
    for name in ["distributed", *names]:  # its config gives some children their own level
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def timeouts() -> Tuple[float, float]:
    """The bounds (connect, workers) in seconds: the defaults or the environment's.

    Raises
    ------
    ClusterError
        An environment variable that is not a number of seconds in (0, 86400].
    """
    values = []
    for name, default in ((CONNECT_TIMEOUT_ENV, CONNECT_TIMEOUT_S),
                          (WORKER_TIMEOUT_ENV, WORKER_TIMEOUT_S)):
        text = os.environ.get(name, "").strip()
        if not text:
            values.append(default)
            continue
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and 0 < value <= _MAX_TIMEOUT_S):
            raise ClusterError(f"--scheduler: {name}={text!r} must be a number of seconds in "
                               f"(0, {_MAX_TIMEOUT_S:g}]")
        values.append(value)
    return values[0], values[1]


def _bounds_hint() -> str:
    return f"{CONNECT_TIMEOUT_ENV} sets this bound"


def probe_scheduler(address: str, timeout: float) -> None:
    """Check that a ``tcp://`` address is a Dask scheduler: connect, read its greeting (a small
    length-prefixed handshake, sent before the client says anything) within ``timeout`` seconds.

    Raises
    ------
    ClusterError
        Refused, unreachable, silent, closed, or bytes that are not a Dask handshake.
    """
    parts = urlsplit(address)
    deadline = time.monotonic() + timeout
    try:
        sock = socket.create_connection((parts.hostname, parts.port), timeout=timeout)
    except socket.timeout:
        raise ClusterError(f"--scheduler: cannot connect to {address}: no answer within "
                           f"{timeout:g} s ({_bounds_hint()})") from None
    except OSError as err:
        why = err.strerror or str(err) or type(err).__name__
        raise ClusterError(f"--scheduler: cannot connect to {address}: {why}") from None
    not_dask = (f"--scheduler: {address} is not a Dask scheduler: it accepted the connection but "
                "{what}; a scheduler listens on port 8786 by default, its dashboard on 8787")
    with sock:
        header = _read_exactly(sock, 8, deadline)
        if header is None:
            raise ClusterError(not_dask.format(what=f"sent no Dask handshake within {timeout:g} s"
                                                    f" ({_bounds_hint()})"))
        if len(header) < 8:
            raise ClusterError(not_dask.format(what="closed it without a Dask handshake"))
        (length,) = struct.unpack("Q", header)
        if not 8 <= length <= _MAX_GREETING_BYTES:
            raise ClusterError(not_dask.format(what=f"sent bytes that are no Dask handshake "
                                                    f"({header[:8]!r})"))
        body = _read_exactly(sock, length, deadline)
        frames = struct.unpack("Q", body[:8])[0] if body and len(body) >= 8 else 0
        if not body or len(body) < length or not 1 <= frames <= _MAX_GREETING_FRAMES:
            raise ClusterError(not_dask.format(what="sent a truncated or malformed Dask "
                                                    "handshake"))


def _read_exactly(sock: socket.socket, n: int, deadline: float) -> Optional[bytes]:
    """``n`` bytes, fewer if the peer closed, None if none came before ``deadline``."""
    data = b""
    while len(data) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            return data or None
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(data))
        except socket.timeout:
            return data or None
        except OSError:
            return data
        if not chunk:
            return data
        data += chunk
    return data


def _start_client(address: str, timeout: float):
    """A distributed Client for ``address``, given up after ``timeout`` (plus a grace second):
    distributed bounds its connection attempts but not every read of its handshake."""
    from distributed import Client

    box: Dict[str, object] = {}

    def start():
        try:
            box["client"] = Client(address, timeout=timeout, set_as_default=False)
        except BaseException as err:  # noqa: BLE001 - reported in the calling thread
            box["error"] = err

    thread = threading.Thread(target=start, name="dask-connect", daemon=True)
    thread.start()
    thread.join(timeout + 1.0)
    if thread.is_alive():
        raise ClusterError(f"--scheduler: {address} did not complete the Dask handshake within "
                           f"{timeout:g} s ({_bounds_hint()})")
    err = box.get("error")
    if err is not None:
        raise ClusterError(f"--scheduler: cannot connect to {address}: {_one_line(err)}") from None
    return box["client"]


def _one_line(err: BaseException) -> str:
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def connect(scheduler) -> Tuple[object, int]:
    """A client connected to a scheduler that has at least one worker, and the cluster's worker
    threads; every step bounded (:func:`timeouts`).

    Parameters
    ----------
    scheduler : str or distributed.Client
        An address (checked, probed, connected to) or a connected client (used as it is, after
        the wait for a worker).

    Raises
    ------
    ClusterError
        A malformed address, 'distributed' missing, the scheduler unreachable or not a scheduler,
        or no worker within the bound.
    """
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterError("--scheduler: running on a Dask cluster needs the 'distributed' "
                           "package (pip install 'dask[distributed]')") from None
    connect_s, workers_s = timeouts()
    own = isinstance(scheduler, str)
    if own:
        address = check_address(scheduler)
        if address.startswith("tcp://"):
            probe_scheduler(address, connect_s)
        client = _start_client(address, connect_s)
    else:
        client, address = scheduler, getattr(scheduler.scheduler, "address", "the scheduler")
    try:
        try:
            client.wait_for_workers(1, timeout=workers_s)
        except TimeoutError:
            raise ClusterError(f"--scheduler: no worker joined the scheduler at {address} within "
                               f"{workers_s:g} s (start some: dask worker {address} --nthreads 1; "
                               f"{WORKER_TIMEOUT_ENV} sets this wait)") from None
        threads = _worker_threads(client, connect_s)
        if threads is None:
            raise ClusterError(f"--scheduler: {address} stopped answering within {connect_s:g} s")
    except BaseException:
        if own:
            _close(client, connect_s)
        raise
    return client, max(1, threads)


def _worker_threads(client, timeout: float) -> Optional[int]:
    """Threads of the cluster's workers (0: none), None when the scheduler does not answer."""
    try:
        return sum(int(n) for n in client.nthreads(callback_timeout=timeout).values())
    except Exception:  # noqa: BLE001 - timeout, closed comm, closed client: no answer
        return None


def _close(client, timeout: float) -> None:
    try:
        client.close(timeout=timeout)
    except Exception:  # noqa: BLE001 - a client of a scheduler that is gone
        pass


def run_on_dask(tasks: List[dict], client) -> Iterator[List[dict]]:
    """Chunks as Dask futures on ``client``, yielded as they finish; the pending ones are
    cancelled when the generator is closed.

    Dask runs a chunk again elsewhere when its worker dies; if every worker has gone and none
    joins within the worker bound, or the scheduler stays unreachable for the connect bound,
    this stops with a resumable :class:`ClusterError` (the chunks finished so far are kept).
    """
    from distributed import as_completed

    connect_s, workers_s = timeouts()
    address = getattr(client.scheduler, "address", "the scheduler")
    futures = []
    try:
        futures = client.map(worker.run_chunk, [{**t, "single_threaded_blas": True} for t in tasks],
                             pure=False)
        done = as_completed(futures, loop=client.loop)
        watch = _Watch(client, address, connect_s, workers_s)
        while not done.is_empty():
            if done.has_ready():
                yield _result(next(done), address)
            else:
                watch.check()
                time.sleep(0.02)
    finally:
        pending = [f for f in futures if not f.done()]
        if pending:
            try:
                client.cancel(pending)
            except Exception:  # noqa: BLE001 - the scheduler is gone: nothing to cancel
                pass


_RESUME = "the finished points are journaled: run again with --resume to compute the rest"


class _Watch:
    """Looks at the cluster every :data:`_CHECK_S` seconds while chunks are pending."""

    def __init__(self, client, address: str, connect_s: float, workers_s: float):
        self.client, self.address = client, address
        self.connect_s, self.workers_s = connect_s, workers_s
        self.next_check = time.monotonic() + _CHECK_S
        self.no_worker_since: Optional[float] = None
        self.no_answer_since: Optional[float] = None

    def check(self) -> None:
        now = time.monotonic()
        if now < self.next_check:
            return
        threads = _worker_threads(self.client, min(self.connect_s, _CHECK_S))
        self.next_check = time.monotonic() + _CHECK_S
        if threads is None:
            self.no_answer_since = self.no_answer_since or now
            if now - self.no_answer_since >= self.connect_s:
                raise ClusterError(f"--scheduler: lost the connection to the scheduler at "
                                   f"{self.address} for {self.connect_s:g} s mid-study "
                                   f"({CONNECT_TIMEOUT_ENV} sets this bound); {_RESUME}",
                                   resumable=True)
            return
        self.no_answer_since = None
        if threads:
            self.no_worker_since = None
            return
        self.no_worker_since = self.no_worker_since or now
        if now - self.no_worker_since >= self.workers_s:
            raise ClusterError(f"--scheduler: every worker of {self.address} left mid-study and "
                               f"none joined within {self.workers_s:g} s ({WORKER_TIMEOUT_ENV} "
                               f"sets this wait); {_RESUME}", resumable=True)


def _result(future, address: str) -> List[dict]:
    """A finished chunk's records; the cluster's failures as a :class:`ClusterError`."""
    from distributed import KilledWorker

    try:
        return future.result()
    except KilledWorker:
        raise ClusterError(f"--scheduler: workers of {address} died while running the "
                           f"same chunk of points, as often as distributed allows "
                           f"(distributed.scheduler.allowed-failures); "
                           f"{_RESUME}", resumable=True) from None
    except CancelledError:
        raise ClusterError(f"--scheduler: lost the connection to the scheduler at {address} "
                           f"mid-study; {_RESUME}", resumable=True) from None
    except ImportError as err:
        raise ClusterError(f"--scheduler: a worker of {address} cannot import the study code "
                           f"({_one_line(err)}): install actuator-design in the workers' "
                           f"environment; {_RESUME}", resumable=True) from None
