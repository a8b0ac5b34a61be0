"""Run a sweep study: plan the points, compute them in parallel, journal them, write the folder.

:func:`plan_study` reads and checks everything (configuration, sweep, analyses, output folder,
what a resume can reuse) before any computing; :func:`run_study` computes the points that are not
in the journal yet — in this process (one worker), in local processes (``concurrent.futures``,
spawned, one built solver per process) or on a Dask cluster (``scheduler=``; Dask is imported only
then) — and writes into the study folder:

``manifest.json``
    the full resolved configuration, package and dependency versions, solver settings, start and
    end times, execution (backend, workers, chunks), the status of every point, and the history
    of runs (a resumed study appends one), with the throughput in points per second;
``journal.jsonl``
    one JSON line per finished point, flushed per point (:mod:`actuator_design.study.journal`);
``results.csv`` (and ``results.parquet`` when pyarrow is installed)
    the tidy table (:mod:`actuator_design.study.outputs`);
``figures/*.png``
    a result against a swept key (:mod:`actuator_design.viz.study`).

Every file is written to a temporary name and renamed. An interrupted study (Ctrl-C, SIGTERM, or a
killed process) resumes with ``resume=True`` without recomputing its finished points.
"""
from __future__ import annotations

import hashlib
import io as _io
import math
import os
import signal
import threading
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional

from ..config import ConfigError, load_config
from ..io import atomic_write, dumps_json, scene_to_dict
from .grid import grid_indices, point_values, resolve_axes, substitute
from .journal import JOURNAL_NAME, Journal
from .outputs import build_table, versions, write_csv, write_manifest, write_parquet
from .spec import SweepSpec, analysis_list, validate_spec

__all__ = ["StudyPlan", "StudyReport", "StudyError", "StudyInterrupted", "plan_study", "run_study"]

MANIFEST_NAME = "manifest.json"
CSV_NAME = "results.csv"
PARQUET_NAME = "results.parquet"
FIGURES_DIR = "figures"


class StudyError(ValueError):
    """A study cannot run as asked (folder in use, scheduler unreachable, …): one line."""


class StudyInterrupted(Exception):
    """The study was interrupted; its journal and manifest allow ``resume``."""


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


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
    done: Dict[int, dict]
    name: str

    @property
    def n_points(self) -> int:
        return len(self.indices)


