"""Plan a study: read and check everything before any computing.

:func:`plan_study` validates the configuration and its ``study:`` section, counts the grid's
points *from the specification* and refuses more than the limit before building anything
(:func:`actuator_design.study.grid.check_grid_size`), resolves the swept keys, checks every swept
value and every grid point that can be checked without solving
(:func:`actuator_design.study.check.check_points`: an out-of-range value is exit 2 before the
folder exists), and checks the output folder: its entries are the tool's own (no links, each of its kind:
:data:`STUDY_ENTRIES`), it is not held by a live run (:mod:`~actuator_design.study.lock`), and it
holds either nothing or this same study when resuming. :func:`journal_records` reads what a resume can reuse,
under the run's lock.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Dict, List, Optional

from actuator_design.analysis import registry
from actuator_design.config import ConfigError, load_config
from actuator_design.config.studies.sweep import SweepSpec
from actuator_design.config.studies.validation import validate_spec
from actuator_design.io.safe_files import DIRECTORY, FILE, check_entries
from actuator_design.io.save import dumps_json
from actuator_design.study.check import check_points
from actuator_design.study.errors import StudyError
from actuator_design.study.grid import (DEFAULT_MAX_POINTS, check_grid_size, grid_indices, point_values,
                                        resolve_axes)
from actuator_design.study.journal import JOURNAL_NAME, Journal, JournalRecords
from actuator_design.study.lock import LOCK_NAME, holder_of, in_use_message

__all__ = ["StudyPlan", "plan_study", "journal_records", "check_study_folder", "STUDY_ENTRIES",
           "CSV_NAME", "PARQUET_NAME", "NETCDF_NAME", "FIGURES_DIR", "MANIFEST_NAME",
           "analysis_list"]

MANIFEST_NAME = "manifest.json"
CSV_NAME = "results.csv"
PARQUET_NAME = "results.parquet"
NETCDF_NAME = "results.nc"
FIGURES_DIR = "figures"

#: The entries a run writes in its study folder and what each must be when it exists.
STUDY_ENTRIES = {LOCK_NAME: FILE, JOURNAL_NAME: FILE, MANIFEST_NAME: FILE, CSV_NAME: FILE,
                 PARQUET_NAME: FILE, NETCDF_NAME: FILE, FIGURES_DIR: DIRECTORY}

#: Versions of the code that shapes a point's result (part of every record's ``inputs`` digest).
_CODE = ("actuator-design", "casadi", "numpy", "scipy")

#: ``study`` keys that do not change a study's results (left out of its identity): the chunk size
#: changes which points a walked path lands on, not the states (they agree to the solver's
#: tolerance, each point on the mesh a lone solve chooses).
_RUN_SETTINGS = ("chunk_size", "max_points")


@dataclass
class StudyPlan:
    """Everything a run needs, checked: built by :func:`plan_study`."""

    raw: dict
    config: Any
    spec: SweepSpec
    axes: list
    indices: list
    analyses: List[dict]
    out: Path
    study_id: str
    resume: bool
    name: str
    inputs_digest: str = ""
    #: the configuration file (absolute path), None for a configuration given as a dict
    source: Optional[str] = None

    @property
    def n_points(self) -> int:
        return len(self.indices)


def plan_study(source, out_dir, resume: bool = False,
               max_points: Optional[int] = None) -> StudyPlan:
    """Load and check a study configuration and its output folder.

    Parameters
    ----------
    source : str, Path or dict
        The configuration (a ``study:`` section of ``type: sweep``).
    out_dir : str or Path
        The study folder.
    resume : bool
        Continue the study in ``out_dir``: its journal's points are not recomputed.
    max_points : int, optional
        Largest number of points allowed; default ``study.max_points``, else
        :data:`~actuator_design.study.grid.DEFAULT_MAX_POINTS`.

    Raises
    ------
    ConfigError
        Invalid configuration or sweep (``study.<…>``), a grid of more than ``max_points``, or a
        grid point whose configuration is invalid (:func:`~actuator_design.study.check.check_points`:
        ``study.sweep.<key>: grid point … is invalid, refused before any work: <field>: <range>``).
    StudyError
        The folder is in use by a live run, holds another study, or holds this one and ``resume``
        is not set.
    OutputFolderError
        An entry of the folder is a symbolic link or of the wrong kind (:data:`STUDY_ENTRIES`).
    """
    config = load_config(source)
    study = config.study
    if study is None:
        raise ConfigError("study", "required: a study needs 'study: {type: sweep, sweep: {...}, "
                                   "analyses: [...]}'")
    if isinstance(study, dict) and study.get("type") == "fit":
        raise ConfigError("study.type", "'fit' studies are run by 'actuator-design fit CONFIG "
                                        "--data DATA.csv'")
    spec = validate_spec(SweepSpec, study)
    check_grid_size(spec, max_points or spec.max_points or DEFAULT_MAX_POINTS)
    axes = resolve_axes(spec)
    analyses = analysis_list(spec)
    indices = grid_indices(axes, spec.grid)
    raw = config.raw
    check_points(raw, axes, indices, spec.grid)
    # identity of the study: the configuration without settings that do not change results
    ident = {**raw, "study": {k: v for k, v in (raw.get("study") or {}).items()
                              if k not in _RUN_SETTINGS}}
    study_id = hashlib.sha256(dumps_json(ident).encode()).hexdigest()[:16]
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise StudyError(f"--out: {out} exists and is not a directory")
    check_study_folder(out)
    holder = holder_of(out) if out.is_dir() else None
    if holder is not None:
        raise StudyError(in_use_message(out, holder))
    _check_journal_header(out, study_id, len(indices), resume)
    name = config.name or (Path(source).stem if isinstance(source, (str, Path)) else "study")
    return StudyPlan(raw=raw, config=config, spec=spec, axes=axes, indices=indices,
                     analyses=analyses, out=out, study_id=study_id, resume=resume, name=name,
                     inputs_digest=_inputs_digest(ident, analyses, spec, config),
                     source=(str(Path(source).resolve()) if isinstance(source, (str, Path))
                             else None))


def check_study_folder(out: Path) -> None:
    """Refuse a study folder whose entries are links or of the wrong kind (:data:`STUDY_ENTRIES`).

    Raises
    ------
    OutputFolderError
        One line naming the entry (exit 2 at the command line).
    """
    check_entries(out, STUDY_ENTRIES)


def _inputs_digest(ident: dict, analyses, spec: SweepSpec, config) -> str:
    """Digest of what shapes every point's result besides its swept values: the configuration
    (without run settings), the analyses, the kept outputs, the resolved solver settings and the
    versions of the code (:data:`_CODE`)."""
    code = {}
    for name in _CODE:
        try:
            code[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            code[name] = None
    shaped = {"config": ident, "analyses": analyses, "outputs": spec.outputs,
              "solver": config.solver_options().as_dict(), "code": code}
    return hashlib.sha256(dumps_json(shaped).encode()).hexdigest()


def _check_journal_header(out: Path, study_id: str, n_points: int, resume: bool) -> bool:
    """True when ``out`` holds a journal of this study and ``resume`` is set; False when it holds
    none.

    Raises
    ------
    StudyError
        It holds a journal and ``resume`` is not set, or a journal of another study.
    """
    head = Journal.read_header(out / JOURNAL_NAME)
    if head is None:
        return False
    if not resume:
        raise StudyError(f"--out: {out} already holds a study ({JOURNAL_NAME}); pass --resume to "
                         "continue it, or choose another folder")
    if head.get("study_id") != study_id or head.get("n_points") != n_points:
        raise StudyError(f"--resume: {out} holds a different study (its configuration or "
                         "points differ from this one); choose another folder")
    return True


def journal_records(plan: StudyPlan) -> JournalRecords:
    """The journal's records that a run of ``plan`` reuses (read under the run's lock).

    Records whose index or swept values do not match the grid, or that do not prove their content
    and inputs, are rejected (their points are computed again); see :meth:`actuator_design.study.journal.Journal.records`.

    Raises
    ------
    StudyError
        As :func:`plan_study`, when the folder changed since the plan.
    """
    if not _check_journal_header(plan.out, plan.study_id, plan.n_points, plan.resume):
        return JournalRecords()
    journal = Journal(plan.out / JOURNAL_NAME, plan.study_id, plan.n_points, plan.inputs_digest)
    return journal.records(lambda i: point_values(plan.axes, plan.indices[i]))


def analysis_list(spec: SweepSpec) -> List[Dict[str, Any]]:
    """The analyses as ``[{"type": name, **settings}]``, names checked against the registry.

    Raises
    ------
    ConfigError
        ``study.analyses[i]``: unknown analysis or malformed entry.
    """
    known = registry.names()
    out = []
    for i, item in enumerate(spec.analyses):
        where = f"study.analyses[{i}]"
        if isinstance(item, str):
            entry = {"type": item}
        elif isinstance(item.get("type"), str):
            entry = dict(item)
        else:
            raise ConfigError(where, "expected an analysis name or a mapping {type: <name>, "
                                     f"<settings>}}, got {item!r}")
        if entry["type"] not in known:
            raise ConfigError(f"{where}", f"unknown analysis '{entry['type']}' (allowed: "
                                          f"{', '.join(known)})")
        if any(e["type"] == entry["type"] for e in out):
            raise ConfigError(where, f"analysis '{entry['type']}' is listed twice")
        out.append(entry)
    return out
