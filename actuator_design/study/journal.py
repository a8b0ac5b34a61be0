"""The journal of a study: one JSON line per finished point, appended and flushed per point.

The first line is a header ``{"journal": "actuator-design study", "study_id": …, "n_points": …}``;
every other line is a point record (:mod:`actuator_design.study.worker`). A line is either
complete (ends with a newline and parses) or ignored: an interrupted write leaves at most one
partial last line, which :meth:`Journal.open` drops (rewriting the file through a temporary name)
before appending. A resumed study reads the records and skips their points.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Dict, Iterable, Optional

from ..io import atomic_write, dumps_json

__all__ = ["Journal", "JOURNAL_NAME"]

JOURNAL_NAME = "journal.jsonl"
_KIND = "actuator-design study"


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

    def records(self) -> Dict[int, dict]:
        """Complete point records by index (a later record of the same point wins)."""
        out: Dict[int, dict] = {}
        if not self.path.exists():
            return out
        with open(self.path, "r", encoding="utf-8") as fh:
            for line in fh:
                if not line.endswith("\n"):
                    break  # a partial last line: ignored
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:
                    continue
                if isinstance(rec, dict) and isinstance(rec.get("index"), int) \
                        and 0 <= rec["index"] < self.n_points:
                    out[rec["index"]] = rec
        return out

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
        """Write records, one line each, flushed per line; fsync once per call."""
        for rec in records:
            self._fh.write(dumps_json(rec) + "\n")
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
