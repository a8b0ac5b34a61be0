"""A command's ``--out`` set: written all or nothing before anything is printed on stdout.

The commands compose result → figures (:mod:`actuator_design.viz`) → files in memory, and hand the
set to :func:`write_out`, which writes it through :func:`actuator_design.io.save.write_output_set`. The
command prints its result (JSON or summary) only after that returned, and then
:func:`print_written`; so a failed write leaves no file of the set and no JSON on stdout (exit 2).
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Mapping, Sequence

from actuator_design.cli.common import InputError, bad_input, stdout_to_stderr

__all__ = ["write_out", "print_written", "emit", "with_vector_figures"]


def write_out(out_dir: str, files: Mapping[str, object], json_mode: bool,
              what: str = "") -> List[Path]:
    """Write ``{name: text, bytes or figure}`` into ``out_dir`` all or nothing.

    Parameters
    ----------
    out_dir : str
        The ``--out`` directory.
    files : mapping of file name → str, bytes or object with ``savefig``
    json_mode : bool
        ``--json`` was given: anything printed while writing goes to stderr.
    what : str
        Named in the error message (``--out: cannot write <what>to DIR: ...``), e.g. ``"results "``.

    Raises
    ------
    InputError
        A file could not be written (read-only or full file system, a directory where a file of
        the set goes; exit 2); nothing of the set is left. A symbolic link where a file of the set
        goes is replaced by the file (never written through).
    """
    from actuator_design.io.save import write_output_set
    from actuator_design.io.safe_files import os_error_text

    files = with_vector_figures(files)
    prefix = f"--out: cannot write {what}to {out_dir}: "
    try:
        with bad_input(prefix), stdout_to_stderr(json_mode):
            return write_output_set(out_dir, files)
    except InputError as exc:  # an OSError in words (no "[Errno 28]"): "No space left on device"
        cause = exc.__cause__
        if isinstance(cause, OSError) and cause.strerror:
            raise InputError(prefix + os_error_text(cause)) from cause
        raise


def with_vector_figures(files: Mapping[str, object]) -> dict:
    """``files`` with ``name.svg`` (or ``.pdf``) after each ``name.png`` whose bytes carry that
    encoding (:class:`~actuator_design.viz.style.FigureBytes`, made under ``--format``)."""
    out = {}
    for name, content in files.items():
        out[name] = content
        for fmt, data in getattr(content, "vector", {}).items():
            out[str(Path(name).with_suffix("." + fmt))] = data
    return out


def print_written(paths: Sequence[Path], json_mode: bool) -> None:
    """``wrote a, b, c`` on stdout (stderr with ``--json``, which keeps stdout one JSON object)."""
    print("wrote " + ", ".join(str(p) for p in paths), file=sys.stderr if json_mode else sys.stdout)


def emit(args, result, files, summary, payload=None) -> None:
    """The end of a command: ``files()`` written all or nothing (with ``--out``), then the JSON
    (``payload``, default ``result.to_dict()``) or ``summary(result)`` on stdout, then the
    ``wrote ...`` line."""
    from actuator_design.io.save import dumps_json

    written = write_out(args.out, files(), args.json) if args.out is not None else None
    print(dumps_json(result.to_dict() if payload is None else payload) if args.json else summary(result))
    if written is not None:
        print_written(written, args.json)
