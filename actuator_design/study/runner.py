"""Run a sweep study: compute the planned points in parallel, journal them, write the folder.

:func:`~actuator_design.study.plan.plan_study` reads and checks everything (configuration, sweep,
point count, analyses, output folder) before any computing; :func:`run_study` takes the folder's
lock (:mod:`~actuator_design.study.lock`: a second writer is refused, naming the holder), reuses
the journal's records that match the grid, computes the other points — in this process (one
worker), in local processes (``concurrent.futures``, one built solver per process, workers that
die with this process) or on a Dask cluster (``scheduler=``; Dask is imported only then), see
:mod:`~actuator_design.study.backends` — and writes into the study folder:

``manifest.json``
    the full resolved configuration, package and dependency versions, solver settings, start and
    end times, execution (backend, workers, chunks, process), the status of every point, the
    history of runs (a resumed study appends one) with the throughput in points per second, and
    warnings (journal records rejected); :func:`read_manifest` reports a dead run's ``running``
    as ``interrupted`` (:mod:`~actuator_design.study.manifest`);
``journal.jsonl``
    one JSON line per finished point, written in blocks as chunks finish
    (:mod:`actuator_design.study.journal`);
``results.csv`` (and ``results.parquet`` when pyarrow is installed)
    the tidy table (:mod:`actuator_design.study.outputs`);
``results.nc``
    the same results on the grid, a labelled N-dimensional array (netCDF3 via xarray,
    :mod:`actuator_design.study.dataset`), rewritten from the full table by a resumed study;
``figures/*.png``
    a result against a swept key (:mod:`actuator_design.viz.study`).

Every file is written to a temporary name in the folder and renamed; the folder's entries must be
the tool's own (no links, each of its kind: :func:`~actuator_design.study.plan.check_study_folder`,
checked again under the lock and before the outputs). A write the file system refuses (read-only,
full) is a :class:`StudyStorageError` naming the file; when the journal holds the finished points
it says so, and ``resume=True`` continues once the cause is gone. An interrupted study (Ctrl-C, SIGTERM, or a
killed process) resumes with ``resume=True`` without recomputing its finished points.
"""
from __future__ import annotations

import errno
import math
import os
import signal
import socket
import sys
import threading
import time
import warnings
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional

from actuator_design.io.save import atomic_write
from actuator_design.io.safe_files import FILE, check_entries, os_error_text
from actuator_design.study import backends, walk
from actuator_design.study.errors import StudyError, StudyInterrupted, StudyStorageError, StudyWarning
from actuator_design.study.journal import JOURNAL_NAME, Journal
from actuator_design.study.lock import FolderLock
from actuator_design.study.manifest import counts, manifest_base, point_list, previous_manifest, read_manifest
from actuator_design.study.dataset import write_dataset
from actuator_design.study.outputs import build_table, write_csv, write_manifest, write_parquet
from actuator_design.study.plan import (CSV_NAME, FIGURES_DIR, MANIFEST_NAME, NETCDF_NAME, PARQUET_NAME,
                                        StudyPlan, check_study_folder, journal_records, plan_study)

__all__ = ["StudyPlan", "StudyReport", "StudyError", "StudyStorageError", "StudyInterrupted",
           "StudyWarning", "plan_study", "run_study", "read_manifest"]

#: Rejected journal records named in a warning (the count is always given).
_SHOWN_REJECTIONS = 3


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


@dataclass
class StudyReport:
    """What a run did. ``throughput`` is points computed in this run per second of wall time."""

    out: Path
    name: str
    status: str
    n_points: int
    counts: Dict[str, int]
    computed: int
    reused: int
    elapsed_s: float
    throughput: float
    backend: str
    workers: int
    files: Dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"out": str(self.out), "name": self.name, "status": self.status,
                "n_points": self.n_points, "counts": dict(self.counts), "computed": self.computed,
                "reused": self.reused, "elapsed_s": self.elapsed_s,
                "throughput_points_per_s": self.throughput, "backend": self.backend,
                "workers": self.workers, "files": self.files}

    def summary(self) -> str:
        counts = ", ".join(f"{v} {k}" for k, v in self.counts.items() if v)
        lines = [f"study: {self.name} — {self.status}",
                 f"  points      : {self.n_points} ({counts})",
                 f"  this run    : {self.computed} computed, {self.reused} reused from the journal, "
                 f"{self.elapsed_s:.2f} s, {self.throughput:.1f} points/s "
                 f"({self.backend}, {self.workers} worker{'s' if self.workers != 1 else ''})",
                 f"  folder      : {self.out}"]
        for k, v in self.files.items():
            if isinstance(v, list):
                lines.append(f"  {k:<12s}: {', '.join(v) if v else '-'}")
            elif v:
                lines.append(f"  {k:<12s}: {v}")
        return "\n".join(lines)


