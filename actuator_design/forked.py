"""Work computed beside this process, in a forked copy of it (issue 17: the main job's wall time).

A design runs stages whose parts do not depend on each other: the search of the next variable
set while this one is searched, half of the starts of a multi-start, the robust design while the
nominal one's robustness is reported, the verification while the robust design's branch is
followed, half of a figure while the other half is drawn. :func:`start` forks the process (a
copy-on-write image: the built solvers, caches and inputs are the parent's, nothing is pickled on
the way in), runs the task in the child and sends its return value back through a pipe;
:meth:`Forked.result` returns it. A task that raises, or whose value does not pickle, is run again
here when its result is asked for, so its exception (with its traceback) or its value is this
process's own.

The child computes exactly what this process would (the same code on the same state), so a
result does not depend on whether the task was forked: the same request gives the same answer
with one worker or two. ``ACTUATOR_DESIGN_WORKERS=N`` (a whole number ≥ 1; default: the CPUs
this process may use) caps the processes of the family; with 1 every task runs in this process,
when its result is asked for.

The task runs here instead of in a child off Linux (macOS's system libraries are not fork-safe;
Windows has no fork), when only
one CPU is usable, when the family already runs as many processes as it may, when this process
already runs threads (forking a multi-threaded process can deadlock the child) or is itself a
worker of :func:`actuator_design.parallel.map_parallel`.
"""
from __future__ import annotations

import contextlib
import os
import pickle
import select
import signal
import sys
import threading
import warnings
from typing import Callable, Generic, List, Optional, Sequence, Tuple, TypeVar

from actuator_design.parallel import default_workers, end_with_parent, in_worker

__all__ = ["Forked", "start", "while_waiting", "fork_allowed"]

T = TypeVar("T")

#: environment variable: the number of processes a design may use (1: none forked)
WORKERS_ENV = "ACTUATOR_DESIGN_WORKERS"
#: at most this many processes in a family, whatever is asked
MAX_WORKERS = 256

_IDLE: List[Callable[[], None]] = []
_IN_CHILD = False


def while_waiting(fn: Callable[[], None]) -> None:
    """Run ``fn`` (once) when this process waits for a forked child that is still computing, e.g.
    importing the figure modules (:func:`actuator_design.viz.style.preload`) while a search
    finishes beside; work that did not fit in a wait is not run by this module."""
    _IDLE.append(fn)


def _workers() -> int:
    given = os.environ.get(WORKERS_ENV, "").strip()
    if given.isdigit() and int(given) >= 1:
        return int(given)
    if given:
        warnings.warn(f"{WORKERS_ENV}={given!r} is not a whole number >= 1: ignored (all usable CPUs)",
                      RuntimeWarning, stacklevel=3)
    return default_workers()


def fork_allowed() -> bool:
    """Whether :func:`start` may fork (see the module docstring for when it does not)."""
    # Linux only: macOS's system libraries are not safe to use in a forked child
    # a forked child forks no further: it dies with its parent (PR_SET_PDEATHSIG), and a
    # grandchild killed that way could not give its slot back
    return (sys.platform.startswith("linux") and not _IN_CHILD and _workers() > 1
            and threading.active_count() == 1 and not in_worker())


#: The process family's free slots, as bytes in a pipe every forked process inherits (a make
#: jobserver): a fork takes one, its parent returns it on reaping the child. Workers − 1 slots, so
#: the family never runs more processes than the CPUs it may use; a task without a slot runs in
#: its own process when its result is asked for.
_SLOTS: Optional[Tuple[int, int]] = None


def _take_slot() -> bool:
    global _SLOTS
    if _SLOTS is None:
        read_fd, write_fd = os.pipe()
        os.set_blocking(read_fd, False)
        os.write(write_fd, b"x" * (min(_workers(), MAX_WORKERS) - 1))  # (a pipe holds 64 KiB)
        _SLOTS = (read_fd, write_fd)
    try:
        return len(os.read(_SLOTS[0], 1)) == 1
    except BlockingIOError:
        return False


def _give_slot() -> None:
    os.write(_SLOTS[1], b"x")


def _quietly(fn: Callable[[], None]) -> None:
    """Run work done ahead of need; a failure is not this task's: the work runs again, and fails
    where it is needed (if it is)."""
    try:
        fn()
    except Exception:  # noqa: BLE001
        pass


