"""The journal of a study: one JSON line per finished point, appended in blocks as chunks finish.

The first line is a header ``{"journal": "actuator-design study", "study_id": …, "n_points": …}``;
every other line is a point record (:mod:`actuator_design.study.worker`). A line is either
complete (ends with a newline and parses) or ignored: an interrupted write leaves at most one
partial last line, which :meth:`Journal.open` drops (rewriting the file through a temporary name)
before appending. A resumed study reads the records and skips their points.

A record is accepted only when it matches the grid: its index names a point of the study and its
``values`` are that point's swept values. A record edited by hand (another index), written by
another version without values, or not a record at all is rejected: its point is computed again
and the rejection is reported (:class:`JournalRecords`).
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Optional

from ..io import atomic_write, dumps_json

__all__ = ["Journal", "JournalRecords", "JOURNAL_NAME"]

JOURNAL_NAME = "journal.jsonl"
_KIND = "actuator-design study"


@dataclass
class JournalRecords:
    """The records of a journal that match the grid, and why the others were rejected.

    Attributes
    ----------
    records : dict of int → dict
        Accepted point records by index (a later record of the same point wins).
    rejected : list of str
        One reason per rejected line, ``line N: …``.
    """

    records: Dict[int, dict] = field(default_factory=dict)
    rejected: List[str] = field(default_factory=list)


def _canonical(values: Any) -> Any:
    """Values as a journal line gives them back (JSON round trip)."""
    return json.loads(dumps_json(values))


class Journal:
    """Append-only record of finished points.

    Parameters
    ----------
    path : Path
    study_id : str
        Identity of the study (hash of its configuration); a journal of another study is refused.
    n_points : int
    """

    def __init__(self, path, study_id: str, n_points: int):
        self.path = Path(path)
        self.study_id = study_id
        self.n_points = int(n_points)
        self._fh = None

    @staticmethod
    def read_header(path) -> Optional[dict]:
        """The header of an existing journal, or None (no file, or no complete header line)."""
        try:
            with open(path, "r", encoding="utf-8") as fh:
                line = fh.readline()
        except FileNotFoundError:
            return None
        if not line.endswith("\n"):
            return None
        try:
            head = json.loads(line)
        except json.JSONDecodeError:
            return None
        return head if isinstance(head, dict) and head.get("journal") == _KIND else None

    def records(self, expected_values: Callable[[int], Any]) -> JournalRecords:
        """Complete point records that match the grid.

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
        if not self.path.exists():
            return out
        with open(self.path, "r", encoding="utf-8") as fh:
            for number, line in enumerate(fh, start=1):
                if not line.endswith("\n"):
                    break  # a partial last line (a write cut by a crash): ignored
                if number == 1 and self.read_header(self.path) is not None:
                    continue
                reason = self._check(line, expected_values)
                if isinstance(reason, str):
                    out.rejected.append(f"line {number}: {reason}")
                else:
                    out.records[reason["index"]] = reason
        return out

    def _check(self, line: str, expected_values) -> Any:
        """The record of a line, or why it is rejected (a string)."""
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            return "not a JSON record"
        index = rec.get("index") if isinstance(rec, dict) else None
        if not isinstance(index, int) or isinstance(index, bool) \
                or not 0 <= index < self.n_points:
            return f"index {index!r} is not a point of this study (0 to {self.n_points - 1})"
        if "values" not in rec:
            return f"point {index} has no swept values to check"
        if rec["values"] != _canonical(expected_values(index)):
            return (f"point {index} has the values {dumps_json(rec['values'])}, not the grid's "
                    f"{dumps_json(expected_values(index))}")
        return rec

    def open(self) -> "Journal":
        """Open for appending: write the header of a new journal, or drop a partial last line."""
        header = dumps_json({"journal": _KIND, "study_id": self.study_id,
                             "n_points": self.n_points}) + "\n"
        if not self.path.exists() or self.path.stat().st_size == 0:
            atomic_write(self.path, lambda fh: fh.write(header))
        else:
            data = self.path.read_bytes()
            if not data.endswith(b"\n"):
                keep = data[: data.rfind(b"\n") + 1]
                if not keep:
                    keep = header.encode()
                atomic_write(self.path, lambda fh: fh.write(keep), binary=True)
        self._fh = open(self.path, "a", encoding="utf-8")
        return self

    def append(self, records: Iterable[dict]) -> None:
        """Write a block of records, one line each, in one write; flush and fsync once per block
        (a crash mid-block leaves whole lines and at most one partial last line)."""
        block = "".join(dumps_json(rec) + "\n" for rec in records)
        if block:
            self._fh.write(block)
            self._fh.flush()
            os.fsync(self._fh.fileno())

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __enter__(self):
        return self.open()

    def __exit__(self, *exc):
        self.close()
