"""The exceptions and warnings of a study run (one line each, no traceback at the CLI)."""
from __future__ import annotations

__all__ = ["StudyError", "StudyInterrupted", "StudyWarning"]


class StudyError(ValueError):
    """A study cannot run as asked (folder in use, scheduler unreachable, …): one line."""


class StudyInterrupted(Exception):
    """The study was interrupted; its journal and manifest allow ``resume``."""


class StudyWarning(UserWarning):
    """Something a study did on its own that its user should know (a stale lock taken over,
    journal records rejected and recomputed)."""