def plan_study(source, out_dir, resume: bool = False) -> StudyPlan:
    """Load and check a study configuration and its output folder.

    Parameters
    ----------
    source : str, Path or dict
        The configuration (a ``study:`` section of ``type: sweep``).
    out_dir : str or Path
        The study folder.
    resume : bool
        Continue the study in ``out_dir``: its journal's points are not recomputed.

    Raises
    ------
    ConfigError
        Invalid configuration or sweep (``study.<…>``).
    StudyError
        The folder holds another study, or holds this one and ``resume`` is not set.
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
    axes = resolve_axes(spec)
    analyses = analysis_list(spec)
    indices = grid_indices(axes, spec.grid)
    raw = config.raw
    _check_keys(raw, axes)
    # identity of the study: the configuration without settings that do not change results
    ident = {**raw, "study": {k: v for k, v in (raw.get("study") or {}).items() if k != "chunk_size"}}
    study_id = hashlib.sha256(dumps_json(ident).encode()).hexdigest()[:16]
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise StudyError(f"--out: {out} exists and is not a directory")
    head = Journal.read_header(out / JOURNAL_NAME)
    done: Dict[int, dict] = {}
    if head is not None:
        if not resume:
            raise StudyError(f"--out: {out} already holds a study ({JOURNAL_NAME}); pass --resume to "
                             "continue it, or choose another folder")
        if head.get("study_id") != study_id or head.get("n_points") != len(indices):
            raise StudyError(f"--resume: {out} holds a different study (its configuration or "
                             "points differ from this one); choose another folder")
        done = Journal(out / JOURNAL_NAME, study_id, len(indices)).records()
    name = config.name or (Path(source).stem if isinstance(source, (str, Path)) else "study")
    return StudyPlan(raw=raw, config=config, spec=spec, axes=axes, indices=indices,
                     analyses=analyses, out=out, study_id=study_id, resume=resume, done=done,
                     name=name)


def _check_keys(raw: dict, axes) -> None:
    """Each swept key must name a value the configuration accepts: try its first value."""
    for a in axes:
        try:
            load_config(substitute(raw, [a], [0]))
        except ConfigError as err:
            path = ".".join((a.section,) + a.path)
            if "unknown key" in err.detail and err.field.startswith(a.section):
                raise ConfigError(f"study.sweep.{a.key}",
                                  f"{path} is not a value of this {a.section}: {err}") from None


# -- execution backends -------------------------------------------------------------------------------
class _Stop:
    """Signal handler for SIGINT/SIGTERM during a run: the first signal asks to stop after the
    point (serial) or chunk (parallel) in progress — IPOPT swallows a KeyboardInterrupt raised
    inside it and would return a spurious failure that a resume would then keep —, a second one
    stops at once."""

    def __init__(self):
        self.requested = False

    def __call__(self, signum, frame):
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def check(self) -> None:
        if self.requested:
            raise KeyboardInterrupt


def _serial(tasks, stop: "_Stop") -> Iterator[List[dict]]:
    """Points in this process, one at a time (journaled per point)."""
    from .worker import run_chunk
    for t in tasks:
        for item in t["points"]:
            stop.check()
            yield run_chunk({**t, "points": [item]})


def _processes(tasks, workers: int) -> Iterator[List[dict]]:
    """Submit every chunk to a local process pool now; the generator yields results as they
    complete. Workers are forked when this process runs no other thread (they then inherit the
    imported modules: no start-up cost), spawned otherwise."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from .worker import ignore_sigint, run_chunk

    method = ("fork" if "fork" in multiprocessing.get_all_start_methods()
              and threading.active_count() == 1 else "spawn")
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context(method),
                             initializer=ignore_sigint)
    futures = [ex.submit(run_chunk, t) for t in tasks]

    def results():
        finished = False
        try:
            for f in as_completed(futures):
                yield f.result()
            finished = True
        finally:
            if finished:
                ex.shutdown(wait=True)
            else:  # interrupted: drop queued chunks and stop the workers now
                procs = list((getattr(ex, "_processes", None) or {}).values())
                ex.shutdown(wait=False, cancel_futures=True)
                for p in procs:
                    try:
                        p.terminate()
                    except Exception:  # noqa: BLE001 - already gone
                        pass

    return results()


def _connect(scheduler):
    """A Dask client for an address (or the client given) and its number of worker threads."""
    try:
        from distributed import Client
    except ImportError:
        raise StudyError("--scheduler: running on a Dask cluster needs the 'distributed' package "
                         "(pip install 'dask[distributed]')") from None
    if isinstance(scheduler, str):
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as err:
            raise StudyError(f"--scheduler: cannot connect to {scheduler}: "
                             f"{' '.join(str(err).split())}") from None
    else:
        client = scheduler
    info = client.scheduler_info()
    threads = sum(int(w.get("nthreads", 1)) for w in info.get("workers", {}).values())
    return client, max(1, threads)


def _dask(tasks, client) -> Iterator[List[dict]]:
    from distributed import as_completed

    from .worker import run_chunk

    futures = []
    try:
        futures = client.map(run_chunk, tasks, pure=False)
        for f in as_completed(futures):
            yield f.result()
    finally:
        pending = [f for f in futures if not f.done()]
        if pending:
            client.cancel(pending)


# -- the run ------------------------------------------------------------------------------------------
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


