"""Stopping a fit on SIGINT/SIGTERM between forward solves.

IPOPT runs inside every forward solve and swallows a KeyboardInterrupt raised while it runs (it
returns a failed solve, which the fit would then try to recover from), so a fit ignored Ctrl-C.
Instead, while a fit runs in the main thread, SIGINT and SIGTERM only set a flag
(:class:`actuator_design.study.backends.StopRequest`, the study runner's pattern); the fit checks it
after each forward solve and raises :class:`FitInterrupted`. A second signal raises
KeyboardInterrupt at once. The previous handlers are restored when the fit ends.
"""
from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

from actuator_design.study.backends import StopRequest

__all__ = ["FitInterrupted", "stop_on_signals"]


class FitInterrupted(KeyboardInterrupt):
    """A fit stopped by SIGINT/SIGTERM; its message says how far it got (nothing is returned)."""


@contextlib.contextmanager
def stop_on_signals(enabled: bool = True) -> Iterator[StopRequest]:
    """Within the block SIGINT and SIGTERM set ``stop.requested`` (main thread only: elsewhere,
    or when not ``enabled``, the handlers are left alone and the flag is never set)."""
    stop = StopRequest()
    old = {}
    if enabled and threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, stop)
    try:
        yield stop
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
