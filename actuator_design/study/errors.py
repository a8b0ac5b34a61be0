"""The exceptions and warnings of a study run (one line each, no traceback at the CLI)."""
from __future__ import annotations

__all__ = ["StudyError", "StudyStorageError", "StudyInterrupted", "StudyWarning"]


class StudyError(ValueError):
    """A study cannot run as asked (folder in use, scheduler unreachable, …): one line."""


class StudyStorageError(StudyError):
    """The file system refused a write (read-only, full, …): one line.

    Attributes
    ----------
    resumable : bool
        The folder holds this study's journal: once the cause is gone, ``--resume`` continues
        without recomputing the journaled points (exit 3 at the command line, else 2).
    """

    def __init__(self, message: str, resumable: bool = False):
        super().__init__(message)
        self.resumable = resumable


class StudyInterrupted(Exception):
    """The study was interrupted; its journal and manifest allow ``resume``."""


class StudyWarning(UserWarning):
    """Something a study did on its own that its user should know (a stale lock taken over,
    journal records rejected and recomputed)."""
