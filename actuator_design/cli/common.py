"""Helpers shared by the subcommands: errors, argument types, loading scenes, field checks, and
the writer of a command's ``--out`` set (all or nothing, before anything is printed)."""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
from pathlib import Path
from typing import List, Mapping, Optional, Sequence

from actuator_design.model.units import MAX_ANGLE_DEG  # the largest |angle| any input takes, also a --*-deg flag

__all__ = [
    "PROG", "EXIT_OK", "EXIT_INTERNAL", "EXIT_BAD_INPUT", "EXIT_NOT_CONVERGED",
    "UsageError", "InputError", "NumericalFailure", "error_line", "package_version", "finite_float",
    "nonnegative_float", "bad_input", "load_config", "check_out_dir",
    "stdout_to_stderr", "SCENE_FLAG_GROUPS", "check_scene_flags", "add_rate_args", "parse_rates",
    "table_csv_text", "check_angle_deg", "check_parameter_angle",
    "MAX_ANGLE_DEG", "EXIT_NOT_VERIFIED", "EXIT_UNREACHABLE", "repeatable",
    "write_out", "print_written", "emit", "with_vector_figures",
]

PROG = "actuator-design"
EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_NOT_CONVERGED = 0, 1, 2, 3
#: the verdicts of design and schedule: found but not verified (or not robust), and out of reach
EXIT_NOT_VERIFIED, EXIT_UNREACHABLE = 3, 4


def repeatable(separator: str) -> type:
    """An argparse action for a flag that takes a list (``--tolerance field=5%,angle=1deg``,
    ``--target-tip '0.3,0.5;0.6,0.2'``) whose repeats add to the list, joined by ``separator``:
    ``--tolerance field=5% --tolerance youngs_modulus=10%`` is ``--tolerance
    field=5%,youngs_modulus=10%``. argparse's own would keep the last one and drop the others
    without a word (a design judged without the field tolerance the user asked for)."""
    class Repeatable(argparse.Action):
        def __call__(self, parser, namespace, values, option_string=None):
            before = getattr(namespace, self.dest, None)
            setattr(namespace, self.dest, values if before is None else f"{before}{separator}{values}")
    return Repeatable


class UsageError(Exception):
    """The command line itself is malformed (argparse error)."""


class InputError(Exception):
    """The user's input (flags, config file, field) is invalid; exit code 2."""


class NumericalFailure(Exception):
    """A computation failed numerically (a singular matrix inside a solver stage): not bad input,
    no result that meets its promise; one line, exit code 3."""


def error_line(exc: BaseException) -> str:
    """``actuator-design: error: <message>`` on one line."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    return f"{PROG}: error: {'; '.join(lines) or type(exc).__name__}"


def package_version() -> str:
    """The installed package version."""
    from actuator_design import __version__
    return __version__


# -- argument types -------------------------------------------------------------------------------
def finite_float(text: str) -> float:
    """argparse type: a finite real number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: expected a finite real number")
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: must be a finite real number")
    return value