def run_study(plan, out_dir=None, *, workers: Optional[int] = None, scheduler=None,
              progress: bool = True, resume: bool = False) -> StudyReport:
    """Compute a study's points that are not done yet and write its folder.

    Parameters
    ----------
    plan : StudyPlan, or a configuration (path or dict)
        From :func:`plan_study` (or planned here with ``out_dir`` and ``resume``).
    out_dir : str or Path, optional
        Study folder when ``plan`` is a configuration.
    workers : int, optional
        Local worker processes (default: all cores; 1 runs in this process). Ignored with a
        scheduler.
    scheduler : str or distributed.Client, optional
        Dask scheduler address (``tcp://…``) or a connected client.
    progress : bool
        Show a tqdm progress bar on stderr.
    resume : bool
        See :func:`plan_study`.

    Returns
    -------
    StudyReport

    Raises
    ------
    StudyInterrupted
        Ctrl-C or SIGTERM: the finished points are journaled, the manifest says "interrupted".
    StudyError
        The scheduler cannot be reached or Dask is missing.
    """
    if not isinstance(plan, StudyPlan):
        if out_dir is None:
            raise StudyError("out_dir is required when run_study is given a configuration")
        plan = plan_study(plan, out_dir, resume=resume)
    from tqdm.auto import tqdm

    out = plan.out
    out.mkdir(parents=True, exist_ok=True)
    n = plan.n_points
    records: Dict[int, dict] = dict(plan.done)
    todo = [i for i in range(n) if i not in records]
    client = None
    if scheduler is not None:
        client, n_workers = _connect(scheduler)
        backend = "dask"
    else:
        n_workers = int(workers or os.cpu_count() or 1)
        backend = "serial" if n_workers == 1 or len(todo) <= 1 else "processes"
    chunk = plan.spec.chunk_size or _default_chunk(len(todo), n_workers)
    axes_d = [a.to_dict() for a in plan.axes]
    tasks = [{"raw": plan.raw, "axes": axes_d, "analyses": plan.analyses,
              "outputs": plan.spec.outputs,
              "points": [(i, tuple(plan.indices[i])) for i in todo[k:k + chunk]]}
             for k in range(0, len(todo), chunk)]

    previous = _read_manifest(out / MANIFEST_NAME) if plan.resume else None
    runs = list(previous.get("runs", [])) if previous else []
    started = _now()
    run_info = {"started": started, "finished": None, "status": "running", "backend": backend,
                "workers": n_workers, "scheduler": scheduler if isinstance(scheduler, str) else
                (None if scheduler is None else "client"), "chunk_size": chunk,
                "computed": 0, "reused": len(records), "elapsed_s": 0.0,
                "throughput_points_per_s": None}
    base = _manifest_base(plan, previous)

    def manifest(status: str) -> dict:
        counts = _counts(records, n)
        return {**base, "status": status, "started": base["started"] or started,
                "finished": run_info["finished"], "counts": counts,
                "runs": runs + [run_info], "points": _point_list(plan, records)}

    write_manifest(out / MANIFEST_NAME, manifest("running"))
    journal = Journal(out / JOURNAL_NAME, plan.study_id, n).open()
    stop = _Stop()
    if backend == "dask":
        gen = _dask(tasks, client)
    elif backend == "processes":
        gen = _processes(tasks, n_workers)
    else:
        gen = _serial(tasks, stop)
    class _Bar(tqdm):
        monitor_interval = 0  # no monitor thread (worker processes may be forked later)

    bar = _Bar(total=n, initial=len(records), disable=not progress, unit="pt", dynamic_ncols=True,
               desc=plan.name[:30], file=__import__("sys").stderr)
    old_handlers = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            old_handlers[sig] = signal.signal(sig, stop)
    t0 = time.perf_counter()
    status = "failed"
    try:
        for recs in gen:
            journal.append(recs)
            for r in recs:
                records[r["index"]] = r
            run_info["computed"] += len(recs)
            bar.update(len(recs))
            if stop.requested and len(records) < n:
                raise KeyboardInterrupt
        status = "completed"
    except KeyboardInterrupt:
        status = "interrupted"
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
        if status != "completed":
            write_manifest(out / MANIFEST_NAME, manifest(status))
    if status == "interrupted":
        raise StudyInterrupted(f"{len(records)} of {n} points finished and journaled in {out}; "
                               "run again with --resume to compute the rest")

    files = _write_outputs(plan, records)
    final = manifest("completed")
    final["files"] = files
    write_manifest(out / MANIFEST_NAME, final)
    return StudyReport(out=out, name=plan.name, status="completed", n_points=n,
                       counts=final["counts"], computed=run_info["computed"],
                       reused=run_info["reused"], elapsed_s=run_info["elapsed_s"],
                       throughput=run_info["throughput_points_per_s"] or 0.0, backend=backend,
                       workers=run_info["workers"] or 0, files=files)


