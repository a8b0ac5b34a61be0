"""Fakes of a hostile file system for tests/test_hostile_fs.py: a folder outside the output folder
whose every byte and time is watched, and ``os`` calls that fail as on a read-only or full file
system (the tests may run as root, for whom permissions do not stop a write)."""
import errno
import os
from pathlib import Path

__all__ = ["Outside", "FakeFS"]


class Outside:
    """A folder beside the output folder, with a file and a folder for links to point at."""

    def __init__(self, tmp_path: Path):
        self.root = tmp_path / "outside"
        self.root.mkdir()
        self.file = self.root / "victim.txt"
        self.file.write_text("precious data\n")
        self.dir = self.root / "victim_dir"
        self.dir.mkdir()
        (self.dir / "inside.txt").write_text("also precious\n")
        for p in (self.file, self.dir / "inside.txt", self.dir, self.root):
            os.utime(p, ns=(10 ** 18, 10 ** 18))  # any change would move the times
        self.before = self.snapshot()

    def snapshot(self):
        out = {}
        for p in sorted(self.root.rglob("*")) + [self.root]:
            st = os.lstat(p)
            out[str(p)] = (p.read_bytes() if p.is_file() else None, st.st_mtime_ns, st.st_size)
        return out

    def assert_unchanged(self):
        assert self.snapshot() == self.before


class FakeFS:
    """The ``os`` calls that create, write or rename under ``root`` fail as on a read-only
    (``EROFS``) or full (``ENOSPC``) file system.

    Full: the writes to files whose name starts with ``only`` (any file when None) fill the disk
    after ``full_after`` bytes (the write that crosses the limit is cut short, as a real one is);
    from then on every write under ``root`` fails with ENOSPC."""

    _WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND

    def __init__(self, monkeypatch, root: Path, kind: str, full_after: int = 0,
                 only: str = None):
        self.root = str(Path(root).resolve())
        self.kind, self.left, self.only, self.full = kind, full_after, only, False
        self.real = {n: getattr(os, n) for n in ("open", "write", "mkdir", "replace", "rename")}
        self.refused = 0
        for name in self.real:
            monkeypatch.setattr(os, name, getattr(self, "_" + name))

    def _under(self, path) -> bool:
        p = os.path.abspath(os.fsdecode(path))
        return p == self.root or p.startswith(self.root + os.sep)

    def _fail(self, code, path=None):
        self.refused += 1
        raise OSError(code, os.strerror(code), *([os.fsdecode(path)] if path is not None else []))

    def _open(self, path, flags, mode=0o777, *, dir_fd=None):
        if self.kind == "EROFS" and flags & self._WRITE_FLAGS and self._under(path):
            self._fail(errno.EROFS, path)
        return self.real["open"](path, flags, mode, dir_fd=dir_fd)

    def _write(self, fd, data):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            target = ""
        if not self._under(target):
            return self.real["write"](fd, data)
        if self.kind == "EROFS":
            self._fail(errno.EROFS)
        counted = self.only is None or Path(target).name.startswith(self.only)
        if not self.full and not counted:
            return self.real["write"](fd, data)
        if self.full or self.left <= 0:
            self.full = True
            self._fail(errno.ENOSPC)  # os.write names no file
        part = memoryview(data)[:self.left]
        self.left -= len(part)
        return self.real["write"](fd, part)

    def _mkdir(self, path, mode=0o777, *, dir_fd=None):
        if self.kind == "EROFS" and self._under(path):
            self._fail(errno.EROFS, path)
        return self.real["mkdir"](path, mode, dir_fd=dir_fd)

    def _move(self, name, src, dst, **kw):
        if self.kind == "EROFS" and self._under(dst):
            self._fail(errno.EROFS, src)
        return self.real[name](src, dst, **kw)

    def _replace(self, src, dst, **kw):
        return self._move("replace", src, dst, **kw)

    def _rename(self, src, dst, **kw):
        return self._move("rename", src, dst, **kw)
