"""The journal of a study: one JSON line per finished point, appended in blocks as chunks finish.

The first line is a header ``{"journal": "actuator-design study", "study_id": …, "n_points": …,
"format": 2}``; every other line is a point record (:mod:`actuator_design.study.worker`). A line is
either complete (ends with a newline and parses) or ignored: an interrupted write leaves at most
one partial last line, which :meth:`Journal.open` cuts off before appending. A resumed study reads
the records and skips their points.

A record proves itself (:meth:`Journal.stamp`): ``inputs`` is the digest of the point's resolved
inputs (the study's configuration, analyses, outputs, solver settings and code versions, see
:func:`actuator_design.study.plan.plan_study`, and the point's swept values) and ``checksum`` the
SHA-256 of the record's canonical JSON without ``checksum``. A record is accepted only when its
index names a point of the study, its ``values`` are that point's swept values, its checksum
matches its content and its ``inputs`` digest the grid point's. Anything else — a record edited by
hand (relabelled, fabricated results), written by another version (no checksum: untrusted),
computed from other inputs, a line that is not JSON, too long or nested too deeply — is rejected:
its point is computed again and the rejection reported (:class:`JournalRecords`).

The checksum detects corruption and hand edits; it is not a signature (whoever can write the folder
can also recompute it).

The file is opened without following a link and only when it is a regular file
(:func:`actuator_design.io.safe_files.open_regular`): a ``journal.jsonl`` planted as a link to a file
elsewhere is never appended to.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Optional

from actuator_design.io.save import dumps_json
from actuator_design.io.safe_files import open_regular, write_all

__all__ = ["Journal", "JournalRecords", "JOURNAL_NAME", "MAX_LINE_BYTES", "canonical_text",
           "point_digest", "record_checksum"]

JOURNAL_NAME = "journal.jsonl"
_KIND = "actuator-design study"
_FORMAT = 2

#: A journal line longer than this is not a record (rejected without being parsed).
MAX_LINE_BYTES = 1 << 20

#: The tail of a journal is searched for its last newline in blocks of this size.
_BLOCK = 1 << 16


@dataclass
class JournalRecords:
    """The records of a journal that match the grid, and why the others were rejected.

    Attributes
    ----------
    records : dict of int → dict
        Accepted point records by index (a later record of the same point wins).
    rejected : list of str
        One reason per rejected line, ``line N: …``.
    unverified : int
        Rejected lines that were records without a checksum (an older version's journal).
    """

    records: Dict[int, dict] = field(default_factory=dict)
    rejected: List[str] = field(default_factory=list)
    unverified: int = 0


def canonical_text(obj: Any) -> str:
    """The canonical JSON of ``obj``: sorted keys, no spaces, UTF-8 text, no NaN."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def point_digest(inputs_digest: str, values: Any) -> str:
    """Digest of one point's resolved inputs: the study's ``inputs_digest`` and its swept
    ``values`` (as a journal line gives them back)."""
    return _sha256(f"{inputs_digest}\n{canonical_text(values)}")


def record_checksum(record: dict) -> str:
    """SHA-256 of the canonical JSON of ``record`` without its ``checksum`` key."""
    return _sha256(canonical_text({k: v for k, v in record.items() if k != "checksum"}))


def _canonical(values: Any) -> Any:
    """Values as a journal line gives them back (JSON round trip)."""
    return json.loads(dumps_json(values))


def _header_of(line: bytes) -> Optional[dict]:
    """The header in a complete first line, or None."""
    if not line.endswith(b"\n") or len(line) > MAX_LINE_BYTES:
        return None
    try:
        head = json.loads(line)
    except (ValueError, RecursionError):
        return None
    return head if isinstance(head, dict) and head.get("journal") == _KIND else None


def _lines(fh):
    """``(number, line or None)`` of a binary file: complete lines only (a partial last line ends
    the iteration); a line longer than :data:`MAX_LINE_BYTES` is skipped and given as None."""
    number = 0
    while True:
        line = fh.readline(MAX_LINE_BYTES + 1)
        if not line.endswith(b"\n"):
            if len(line) <= MAX_LINE_BYTES:
                return  # end of file, or a partial last line (a write cut by a crash)
            while line and not line.endswith(b"\n"):  # the rest of an overlong line
                line = fh.readline(MAX_LINE_BYTES + 1)
            if not line:
                return
            line = None
        number += 1
        yield number, line


class Journal:
    """Append-only record of finished points.

    Parameters
    ----------
    path : Path
    study_id : str
        Identity of the study (hash of its configuration); a journal of another study is refused.
    n_points : int
    inputs_digest : str
        Digest of what shapes every point's result besides its swept values (configuration,
        analyses, solver settings, code versions): part of each record's ``inputs``.
    """

    def __init__(self, path, study_id: str, n_points: int, inputs_digest: str = ""):
        self.path = Path(path)
        self.study_id = study_id
        self.n_points = int(n_points)
        self.inputs_digest = inputs_digest
        self._fd: Optional[int] = None

    @staticmethod
    def read_header(path) -> Optional[dict]:
        """The header of an existing journal, or None (no file, or no complete header line).

        Raises
        ------
        OutputFolderError
            ``path`` is a link or not a regular file.
        """
        try:
            fd = open_regular(path, os.O_RDONLY)
        except FileNotFoundError:
            return None
        with os.fdopen(fd, "rb") as fh:
            return _header_of(fh.readline(MAX_LINE_BYTES + 1))

    def stamp(self, record: dict) -> dict:
        """The record as the journal writes it: JSON types only, with its ``inputs`` digest and
        its ``checksum``."""
        rec = _canonical({k: v for k, v in record.items() if k not in ("inputs", "checksum")})
        rec["inputs"] = point_digest(self.inputs_digest, rec.get("values"))
        rec["checksum"] = record_checksum(rec)
        return rec

    def records(self, expected_values: Callable[[int], Any]) -> JournalRecords:
        """Complete point records that match the grid and prove their content.

        Parameters
        ----------
        expected_values : callable
            ``expected_values(index)``: the swept values of grid point ``index``
            (:func:`actuator_design.study.grid.point_values`).

        Returns
        -------
        JournalRecords
        """
        out = JournalRecords()
        try:
            fd = open_regular(self.path, os.O_RDONLY)
        except FileNotFoundError:
            return out
        with os.fdopen(fd, "rb") as fh:
            for number, line in _lines(fh):
                if number == 1 and line is not None and _header_of(line) is not None:
                    continue
                reason = (f"longer than {MAX_LINE_BYTES} bytes" if line is None
                          else self._check(line, expected_values))
                if isinstance(reason, str):
                    out.rejected.append(f"line {number}: {reason}")
                    out.unverified += reason.endswith(_UNVERIFIED)
                else:
                    out.records[reason["index"]] = reason
        return out

    def _check(self, line: bytes, expected_values) -> Any:
        """The record of a line, or why it is rejected (a string)."""
        try:
            rec = json.loads(line)
        except RecursionError:
            return "nested too deeply to be a record"
        except ValueError:
            return "not a JSON record"
        index = rec.get("index") if isinstance(rec, dict) else None
        if not isinstance(index, int) or isinstance(index, bool) \
                or not 0 <= index < self.n_points:
            return f"index {_short(index)} is not a point of this study (0 to {self.n_points - 1})"
        if "values" not in rec:
            return f"point {index} has no swept values to check"
        expected = _canonical(expected_values(index))
        try:
            if rec["values"] != expected:
                return (f"point {index} has the values {_short(rec['values'])}, not the grid's "
                        f"{dumps_json(expected)}")
            if "checksum" not in rec:
                return f"point {index} {_UNVERIFIED}"
            if rec["checksum"] != record_checksum(rec):
                return f"point {index}: its checksum does not match its content (edited or damaged)"
        except RecursionError:
            return f"point {index} is nested too deeply to be a record"
        except ValueError:  # NaN or infinity: never written by the journal
            return f"point {index} holds a number JSON does not allow (NaN or infinity)"
        if rec.get("inputs") != point_digest(self.inputs_digest, expected):
            return (f"point {index} was computed from other inputs (configuration, solver "
                    "settings or code version)")
        return rec

    def open(self) -> "Journal":
        """Open for appending: write the header of a new journal, or cut off a partial last line.

        Raises
        ------
        OutputFolderError
            The journal is a link or not a regular file.
        OSError
            It cannot be created or written (``EROFS``, ``ENOSPC``, …).
        """
        header = dumps_json({"journal": _KIND, "study_id": self.study_id,
                             "n_points": self.n_points, "format": _FORMAT}) + "\n"
        try:
            fd = open_regular(self.path, os.O_RDWR | os.O_CREAT | os.O_APPEND)
        except OSError as err:
            raise _naming(err, self.path)
        try:
            size = os.fstat(fd).st_size
            keep = _end_of_last_line(fd, size)
            if keep < size:
                os.ftruncate(fd, keep)
            if keep == 0:
                write_all(fd, header.encode("utf-8"))
            os.fsync(fd)
        except BaseException as err:
            os.close(fd)
            raise _naming(err, self.path)
        self._fd = fd
        return self

    def append(self, records: Iterable[dict]) -> List[dict]:
        """Write a block of records (:meth:`stamp`-ed), one line each, in one write; fsync once per
        block (a crash mid-block leaves whole lines and at most one partial last line).

        Returns
        -------
        list of dict
            The records as written.
        """
        stamped = [self.stamp(rec) for rec in records]
        block = "".join(dumps_json(rec) + "\n" for rec in stamped)
        if block:
            try:
                write_all(self._fd, block.encode("utf-8"))
                os.fsync(self._fd)
            except OSError as err:
                raise _naming(err, self.path)
        return stamped

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self):
        return self.open()

    def __exit__(self, *exc):
        self.close()


_UNVERIFIED = "has no checksum (a journal of an older version): untrusted"


def _naming(err: BaseException, path: Path) -> BaseException:
    """``err``, naming ``path`` when it is an OSError that names no file (``os.write`` errors)."""
    if isinstance(err, OSError) and err.filename is None:
        err.filename = str(path)
    return err


def _short(value: Any, limit: int = 80) -> str:
    """A value for a message, cut to ``limit`` characters."""
    try:
        text = dumps_json(value)
    except (RecursionError, ValueError):
        text = repr(type(value).__name__)
    return text if len(text) <= limit else text[:limit] + "…"


def _end_of_last_line(fd: int, size: int) -> int:
    """The offset just after the last newline of the file (0 when it has none)."""
    pos = size
    while pos > 0:
        start = max(0, pos - _BLOCK)
        k = os.pread(fd, pos - start, start).rfind(b"\n")
        if k >= 0:
            return start + k + 1
        pos = start
    return 0