class Forked(Generic[T]):
    """A task started by :func:`start`: its result, once, by :meth:`result`; :meth:`cancel` ends it."""

    def __init__(self, task: Callable[[], T], while_waiting: Sequence[Callable[[], None]] = ()):
        self._task, self._pid, self._fd, self._done = task, None, None, False
        self._idle = list(while_waiting)
        self._value: Optional[tuple] = None
        try:
            if fork_allowed() and _take_slot():
                try:
                    self._fork()
                except OSError:  # no process or pipe to be had (EAGAIN, EMFILE): the task runs here
                    _give_slot()
        except OSError:  # no pipe for the slots: the task runs here
            pass

    def _fork(self) -> None:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.flush()
        read_fd, write_fd = os.pipe()
        try:
            pid = os.fork()
        except OSError:
            os.close(read_fd)
            os.close(write_fd)
            raise
        if pid == 0:  # the child: compute, send, leave without running the parent's clean-up
            global _IN_CHILD
            _IN_CHILD = True
            os.close(read_fd)
            code = 0
            try:
                signal.signal(signal.SIGINT, signal.SIG_DFL)  # Ctrl-C: the parent reports it
                end_with_parent()  # a parent killed outright leaves no child computing for nobody
                quiet = os.open(os.devnull, os.O_WRONLY)  # what the task says, the parent says
                os.dup2(quiet, 1)
                os.dup2(quiet, 2)
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    outcome = ("value", self._task())
                payload = pickle.dumps((outcome, [(str(w.message), w.category) for w in caught]))
            except BaseException:  # noqa: BLE001 - a failure, or a value that does not pickle:
                payload = pickle.dumps((("inline", None), []))  # the parent runs the task itself
            try:
                with os.fdopen(write_fd, "wb") as fh:
                    fh.write(payload)
            except BaseException:  # noqa: BLE001 - the parent is gone or cancelled the task
                code = 1
            os._exit(code)
        os.close(write_fd)
        self._pid, self._fd = pid, read_fd

    def result(self) -> T:
        """The task's return value (computed here if it was not forked, raised, or did not pickle:
        its exception is then raised here). Warnings the child raised are raised again here."""
        if not self._done:
            if self._pid is None:
                self._value = ("value", self._task())
            else:
                # this task's own work for the wait, then everyone's, one at a time while the child
                # still computes (what is left runs when it is needed)
                try:
                    for fn in self._idle:
                        if self._finished():
                            break
                        _quietly(fn)
                    while _IDLE and not self._finished():
                        _quietly(_IDLE.pop(0))
                except BaseException:  # interrupted while waiting: the child is not wanted any more
                    self._end_child(kill=True)
                    raise
                data, ok = self._collect()
                # a child that did not end cleanly (killed mid-write) leaves the task to this process
                try:
                    self._value, caught = pickle.loads(data) if ok and data else (("inline", None), [])
                except Exception:  # noqa: BLE001 - a truncated payload
                    self._value, caught = ("inline", None), []
                for message, category in caught:
                    warnings.warn(message, category, stacklevel=2)
                if self._value[0] == "inline":  # its own exception, with its traceback, or its value
                    self._value = ("value", self._task())
            self._done, self._task = True, None
        kind, value = self._value
        if kind == "cancelled":
            raise RuntimeError("the result of a cancelled task was asked for")
        return value

    def _collect(self) -> bytes:
        """Read the child's payload, reap it, give its slot back (also when interrupted):
        ``(payload, whether the child exited cleanly)``."""
        chunks = []
        try:
            while True:
                chunk = os.read(self._fd, 1 << 20)
                if not chunk:
                    break
                chunks.append(chunk)
        except BaseException:  # interrupted: the child's result is not wanted any more
            self._end_child(kill=True)
            raise
        return b"".join(chunks), self._end_child(kill=False)

    def _end_child(self, kill: bool) -> bool:
        """Reap the child (killed first when ``kill``), close its pipe, give its slot back; whether
        it exited with status 0."""
        if self._pid is None:
            return False
        pid, self._pid = self._pid, None
        clean = False
        try:
            if kill:
                os.kill(pid, signal.SIGKILL)
            clean = os.waitpid(pid, 0)[1] == 0
        except OSError:
            pass
        try:
            os.close(self._fd)
        except OSError:
            pass
        _give_slot()
        return clean

    def _finished(self) -> bool:
        """The child has sent its result (or ended): its pipe is readable."""
        return bool(select.select([self._fd], [], [], 0.0)[0])

    def cancel(self) -> None:
        """End the task if it still runs in a child (its result is not wanted); after
        :meth:`result`, nothing."""
        self._end_child(kill=True)
        if not self._done:
            self._done, self._task, self._value = True, None, ("cancelled", None)


def start(task: Callable[[], T], while_waiting: Sequence[Callable[[], None]] = ()) -> Forked[T]:
    """Start ``task`` (a function of no arguments whose return value pickles) beside this process.

    ``while_waiting``: functions this process runs when it comes to wait for the task's result,
    one at a time while the child still computes (work it will need anyway, e.g. building a
    solver); not run when the task was not forked.

    Returns
    -------
    Forked
        Ask for the value with :meth:`Forked.result`; :meth:`Forked.cancel` when it is not needed.
    """
    return Forked(task, while_waiting)
