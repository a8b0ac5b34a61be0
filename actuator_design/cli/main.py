"""Entry point of the ``actuator-design`` command line (meshio / PyFR style).

Every subcommand lives in its own module ``actuator_design.cli.<name>`` that defines

``HELP``
    a one-line summary shown in ``actuator-design --help``;
``add_args(parser)``
    which adds its arguments to an :class:`argparse.ArgumentParser`;
``run(args) -> int``
    which calls the library API and returns the exit code.

Adding a subcommand means writing such a module and adding its name to :data:`COMMANDS`
(an underscore in the module name becomes a hyphen in the command name, and a trailing underscore
is dropped, so ``continue_`` is the command ``continue``).

Exit codes: 0 success, 1 unexpected internal error, 2 bad input (one line on stderr, nothing
written), 3 no result that meets its promise (not converged, inaccurate, a fit that does not explain
its data, a partial study that ``--resume`` continues; the result is still printed / written,
``success`` false), 4 ``design``: unreachable target, 130 interrupted.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import re
import sys
import traceback
import warnings
from typing import List, Optional, Sequence

from actuator_design.cli.common import (EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_NOT_CONVERGED, InputError,
                                        NumericalFailure, PROG, UsageError, check_scene_flags, error_line,
                                        package_version)

__all__ = ["main", "build_parser", "COMMANDS"]

#: Subcommand modules of ``actuator_design.cli``, in the order ``--help`` lists them.
COMMANDS: List[str] = [
    "solve", "validate", "design", "schedule", "equilibria", "continue_", "critical", "map", "path", "stiffness", "phase", "fit", "study", "bench",
]


#: What argparse must read as a value starting with a negative number, not as an option: ``-1``,
#: ``-1.5``, ``-.5``, ``-1e3``, ``-2.5E-4`` (argparse's own pattern misses exponents, so ``--p -1e3``
#: failed), and lists that start with one: ``-0.3,0.4``, ``-0.3,0.4;0.6,-0.2``, ``-5,5`` (so that
#: ``--target-tip -0.3,0.4`` works as the ``=`` form does).
_NUMBER = r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?"
NEGATIVE_NUMBER = re.compile(rf"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?([,;]\s*{_NUMBER})*$")


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors become :class:`UsageError` (one line, exit 2) and that
    reads every negative number, exponents included, as a value (sub-parsers inherit the class)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message):  # noqa: D102 - argparse hook
        raise UsageError(f"{message} (see '{self.prog} --help')")


def build_parser(only: Optional[str] = None) -> argparse.ArgumentParser:
    """The top-level parser with one sub-parser per module in :data:`COMMANDS`.

    With ``only`` (a command name), only that command's module is imported and given its full
    arguments: the others are listed by name, which keeps a command's start-up free of the imports
    of every other command. With ``only=""`` (no command given: ``--help``, ``--version``) no
    command module is imported; each is listed with its ``HELP`` read from its source.
    """
    parser = _Parser(
        prog=PROG,
        description="Equilibria of magneto-elastic soft actuators: elastic rods with magnetic "
                    "particles bent by an applied field. Without a CONFIG values are dimensionless "
                    "(THEORY §5): lengths in rod lengths l, energies in B0/l, forces in B0/l^2; a "
                    "physical scene (CONFIG with type: physical) is read in its own units (mm, mT, "
                    "N/m, ...) and each output states the units it is in. Angles are in the unit "
                    "each flag names.",
        epilog=("Exit codes: 0 success, 1 internal error, 2 bad input, 3 no result meeting its promise "
                "(not converged, inaccurate, poor fit, partial study: --resume), 4 design: unreachable "
                "target, 130 interrupted."),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    sub.required = True
    for name in COMMANDS:
        command = name.rstrip("_").replace("_", "-")
        if only == "":
            sub.add_parser(command, help=_help_of(name))
            continue
        if only is not None and command != only:
            sub.add_parser(command)
            continue
        module = importlib.import_module(f"{__package__}.{name}")
        p = sub.add_parser(command, help=module.HELP, description=module.__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_args(p)
        _add_figure_format(p)
        p.set_defaults(_run=module.run)
    return parser


def _add_figure_format(parser: argparse.ArgumentParser) -> None:
    """``--format svg|pdf`` for every command that writes an ``--out`` set with figures."""
    actions = parser._option_string_actions
    if "--out" not in actions or "--format" in actions:
        return
    from actuator_design.viz.style import VECTOR_FORMATS
    parser.add_argument("--format", choices=VECTOR_FORMATS, default=None, metavar="{svg,pdf}",
                        help="with --out: also write every figure in this vector format, beside its "
                             "PNG (150 dpi)")


def _help_of(name: str) -> str:
    """The literal ``HELP`` string of the command module ``name``, read from its source without
    importing it (importing every command costs ~1 s of CasADi and SciPy start-up)."""
    import ast
    import importlib.util

    spec = importlib.util.find_spec(f"{__package__}.{name}")
    with open(spec.origin, encoding="utf-8") as fh:
        tree = ast.parse(fh.read())
    for node in tree.body:
        if (isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "HELP" for t in node.targets)
                and isinstance(node.value, ast.Constant)):
            return node.value.value
    return importlib.import_module(f"{__package__}.{name}").HELP  # not a literal: import it


def _command_of(argv: Sequence[str]) -> Optional[str]:
    """The subcommand named in ``argv`` (its first non-option word) if it is a known one, "" when
    there is none, None for an unknown word (every command is then imported for the message)."""
    names = {n.rstrip("_").replace("_", "-") for n in COMMANDS}
    first = next((a for a in argv if not a.startswith("-")), None)
    if first is None:
        return ""  # no command (--help, --version): import none
    return first if first in names else None


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``) and return the exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name.

    Returns
    -------
    int
        0 success, 1 internal error, 2 bad input, 3 no result meeting its promise, 4 unreachable
        design target, 130 interrupted.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    with warnings.catch_warnings():
        warnings.showwarning = _one_line_warning(set())
        return _main(argv)


def run() -> None:
    """The ``actuator-design`` console script: :func:`main`, then the process ends with its exit
    code without tearing the interpreter down. The clean-up frees every CasADi expression graph
    and solver one by one (0.3–0.4 s after a design, measured, issue 17); the operating system
    frees the memory at once. Output streams are flushed and ``atexit`` handlers run first."""
    import atexit

    code = main()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    atexit._run_exitfuncs()
    os._exit(code)


def _one_line_warning(seen: set):
    """A :func:`warnings.showwarning` that prints each distinct warning once, as one line
    ``actuator-design: warning: <message>`` on stderr (no file path, no source line)."""

    def show(message, category, filename, lineno, file=None, line=None):  # noqa: ARG001 - hook
        text = " ".join(str(message).split())
        if text in seen:
            return
        seen.add(text)
        print(f"{PROG}: warning: {text}", file=sys.stderr if file is None else file)

    return show


def _main(argv: List[str]) -> int:
    """:func:`main` once warnings are routed to one-line messages."""
    try:
        parser = build_parser(only=_command_of(argv))
        args = parser.parse_args(argv)
        check_scene_flags(args)
        from actuator_design.parallel import single_threaded_blas
        from actuator_design.viz.style import vector_format
        single_threaded_blas()  # small matrices: BLAS threads only contend with worker processes
        with vector_format(getattr(args, "format", None)):
            return int(args._run(args))
    except (UsageError, InputError) as exc:
        print(error_line(exc), file=sys.stderr)
        return EXIT_BAD_INPUT
    except NumericalFailure as exc:
        print(error_line(exc), file=sys.stderr)
        return EXIT_NOT_CONVERGED
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else EXIT_BAD_INPUT)
    except BrokenPipeError:  # e.g. `actuator-design solve --json | head`
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_INTERNAL
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the last line of defence
        traceback.print_exc(file=sys.stderr)
        print(f"{PROG}: internal error: {type(exc).__name__}: {' '.join(str(exc).split())}",
              file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
