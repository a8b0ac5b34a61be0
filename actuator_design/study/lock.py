"""The lock of a study folder: one writer at a time.

A run holds ``<folder>/study.lock`` with an exclusive :func:`fcntl.flock` from before it writes
anything until after its last file; the file's content names the holder (pid, host, start time)
so that a second writer can say who has the folder. The kernel drops a ``flock`` when its holder
dies, also by ``kill -9``, so a dead run never keeps a folder: a lock file it left behind is
taken over, with a note naming the run that left it.

Where ``fcntl`` does not exist (Windows) the file is created exclusively instead; an existing one
is taken over only when it names a process of this host known to be gone (:func:`pid_alive`
cannot tell on Windows: there the refusal names the file to remove).

The lock file is opened without following a link and refused unless it is a regular file
(:func:`actuator_design.io.safe_files.open_regular`): a ``study.lock`` planted as a link to a file
elsewhere is never truncated or written.

Locks are per open file: forked worker processes inherit the descriptor, so a worker calls
:func:`close_inherited` first (otherwise a worker that outlived its parent would hold the lock).
"""
from __future__ import annotations

import errno
import json
import os
import socket
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Optional, Set

from actuator_design.io.safe_files import OutputFolderError, open_regular
from actuator_design.study.errors import StudyError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

__all__ = ["LOCK_NAME", "Holder", "FolderLock", "holder_of", "close_inherited", "pid_alive"]

LOCK_NAME = "study.lock"

#: Descriptors of the locks this process holds (closed in forked children).
_HELD: Set[int] = set()

#: A lock found busy is tried again this many times, this far apart, before it is called held
#: (a reader probing the lock holds it for a moment).
_TRIES, _PAUSE_S = 4, 0.05


@dataclass(frozen=True)
class Holder:
    """Who holds (or held) a folder's lock, as its lock file says."""

    pid: Optional[int]
    host: Optional[str]
    started: Optional[str]

    def describe(self) -> str:
        """``pid 123 on host h, started 2026-01-01T00:00:00+00:00`` (unknown parts left out)."""
        if self.pid is None:
            return "a process that has not written its name yet"
        parts = [f"pid {self.pid}"]
        if self.host:
            parts.append(f"on host {self.host}")
        text = " ".join(parts)
        return f"{text}, started {self.started}" if self.started else text

    @classmethod
    def parse(cls, text: str) -> Optional["Holder"]:
        """The holder named by a lock file's text; None for an empty file."""
        if not text.strip():
            return None
        try:
            d = json.loads(text)
            pid = d.get("pid")
            return cls(pid if isinstance(pid, int) else None, d.get("host"), d.get("started"))
        except (ValueError, AttributeError):
            return cls(None, None, None)

    @classmethod
    def this_process(cls) -> "Holder":
        return cls(os.getpid(), socket.gethostname(),
                   datetime.now(timezone.utc).isoformat(timespec="seconds"))

    def to_text(self) -> str:
        return json.dumps({"pid": self.pid, "host": self.host, "started": self.started}) + "\n"


def pid_alive(pid: int) -> bool:
    """True when a process with this id exists on this host (POSIX; True when unknown)."""
    if os.name != "posix":
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


#: A lock file longer than this is not a holder's name (only its start is read).
_MAX_HOLDER_BYTES = 4096


def _read(fd: int) -> Optional[Holder]:
    size = min(os.fstat(fd).st_size, _MAX_HOLDER_BYTES)
    return Holder.parse(os.pread(fd, size, 0).decode("utf-8", "replace")) if size else None


def _busy(err: OSError) -> bool:
    return err.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES)


def in_use_message(folder, holder: Optional[Holder]) -> str:
    """The one-line refusal of a second writer."""
    who = holder.describe() if holder else "another process"
    gone = "" if fcntl is not None else f" (if that run is gone, remove {Path(folder) / LOCK_NAME})"
    return (f"--out: {folder} is in use by another study run ({who}); wait for it to end or "
            f"choose another folder{gone}")