def _read_manifest(path) -> Optional[dict]:
    import json
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _manifest_base(plan: StudyPlan, previous: Optional[dict]) -> dict:
    from .. import __version__
    scene = plan.config.to_scene()
    return {
        "manifest": "actuator-design study",
        "name": plan.name,
        "description": plan.config.description,
        "study_id": plan.study_id,
        "package_version": __version__,
        "versions": versions(),
        "config": plan.raw,
        "resolved": {
            "grid": plan.spec.grid,
            "sweep": [a.to_dict() for a in plan.axes],
            "analyses": plan.analyses,
            "outputs": plan.spec.outputs,
            "figures": [f.model_dump() for f in plan.spec.figures] if plan.spec.figures else None,
            "base_scene": scene_to_dict(scene),
        },
        "solver": plan.config.solver_options().as_dict(),
        "n_points": plan.n_points,
        "started": previous.get("started") if previous else None,
        "files": {"journal": JOURNAL_NAME},
    }


def _counts(records: Dict[int, dict], n: int) -> Dict[str, int]:
    out = {"ok": 0, "not_converged": 0, "invalid": 0, "error": 0}
    for r in records.values():
        out[r.get("status", "error")] = out.get(r.get("status", "error"), 0) + 1
    out["pending"] = n - len(records)
    return out


def _point_list(plan: StudyPlan, records: Dict[int, dict]) -> List[dict]:
    pts = []
    for i, idx in enumerate(plan.indices):
        rec = records.get(i)
        entry = {"index": i, "values": point_values(plan.axes, idx),
                 "status": rec.get("status") if rec else "pending"}
        if rec and rec.get("message"):
            entry["message"] = rec["message"]
        pts.append(entry)
    return pts


def _write_outputs(plan: StudyPlan, records: Dict[int, dict]) -> Dict[str, Any]:
    from ..viz.study import default_figures, study_figures

    table = build_table(plan.axes, plan.indices, records, plan.spec.outputs)
    files: Dict[str, Any] = {"journal": JOURNAL_NAME}
    write_csv(plan.out / CSV_NAME, table)
    files["csv"] = CSV_NAME
    files["parquet"] = PARQUET_NAME if write_parquet(plan.out / PARQUET_NAME, table) else None
    specs = ([f.model_dump() for f in plan.spec.figures] if plan.spec.figures
             else default_figures(plan.axes, table))
    figs = study_figures(plan.axes, table, specs)
    fig_dir = plan.out / FIGURES_DIR
    names = []
    if figs:
        fig_dir.mkdir(exist_ok=True)
    for stem, fig in figs.items():
        buf = _io.BytesIO()
        fig.savefig(buf, format="png", dpi=120)
        atomic_write(fig_dir / f"{stem}.png", lambda fh, b=buf.getvalue(): fh.write(b), binary=True)
        names.append(f"{FIGURES_DIR}/{stem}.png")
    files["figures"] = names
    return files
