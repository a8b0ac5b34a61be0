"""Files of an output folder are the tool's own: no symbolic links followed, no wrong entry types.

A folder the tool writes into (a study folder, a command's ``--out``) may hold entries planted by
someone else: ``journal.jsonl`` as a symbolic link to a file elsewhere, ``figures`` as a file,
``results.csv`` as a directory, ``study.lock`` as a FIFO. :func:`check_entries` refuses such a
folder before anything is written (:class:`OutputFolderError`, one line naming the entry), and
:func:`open_regular` opens a file without following a link (``O_NOFOLLOW``) and without blocking on
a FIFO (``O_NONBLOCK``), refusing anything that is not a regular file. :func:`write_all` writes
through :func:`os.write` (a short write is continued, an error such as ``ENOSPC`` raised), and
:func:`os_error_text` turns an :class:`OSError` into the words of one error line.
"""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import Mapping, Optional

__all__ = ["OutputFolderError", "FILE", "DIRECTORY", "entry_problem", "check_entries",
           "open_regular", "write_all", "read_all", "os_error_text"]

#: Kinds of entries :func:`check_entries` expects.
FILE, DIRECTORY = "file", "directory"

_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)

_REMEDY = "remove it or choose another folder"


class OutputFolderError(ValueError):
    """An entry of an output folder is not what the tool writes there (one line, exit 2)."""


def _kind(mode: int) -> str:
    """The kind of a file mode in words: ``a regular file``, ``a directory``, ``a FIFO``, …"""
    for test, name in ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a directory"),
                       (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISLNK, "a symbolic link")):
        if test(mode):
            return name
    return "a special file"


def entry_problem(path, expected: str) -> Optional[str]:
    """Why the entry ``path`` cannot be written as ``expected`` (:data:`FILE` or
    :data:`DIRECTORY`), or None when it is absent or of the expected kind (links not followed)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(st.st_mode):
        try:
            target = os.readlink(path)
        except OSError:
            target = "?"
        return f"{path} is a symbolic link (to {target}), not the tool's own {expected}"
    wanted = stat.S_ISREG if expected == FILE else stat.S_ISDIR
    if not wanted(st.st_mode):
        article = "a regular file" if expected == FILE else "a directory"
        return f"{path} is {_kind(st.st_mode)}, expected {article}"
    return None


def check_entries(folder, entries: Mapping[str, str], what: str = "--out") -> None:
    """Refuse a folder whose named entries are links or of the wrong kind.

    Parameters
    ----------
    folder : str or Path
        The folder (absent: nothing to check).
    entries : mapping of name → :data:`FILE` or :data:`DIRECTORY`
        The entries the tool writes, and what each must be when present.
    what : str
        Names the option in the message.

    Raises
    ------
    OutputFolderError
        ``--out: DIR/figures is a regular file, expected a directory; remove it or …``.
    """
    folder = Path(folder)
    for name, expected in entries.items():
        problem = entry_problem(folder / name, expected)
        if problem is not None:
            raise OutputFolderError(f"{what}: {problem}; {_REMEDY}")


def open_regular(path, flags: int, mode: int = 0o644, what: str = "--out") -> int:
    """``os.open`` of a regular file of an output folder: a link is not followed, a FIFO does not
    block, and anything but a regular file is refused.

    Returns
    -------
    int
        The descriptor (blocking, close-on-exec).

    Raises
    ------
    OutputFolderError
        ``path`` is a symbolic link or not a regular file.
    OSError
        Any other failure (``ENOENT``, ``EROFS``, ``ENOSPC``, …).
    """
    try:
        fd = os.open(path, flags | _NOFOLLOW | _NONBLOCK | _CLOEXEC, mode)
    except OSError as err:
        if err.errno in (errno.ELOOP, errno.EMLINK, errno.ENXIO):  # a link, or a FIFO (no reader)
            raise OutputFolderError(f"{what}: {entry_problem(path, FILE) or err}; "
                                    f"{_REMEDY}") from None
        raise
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OutputFolderError(f"{what}: {path} is {_kind(st.st_mode)}, expected a regular "
                                    f"file; {_REMEDY}")
        if _NONBLOCK:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


def write_all(fd: int, data: bytes) -> None:
    """Write all of ``data`` to ``fd`` (short writes continued; errors such as ENOSPC raised)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def read_all(fd: int) -> bytes:
    """All bytes of an open file from its start."""
    chunks = []
    offset = 0
    while True:
        chunk = os.pread(fd, 1 << 20, offset)
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)
        offset += len(chunk)


def os_error_text(err: OSError, doing: str = "") -> str:
    """The words of one error line for a file-system error: ``cannot write X: No space left on
    device`` (no ``[Errno 28]``; the file named once)."""
    reason = err.strerror or str(err) or type(err).__name__
    name = err.filename
    where = f" {name}" if name is not None else ""
    lead = f"{doing}{where}: " if (doing or where) else ""
    return f"{lead}{reason}".strip()