def nonnegative_float(text: str) -> float:
    """argparse type: a finite number ≥ 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(f"invalid value {text!r}: must be a finite number >= 0")
    return value


#: Numeric flags (by argparse ``dest``) that set or bound a dimensionless group, and that group
#: (:data:`actuator_design.config.limits.GROUP_RANGES`): checked for every command before it runs.
SCENE_FLAG_GROUPS = {"h": "h", "p": "p", "h_max": "h", "p_max": "p"}


def check_angle_deg(value, name: str) -> None:
    """An angle given in degrees (a ``--*-deg`` flag, a ``*_deg`` study value) within
    ±MAX_ANGLE_DEG, reported in degrees, the unit the user gave.

    Raises
    ------
    InputError
        ``--phi-deg: must be a finite angle in [-1e+06, 1e+06] deg, got 1e+07 deg``.
    """
    from actuator_design.model.units import angle_range_problem

    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    problem = angle_range_problem(float(value), "deg")
    if problem is not None:
        raise InputError(f"{name}: {problem}")


def check_parameter_angle(name: str, value, where: str) -> None:
    """A value of the lens parameter ``name`` given as a plain number (a study section, a
    schedule): when it is an angle, within ±MAX_ANGLE_DEG, reported in the unit of ``name`` —
    degrees for a ``<name>_deg`` alias, rad for the lens' own angles.

    Raises
    ------
    InputError
        ``study.window: must be a finite angle in [-17453.3, 17453.3] rad, got 20000 rad``.
    """
    from actuator_design.physics.parameters import degree_aliases, parameters
    from actuator_design.model.units import angle_range_problem

    if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    if name in degree_aliases():
        check_angle_deg(value, where)
        return
    p = parameters().get(name)
    problem = angle_range_problem(value, "rad") if p is not None and p.unit == "rad" else None
    if problem is not None:
        raise InputError(f"{where}: {problem}")


def check_scene_flags(args: argparse.Namespace) -> None:
    """Every scene flag given on the command line within its group's valid range.

    Raises
    ------
    InputError
        ``--h: invalid value 1e+155: must be a finite number in [0, 10000]`` (exit code 2).
    """
    from actuator_design.config.limits import group_problem

    out = getattr(args, "out", None)
    if isinstance(out, str) and not out.strip():  # '' would write into the current directory
        raise InputError("--out: an empty folder name; give the folder to write into, e.g. --out results")
    for dest, value in sorted(vars(args).items()):
        if dest.endswith("_deg") and not dest.endswith("_max_deg"):  # (a bound has its own range: alpha_max)
            check_angle_deg(value, "--" + dest.replace("_", "-"))
    for dest, group in SCENE_FLAG_GROUPS.items():
        value = getattr(args, dest, None)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            problem = group_problem(group, float(value))
            if problem is not None:
                flag = "--" + dest.replace("_", "-")
                raise InputError(f"{flag}: invalid value {value:g}: {problem.split(', got')[0]}")


# -- schedules in the user's units ----------------------------------------------------------------
def add_rate_args(parser: argparse.ArgumentParser) -> None:
    """--rate and --rotation-rate: the time column of a schedule."""
    g = parser.add_argument_group("schedule timing (adds a time column to the schedule)")
    g.add_argument("--rate", metavar="RATE",
                   help="largest rate of change of the field, e.g. '5 mT/s' or '4 kA/m/s' (physical scenes)")
    g.add_argument("--rotation-rate", metavar="RATE",
                   help="largest rotation rate of the field, e.g. '30 deg/s'; with --rate the slower "
                        "of the two changes governs each step")


def parse_rates(field_rate, rotation_rate):
    """``(field rate in A/m/s or None, rotation rate in rad/s or None)`` from flag or YAML values.

    Raises
    ------
    InputError
        One line naming the flag: not a rate of the right dimension, or not > 0.
    """
    from actuator_design.model.units import parse_quantity

    out = []
    for flag, value, dim in (("--rate", field_rate, "field_rate"),
                             ("--rotation-rate", rotation_rate, "angular_rate")):
        if value is None:
            out.append(None)
            continue
        with bad_input():
            v = parse_quantity(value, dim, flag)
        if not v > 0:
            raise InputError(f"{flag}: must be > 0, got {value!r}")
        out.append(v)
    return tuple(out)


def table_csv_text(rows, columns=None) -> str:
    """CSV text of a list of dicts (floats written exactly with repr, missing values empty)."""
    import csv
    import io

    columns = list(columns or (rows[0] if rows else []))
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(columns)
    for r in rows:
        w.writerow([repr(float(r[c])) if isinstance(r.get(c), float) else r.get(c, "") for c in columns])
    return buf.getvalue()


# -- turning library errors into bad-input errors -------------------------------------------------
@contextlib.contextmanager
def bad_input(prefix: str = ""):
    """Re-raise ``ValueError`` (``ConfigError``, ``FieldCheckError``, …) and ``OSError`` raised
    inside the block as :class:`InputError` (exit code 2), with an optional message prefix."""
    try:
        yield
    except InputError:
        raise
    except (ValueError, OSError) as exc:
        numpy = sys.modules.get("numpy")  # not imported here: start-up stays free of it
        if numpy is not None and isinstance(exc, numpy.linalg.LinAlgError):
            # a ValueError subclass, but the computation failed, not the input
            raise NumericalFailure(f"numerical failure ({type(exc).__name__}: {exc}); the input was "
                                   "accepted: try another mesh (--elements, --degree) or report it") from exc
        raise InputError(f"{prefix}{exc}") from exc
    except Exception as exc:
        try:
            import yaml
        except ImportError:  # pragma: no cover - pyyaml is a dependency
            raise exc
        if isinstance(exc, yaml.YAMLError):
            raise InputError(f"{prefix}invalid YAML: {exc}") from exc
        raise


def load_config(path: str):
    """Load and validate a YAML config: ``(Scene, SolverOptions, raw dict)``.

    Raises
    ------
    InputError
        The file does not exist, is not valid YAML, or fails validation (``ConfigError``).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"config file not found: {path}")
    with bad_input():
        from actuator_design.config import load_scene
        return load_scene(p)


def check_out_dir(out: Optional[str]) -> None:
    """Fail early (before solving) when ``--out`` names something that is not a directory."""
    if out is not None and os.path.exists(out) and not os.path.isdir(out):
        raise InputError(f"--out: {out} exists and is not a directory")


@contextlib.contextmanager
def stdout_to_stderr(enabled: bool = True):
    """Send everything written to file descriptor 1 (including C libraries) to stderr.

    Keeps stdout clean for ``--json``. A no-op when the descriptors cannot be duplicated.
    """
    if not enabled:
        yield
        return
    try:
        sys.stdout.flush()
        saved = os.dup(1)
        os.dup2(2, 1)
    except (OSError, ValueError, AttributeError):
        yield
        return
    old_stdout = sys.stdout
    sys.stdout = sys.stderr
    try:
        yield
    finally:
        sys.stdout = old_stdout
        with contextlib.suppress(OSError):
            os.dup2(saved, 1)
        os.close(saved)


# -- a command's --out set --------------------------------------------------------------------------
#
# The commands compose result → figures (:mod:`actuator_design.viz`) → files in memory, and hand the
# set to :func:`write_out`, which writes it through :func:`actuator_design.io.save.write_output_set`. The
# command prints its result (JSON or summary) only after that returned, and then
# :func:`print_written`; so a failed write leaves no file of the set and no JSON on stdout (exit 2).


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