def _default_chunk(n_todo: int, workers: int) -> int:
    return int(min(16, max(1, math.ceil(n_todo / max(1, 8 * workers)))))


def _warn(message: str) -> None:
    warnings.warn(message, StudyWarning, stacklevel=3)


def run_study(plan, out_dir=None, *, workers: Optional[int] = None, scheduler=None,
              progress: bool = True, resume: bool = False, max_points: Optional[int] = None,
              notify: Optional[Callable[[str], None]] = None) -> StudyReport:
    """Compute a study's points that are not done yet and write its folder.

    Parameters
    ----------
    plan : StudyPlan, or a configuration (path or dict)
        From :func:`plan_study` (or planned here with ``out_dir``, ``resume`` and
        ``max_points``).
    out_dir : str or Path, optional
        Study folder when ``plan`` is a configuration.
    workers : int, optional
        Local worker processes (default: all cores; 1 runs in this process). Ignored with a
        scheduler.
    scheduler : str or distributed.Client, optional
        Dask scheduler address (``tcp://…``) or a connected client.
    progress : bool
        Show a tqdm progress bar on stderr.
    resume, max_points
        See :func:`plan_study`.
    notify : callable, optional
        Called with a one-line message for what the user should know (a stale lock taken over,
        journal records rejected); default: :class:`StudyWarning` warnings.

    Returns
    -------
    StudyReport

    Raises
    ------
    StudyInterrupted
        Ctrl-C or SIGTERM: the finished points are journaled, the manifest says "interrupted".
    StudyError
        Another live run holds the folder, the scheduler cannot be reached or Dask is missing.
    StudyStorageError
        The file system refused a write (``resumable`` when the journal keeps the finished points).
    OutputFolderError
        An entry of the folder is a link or of the wrong kind.
    """
    if not isinstance(plan, StudyPlan):
        if out_dir is None:
            raise StudyError("out_dir is required when run_study is given a configuration")
        plan = plan_study(plan, out_dir, resume=resume, max_points=max_points)
    notify = notify or _warn
    try:
        plan.out.mkdir(parents=True, exist_ok=True)
        lock = FolderLock(plan.out)
        note = lock.acquire()
        try:
            if note:
                notify(note)
            check_study_folder(plan.out)  # again, now that no other run of this tool can change it
            return _run_locked(plan, workers, scheduler, progress, notify)
        finally:
            lock.release()
    except OSError as err:
        if not _is_storage(err):
            raise
        raise _storage_error(err, plan, None) from None


#: Errors of the file system even when the error names no file.
_STORAGE_ERRNOS = {errno.ENOSPC, errno.EROFS, errno.EDQUOT, errno.EFBIG, errno.EIO}


def _is_storage(err: OSError) -> bool:
    """An error of a file (named, or of a kind only a file system raises), not e.g. a lost
    connection to a Dask scheduler."""
    return err.filename is not None or err.errno in _STORAGE_ERRNOS


def _storage_error(err: OSError, plan: StudyPlan, journaled: Optional[int]) -> StudyStorageError:
    """The one-line error of a refused write; resumable when the folder holds this study's
    journal (``journaled``: its points, when known)."""
    text = f"--out: {os_error_text(err, 'cannot write')}"
    try:
        has_journal = Journal.read_header(plan.out / JOURNAL_NAME) is not None
    except (OSError, ValueError):
        has_journal = False
    if not has_journal:
        return StudyStorageError(f"{text}; nothing of the study is kept in {plan.out}")
    kept = (f"{journaled} of {plan.n_points} points are journaled" if journaled is not None
            else "the journal keeps the finished points")
    return StudyStorageError(f"{text}; {kept} in {plan.out}: once the cause is gone (space freed, "
                             "folder writable), run again with --resume", resumable=True)