class FolderLock:
    """Exclusive lock of a study folder for one run (see the module docstring).

    Parameters
    ----------
    folder : str or Path
        An existing folder.
    """

    def __init__(self, folder):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._fd: Optional[int] = None

    def acquire(self) -> Optional[str]:
        """Take the lock.

        Returns
        -------
        str or None
            A note when a lock left by a run that is over was taken over, else None.

        Raises
        ------
        StudyError
            Another live run holds the folder (the message names it).
        """
        if fcntl is None:  # pragma: no cover - Windows
            return self._acquire_exclusive_file()
        for _ in range(_TRIES):
            fd = self._open()
            self._flock_or_refuse(fd)
            try:  # the file may have been unlinked by its previous holder meanwhile: start again
                same = os.lstat(self.path)[:2] == os.fstat(fd)[:2]
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            left = _read(fd)
            self._hold(fd)
            return self._takeover_note(left)
        raise StudyError(in_use_message(self.folder, self._current_holder()))

    def _open(self) -> int:
        """The lock file, created if absent, opened without following a link."""
        try:
            return open_regular(self.path, os.O_RDWR | os.O_CREAT)
        except OutputFolderError as err:
            raise StudyError(str(err)) from None

    def _flock_or_refuse(self, fd: int) -> None:
        """Exclusive flock on fd (a few tries); StudyError naming the holder (fd closed) when
        another run holds it."""
        for attempt in range(_TRIES):
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return
            except OSError as err:
                if not _busy(err):  # e.g. ENOLCK: a file system without locks
                    os.close(fd)
                    raise StudyError(f"--out: cannot lock {self.folder} "
                                     f"({os.strerror(err.errno)}); choose a local folder") from None
            if attempt + 1 < _TRIES:
                time.sleep(_PAUSE_S)
        holder = _read(fd)
        os.close(fd)
        raise StudyError(in_use_message(self.folder, holder))

    def _current_holder(self) -> Optional[Holder]:
        try:
            fd = open_regular(self.path, os.O_RDONLY)
        except (OSError, OutputFolderError):
            return None
        try:
            return _read(fd)
        finally:
            os.close(fd)

    def _hold(self, fd: int) -> None:
        text = Holder.this_process().to_text().encode()
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, text, 0)
            os.fsync(fd)
        except OSError as err:  # e.g. ENOSPC: name the file (os.pwrite does not)
            os.close(fd)
            if err.filename is None:
                err.filename = str(self.path)
            raise
        self._fd = fd
        _HELD.add(fd)

    def _takeover_note(self, left: Optional[Holder]) -> Optional[str]:
        if left is None:
            return None
        gone = (left.pid is not None and left.host == socket.gethostname()
                and not pid_alive(left.pid))
        why = "that process is gone" if gone else "its lock was free"
        return (f"took over the lock of {self.folder} left by an earlier run ({left.describe()}): "
                f"{why}")

    def _acquire_exclusive_file(self) -> Optional[str]:  # pragma: no cover - Windows
        text = Holder.this_process().to_text()
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            left = self._current_holder()
            if left is None or left.pid is None or left.host != socket.gethostname() \
                    or pid_alive(left.pid):
                raise StudyError(in_use_message(self.folder, left)) from None
            tmp = self.path.with_name(f".{LOCK_NAME}.{os.getpid()}.tmp")
            tmp.write_text(text, encoding="utf-8")
            os.replace(tmp, self.path)
            self._fd = os.open(self.path, os.O_RDWR)
            return self._takeover_note(left)
        os.write(fd, text.encode())
        self._fd = fd
        return None

    def release(self) -> None:
        """Remove the lock file and drop the lock (no-op when not held)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        _HELD.discard(fd)
        if fcntl is None:  # pragma: no cover - Windows: an open file cannot be removed
            os.close(fd)
        try:
            self.path.unlink()
        except OSError:
            pass
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_UN)  # also drops the copies forked workers may still hold
            os.close(fd)

    def __enter__(self) -> "FolderLock":
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def holder_of(folder) -> Optional[Holder]:
    """The live holder of a folder's lock, or None when no run holds it.

    A probe: takes a shared lock for an instant (a writer starting at that moment retries).
    Without ``fcntl``, a lock file naming a live process of this host (or another host) counts.
    """
    path = Path(folder) / LOCK_NAME
    try:
        fd = open_regular(path, os.O_RDONLY)
    except (OSError, OutputFolderError):  # absent, or not a lock this tool made: not held
        return None
    try:
        if fcntl is None:  # pragma: no cover - Windows
            left = _read(fd)
            alive = left is not None and (left.host != socket.gethostname() or left.pid is None
                                          or pid_alive(left.pid))
            return left if alive else None
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError as err:
            if not _busy(err):
                raise
            return _read(fd) or Holder(None, None, None)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def close_inherited() -> None:
    """In a forked child: close the lock descriptors inherited from the parent (the parent keeps
    its lock; the child must not keep it alive after the parent dies)."""
    for fd in list(_HELD):
        try:
            os.close(fd)
        except OSError:
            pass
    _HELD.clear()