def _tasks(plan: StudyPlan, todo: List[int], chunk: int) -> List[dict]:
    """Chunks of points for the workers. A plain ``solve`` study walks chunks fixed by the grid
    (:mod:`~actuator_design.study.walk`: a chunk with a point to do is walked whole, its points
    not done are emitted); other studies take the points to do ``chunk`` at a time."""
    axes_d = [a.to_dict() for a in plan.axes]
    base = {"raw": plan.raw, "axes": axes_d, "analyses": plan.analyses, "outputs": plan.spec.outputs}
    if walk.walkable(plan.analyses):
        pending = set(todo)
        chunks = walk.plan_chunks(plan.raw, plan.axes, plan.indices, plan.spec.grid,
                                  plan.spec.chunk_size)
        return [{**base, "walk": True, "emit": [i for i in c if i in pending],
                 "points": [(i, tuple(plan.indices[i])) for i in c]}
                for c in chunks if pending.intersection(c)]
    return [{**base, "points": [(i, tuple(plan.indices[i])) for i in todo[k:k + chunk]]}
            for k in range(0, len(todo), chunk)]


def _rejection_warning(found) -> Optional[str]:
    """One line: how many journal lines were rejected (of them, how many had no checksum), the
    first reasons, and that their points are computed again."""
    rejected = found.rejected
    if not rejected:
        return None
    shown = "; ".join(rejected[:_SHOWN_REJECTIONS])
    more = f"; and {len(rejected) - _SHOWN_REJECTIONS} more" if len(rejected) > _SHOWN_REJECTIONS \
        else ""
    old = (f", {found.unverified} of them without a checksum (a journal of an older version: "
           "untrusted)" if found.unverified else "")
    return (f"journal: {len(rejected)} line(s) rejected{old} ({shown}{more}); points without an "
            "accepted record are computed again")


def _run_locked(plan: StudyPlan, workers, scheduler, progress: bool, notify) -> StudyReport:
    """:func:`run_study` once the folder's lock is held."""
    from tqdm.auto import tqdm

    out, n = plan.out, plan.n_points
    found = journal_records(plan)
    records: Dict[int, dict] = dict(found.records)
    rejection = _rejection_warning(found)
    if rejection:
        notify(rejection)
    todo = [i for i in range(n) if i not in records]
    client = None
    if scheduler is not None:
        client, n_workers = backends.connect(scheduler)
        backend = "dask"
    else:
        n_workers = int(workers or os.cpu_count() or 1)
        backend = "serial" if n_workers == 1 or len(todo) <= 1 else "processes"
    chunk = plan.spec.chunk_size or _default_chunk(len(todo), n_workers)
    tasks = _tasks(plan, todo, chunk)
    walked = bool(tasks) and bool(tasks[0].get("walk"))
    if walked:
        chunk = max(len(t["points"]) for t in tasks)

    previous = previous_manifest(out) if plan.resume else None
    runs = list(previous.get("runs", [])) if previous else []
    notes = list(previous.get("warnings", [])) if previous else []
    notes += [rejection] if rejection else []
    started = _now()
    run_info = {"started": started, "finished": None, "status": "running", "backend": backend,
                "workers": n_workers, "scheduler": scheduler if isinstance(scheduler, str) else
                (None if scheduler is None else "client"), "chunk_size": chunk,
                "walk": walked, "chunks": len(tasks),
                "computed": 0, "reused": len(records), "rejected_records": len(found.rejected),
                "elapsed_s": 0.0, "throughput_points_per_s": None,
                "pid": os.getpid(), "host": socket.gethostname()}
    base = manifest_base(plan, previous)

    def manifest(status: str) -> dict:
        return {**base, "status": status, "started": base["started"] or started,
                "finished": run_info["finished"], "counts": counts(records, n),
                "runs": runs + [run_info], "warnings": notes, "points": point_list(plan, records)}

    write_manifest(out / MANIFEST_NAME, manifest("running"))
    journal = Journal(out / JOURNAL_NAME, plan.study_id, n, plan.inputs_digest).open()
    stop = backends.StopRequest()
    if backend == "dask":
        gen = backends.on_dask(tasks, client)
    elif backend == "processes":
        gen = backends.processes(tasks, n_workers)
    else:
        gen = backends.serial(tasks, stop)
    if backend != "serial":  # the workers compute: load the plotting code meanwhile
        threading.Thread(target=_import_figure_code, daemon=True).start()

    class _Bar(tqdm):
        monitor_interval = 0  # no monitor thread (worker processes may be forked later)

    bar = _Bar(total=n, initial=len(records), disable=not progress, unit="pt", dynamic_ncols=True,
               desc=plan.name[:30], file=sys.stderr)
    old_handlers = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            old_handlers[sig] = signal.signal(sig, stop)
    t0 = time.perf_counter()
    status = "failed"
    try:
        for recs in gen:
            recs = journal.append(recs)  # as written (and as a resume reads them back)
            for r in recs:
                records[r["index"]] = r
            run_info["computed"] += len(recs)
            bar.update(len(recs))
            if stop.requested and len(records) < n:
                raise KeyboardInterrupt
        status = "completed"
    except KeyboardInterrupt:
        status = "interrupted"
    except OSError as err:
        if not _is_storage(err):
            raise
        raise _storage_error(err, plan, len(records)) from None
    finally:
        gen.close()
        journal.close()
        bar.close()
        for sig, handler in old_handlers.items():
            signal.signal(sig, handler)
        elapsed = time.perf_counter() - t0
        run_info.update(finished=_now(), status=status, elapsed_s=elapsed,
                        throughput_points_per_s=(run_info["computed"] / elapsed
                                                 if elapsed > 0 and run_info["computed"] else None))
        if client is not None and isinstance(scheduler, str):
            client.close()
        if status == "interrupted":
            write_manifest(out / MANIFEST_NAME, manifest(status))
        elif status == "failed":  # an error is on its way out: do not let this one replace it
            try:
                write_manifest(out / MANIFEST_NAME, manifest(status))
            except OSError:
                pass
    if status == "interrupted":
        raise StudyInterrupted(f"{len(records)} of {n} points finished and journaled in {out}; "
                               "run again with --resume to compute the rest")

    try:
        files = _write_outputs(plan, records)
        final = manifest("completed")
        final["files"] = files
        write_manifest(out / MANIFEST_NAME, final)
    except OSError as err:
        if not _is_storage(err):
            raise
        raise _storage_error(err, plan, len(records)) from None
    return StudyReport(out=out, name=plan.name, status="completed", n_points=n,
                       counts=final["counts"], computed=run_info["computed"],
                       reused=run_info["reused"], elapsed_s=run_info["elapsed_s"],
                       throughput=run_info["throughput_points_per_s"] or 0.0, backend=backend,
                       workers=run_info["workers"] or 0, files=files)


def _import_figure_code() -> None:
    """Import matplotlib and the study figures (≈0.5 s), and xarray for ``results.nc`` (≈0.3 s),
    while the workers compute."""
    try:
        from actuator_design.viz.study import study_figures  # noqa: F401
        from actuator_design.viz.style import preload
        preload()
        import xarray  # noqa: F401
    except Exception:  # noqa: BLE001 - the outputs import it again and report any error there
        pass


def _write_outputs(plan: StudyPlan, records: Dict[int, dict]) -> Dict[str, Any]:
    from actuator_design.viz.study import default_figures, study_figures

    check_study_folder(plan.out)
    table = build_table(plan.axes, plan.indices, records, plan.spec.outputs)
    files: Dict[str, Any] = {"journal": JOURNAL_NAME}
    write_csv(plan.out / CSV_NAME, table)
    files["csv"] = CSV_NAME
    write_dataset(plan.out / NETCDF_NAME, plan, table)
    files["netcdf"] = NETCDF_NAME
    files["parquet"] = PARQUET_NAME if write_parquet(plan.out / PARQUET_NAME, table) else None
    specs = ([f.model_dump() for f in plan.spec.figures] if plan.spec.figures
             else default_figures(plan.axes, table))
    figs = study_figures(plan.axes, table, specs)
    fig_dir = plan.out / FIGURES_DIR
    names = []
    from actuator_design.viz.style import png_bytes
    encoded = {f"{stem}.png": png_bytes(fig, dpi=150) for stem, fig in figs.items()}
    for name, png in list(encoded.items()):  # under --format: the vector copies beside each PNG
        encoded.update({f"{name[:-4]}.{fmt}": data for fmt, data in png.vector.items()})
    check_entries(fig_dir, {name: FILE for name in encoded})
    if figs:
        fig_dir.mkdir(exist_ok=True)
    for name, data in encoded.items():
        atomic_write(fig_dir / name, lambda fh, b=data: fh.write(b), binary=True)
        names.append(f"{FIGURES_DIR}/{name}")
    files["figures"] = names
    return files
