"""Solve sweeps that walk the grid: the points of one load ray share one path from rest.

``solve`` answers with the state reached from rest: the loads and the field ramped together from
zero, λ P for λ ∈ [0, 1] (:mod:`actuator_design.continuation.from_rest`). Grid points whose parameter vectors
lie on one ray {λ P_ref} — a line of the grid along the field magnitude (or a load) with every
other load zero — lie on each other's loading paths: one path from rest that lands on each of them
in turn (:func:`~actuator_design.continuation.from_rest.path_from_rest` with ``stations``) yields every point's
answer, each a warm-started Newton step on the fast path (IPOPT only where the rod snaps or leaves
a branch point, whose answer is then polished as a lone solve's is), with the same stable-state
selection as a solve of that point alone, on the mesh a lone solve chooses for it (points whose
boundary layers need another grading share another path). A study with ``ensure_stable: false``
solves every point alone: without stability checks a path's branch depends on its steps.

Chunks are fixed by the grid, never by the number of workers: :func:`plan_chunks` splits each
grid line along the *walk axis* (chosen here from the scene: the first swept key whose line is a
ray) into its two rays (values ≥ 0 and < 0, by |value|) and those into segments of at most
:data:`WALK_CHUNK` points, each walked from rest. A point's result therefore does not depend on
the workers, the backend, or a resume (an interrupted chunk is walked again whole; only its
missing points are recorded). A chunk whose points do not form a ray (another load swept too, a
swept solver setting) is solved point by point, each from rest on its own.

Only the result columns the study keeps are evaluated (:meth:`EquilibriumResult.to_dict` with
``include``); the accuracy checks behind ``success`` (Euler–Lagrange residual, self-intersection,
:func:`actuator_design.equilibrium.acceptance.accept`) always run, and a point that misses the
residual limit is refined as a lone solve's is (:func:`~actuator_design.equilibrium.acceptance.refined`). Unlike a lone ``solve``, a study point is
not also solved from the straight rod to look for another stable state (the ``equilibria``
analysis lists them all); its ``solver.from_rest.walk`` is true.

A point computed on its own (any other study, or a chunk that is not a ray) is :func:`one_point`:
its configuration validated, every analysis run on its scene, the results flattened into table
columns (a record of the journal, :mod:`actuator_design.study.worker`).
"""
from __future__ import annotations

import fnmatch
import functools
import time
import warnings
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from actuator_design.analysis import registry
from actuator_design.config import ConfigError, load_config
from actuator_design.continuation.from_rest import path_from_rest
from actuator_design.equilibrium.acceptance import accept, graded_options, refined
from actuator_design.equilibrium.balance import balance_many, operator_for
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.single import make_result, solve_on
from actuator_design.equilibrium.solver import get_solver
from actuator_design.io.save import jsonable
from actuator_design.reduced.stability import verdict_of
from actuator_design.study.grid import Axis, point_values, substitute

__all__ = ["WALK_CHUNK", "walkable", "plan_chunks", "run_walk_chunk", "wanted_keys", "one_point", "flatten",
           "MAX_LIST"]

#: Lists of at most this many scalars become columns ``key.0``, ``key.1``, …; longer ones are
#: left out of the table (e.g. a shape).
MAX_LIST = 8


def flatten(obj: Any, prefix: str, out: Dict[str, Any] = None) -> Dict[str, Any]:
    """Scalars of nested dicts as ``{"prefix.a.b": value}`` (short lists by index)."""
    out = {} if out is None else out
    if isinstance(obj, dict):
        for k, v in obj.items():
            flatten(v, f"{prefix}.{k}", out)
    elif isinstance(obj, (list, tuple)):
        if len(obj) <= MAX_LIST and all(not isinstance(v, (dict, list, tuple)) for v in obj):
            for i, v in enumerate(obj):
                out[f"{prefix}.{i}"] = jsonable(v)
    else:
        out[prefix] = jsonable(obj)
    return out


def one_point(raw: dict, axes, analyses, index: int, idx, outputs=None) -> Dict[str, Any]:
    """One point's record: its configuration validated, every analysis run on its scene."""
    t0 = time.perf_counter()
    rec: Dict[str, Any] = {"index": int(index), "values": point_values(axes, idx), "status": "ok",
                           "message": "", "results": {}}
    notes: List[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            config = load_config(substitute(raw, axes, idx))
            scene, options = config.to_scene(), config.solver_options()
        except ConfigError as err:
            rec.update(status="invalid", message=str(err))
            scene = None
        if scene is not None:
            for entry in analyses:
                name = entry["type"]
                settings = {k: v for k, v in entry.items() if k != "type"}
                try:
                    out = registry.get(name)(scene, options, **settings)
                except Exception as err:  # noqa: BLE001 - recorded per point, the study goes on
                    rec.update(status="error", message=f"{name}: {type(err).__name__}: "
                                                       f"{' '.join(str(err).split())}")
                    break
                flatten(out, name, rec["results"])
                if isinstance(out, dict) and out.get("success") is False:
                    rec["status"] = "not_converged"
                    why = "; ".join(str(out[k]) for k in ("message", "accuracy") if out.get(k))
                    notes.append(f"{name}: {' '.join(why.split())}")
        for w in caught:
            notes.append(f"warning: {' '.join(str(w.message).split())}")
    if outputs is not None:  # keep only the columns the study asked for (smaller journal)
        rec["results"] = {k: v for k, v in rec["results"].items()
                          if any(fnmatch.fnmatchcase(k, p) for p in outputs)}
    if notes and rec["status"] not in ("invalid", "error"):
        rec["message"] = "; ".join(notes)
    rec["time_s"] = time.perf_counter() - t0
    return rec


#: most points of one walked chunk (a segment of a ray; each segment starts from rest)
WALK_CHUNK = 256
#: relative tolerance of the ray test on parameter vectors
_RAY_RTOL = 1e-12


def walkable(analyses: Sequence[dict]) -> bool:
    """Whether a study's analysis list is the plain ``solve`` the walk computes."""
    return [dict(a) for a in analyses] == [{"type": "solve"}]


def wanted_keys(outputs: Optional[Sequence[str]]) -> Optional[List[str]]:
    """Top-level result keys whose columns a study keeps (``solve.<key>…``), or None for all.

    A pattern keeps a key when the pattern's literal prefix (up to its first wildcard) and
    ``solve.<key>`` agree as far as both go (conservative: a key is never dropped wrongly).
    """
    if outputs is None:
        return None
    keys = []
    for k in EquilibriumResult.DICT_KEYS:
        col = f"solve.{k}"
        for pat in outputs:
            cut = min([pat.index(c) for c in "*?[" if c in pat] + [len(pat)])
            prefix = pat[:cut]
            if (fnmatch.fnmatchcase(col, pat) or col.startswith(prefix) or prefix.startswith(col + ".")
                    or (cut < len(pat) and prefix.startswith(col))):
                keys.append(k)
                break
    return keys


# -- planning (in the study process) ---------------------------------------------------------------
def _scene_point(raw, axes, idx):
    config = load_config(substitute(raw, axes, idx))
    return config.to_scene(), config.solver_options()


def _is_ray(vectors: Sequence[np.ndarray], load_slots: Sequence[int]) -> Optional[np.ndarray]:
    """Load fractions c_j with P_j = c_j P_ref on the load slots and P_j = P_ref elsewhere
    (P_ref the vector with the largest loads), shape (m,); None when the points are not on one ray."""
    P = np.asarray(vectors, float)
    L = np.zeros(P.shape[1], bool)
    L[list(load_slots)] = True
    loads, rest = P[:, L], P[:, ~L]
    ref = int(np.argmax(np.linalg.norm(loads, axis=1)))
    norm = float(np.linalg.norm(loads[ref]))
    if norm == 0.0:
        return None
    scale = np.maximum(1.0, np.abs(rest[ref]))
    if np.any(np.abs(rest - rest[ref]) > _RAY_RTOL * scale):
        return None
    c = loads @ loads[ref] / norm ** 2
    if np.any(np.abs(loads - c[:, None] * loads[ref]) > _RAY_RTOL * norm) or np.any(c < -_RAY_RTOL):
        return None
    return np.clip(c, 0.0, 1.0)


def walk_axis(raw, axes, indices) -> Optional[int]:
    """The first numeric swept key along which the grid's first line is a load ray, or None.

    Three points of the line (first, middle, largest value) are built as scenes and their
    parameter vectors tested (:func:`_is_ray`); the solver built for it is cached for the workers
    that fork from this process.
    """
    for a, axis in enumerate(axes):
        n = len(axis.values)
        if n < 3 or not axis.numeric:
            continue
        mags = [abs(v) for v in axis.numbers]
        top = int(np.argmax(mags))  # three points on the side of the largest value (a ray)
        side = sorted((j for j in range(n) if (axis.numbers[j] >= 0) == (axis.numbers[top] >= 0)),
                      key=lambda j: mags[j])
        if len(side) < 2:
            continue
        picks = sorted({side[0], side[len(side) // 2], top})
        base = list(indices[0])
        try:
            pts = [_scene_point(raw, axes, base[:a] + [j] + base[a + 1:]) for j in picks]
        except ConfigError:
            continue
        if any(o != pts[0][1] for _, o in pts):
            continue
        solver = get_solver(pts[-1][0], pts[-1][1])
        try:
            vecs = [solver.parameter_vector(s) for s, _ in pts]
        except (KeyError, ValueError):
            continue
        if _is_ray(vecs, list(solver._scale_lin) + list(solver._scale_sq)) is not None:
            return a
    return None


def plan_chunks(raw, axes, indices, grid: str, chunk: Optional[int] = None) -> List[List[int]]:
    """The grid's points in walk order, cut into chunks fixed by the grid (module doc).

    Returns
    -------
    list of list of int
        Point indices of each chunk, in the order they are walked.
    """
    size = int(chunk or WALK_CHUNK)
    a = walk_axis(raw, axes, indices) if grid == "cartesian" else None
    if a is None:
        order = list(range(len(indices)))
        return [order[k:k + size] for k in range(0, len(order), size)]
    lines: Dict[Tuple[int, ...], List[int]] = {}
    for i, idx in enumerate(indices):
        lines.setdefault(tuple(idx[:a]) + tuple(idx[a + 1:]), []).append(i)
    numbers = axes[a].numbers
    chunks = []
    for members in lines.values():
        for side in (lambda v: v >= 0, lambda v: v < 0):
            ray = sorted((i for i in members if side(numbers[indices[i][a]])),
                         key=lambda i: (abs(numbers[indices[i][a]]), i))
            chunks += [ray[k:k + size] for k in range(0, len(ray), size)]
    return chunks


# -- computing (in a worker) -----------------------------------------------------------------------
def _record(index, values) -> Dict[str, Any]:
    return {"index": int(index), "values": values, "status": "ok", "message": "", "results": {}}


@functools.lru_cache(maxsize=4096)
def _kept(column: str, outputs: Tuple[str, ...]) -> bool:
    return any(fnmatch.fnmatchcase(column, p) for p in outputs)


def _finish(rec, result, include, outputs, notes) -> Dict[str, Any]:
    out = result.to_dict(include=include)
    out.pop("shape", None)
    flatten(out, "solve", rec["results"])
    if not result.success:
        rec["status"] = "not_converged"
        notes.append(f"solve: {' '.join(str(result.message).split())}")
    if outputs is not None:
        rec["results"] = {k: v for k, v in rec["results"].items() if _kept(k, tuple(outputs))}
    if notes:
        rec["message"] = "; ".join(notes)
    return rec


def _station_result(scene, opts, solver, params, st, lam, walked, elapsed, check=None,
                    need_eigenvalues=True):
    """The :class:`EquilibriumResult` of one station, checked like a lone ``solve`` (``check``:
    its clamp force, clamp moment and residual when computed already, :func:`balance_many`;
    ``need_eigenvalues``: the result's eigenvalues are asked for)."""
    if not st.newton:  # IPOPT's answer after a kick or a snap: polished as a lone solve does
        return _polished_result(scene, opts, solver, st, lam, walked)
    verdict = verdict_of(solver, st.z, params, st.check, need_eigenvalues)
    notes = []
    if st.branch_points:
        notes.append("from rest the rod left an unstable equilibrium along its unstable mode at "
                     + ", ".join(f"{v / lam:.4g}" for v in st.branch_points) + " of the load")
    if st.snaps:
        notes.append("from rest the rod snaps at " + ", ".join(f"{v / lam:.4g}" for v in st.snaps)
                     + " of the load")
    result = make_result(scene, opts, solver, params, st.raw, verdict, bool(st.branch_points),
                          notes, elapsed)
    if check is not None:
        force, moment, residual = check
        result._balance = lambda: (np.asarray(force, float), float(moment), float(residual))
    op = operator_for(solver)
    if op is not None:
        result._clamp_curvature = lambda: float(op.clamp_curvature_row @ st.z)
    result.stats["method"] = "fast"
    result.stats["from_rest"] = {"reached": True, "walk": walked,
                                 "snaps_at": [v / lam for v in st.snaps],
                                 "branch_points_at": [v / lam for v in st.branch_points]}
    return accept(refined(scene, result) if opts.adapt else result)


def _polished_result(scene, opts, solver, st, lam, walked):
    """The lone ``solve``'s last step from a state of the path: a strict solve on this mesh from
    it (IPOPT, Newton polish, saddle escapes), then the acceptance checks."""
    result = solve_on(scene, opts, st.z, solver, strict=True)
    if st.branch_points:
        result.escaped_saddle = True
        result.message += ("; from rest the rod left an unstable equilibrium along its unstable mode "
                           "at " + ", ".join(f"{v / lam:.4g}" for v in st.branch_points) + " of the load")
    if st.snaps:
        result.message += ("; from rest the rod snaps at " + ", ".join(f"{v / lam:.4g}" for v in st.snaps)
                           + " of the load")
    result.stats["from_rest"] = {"reached": True, "walk": walked,
                                 "snaps_at": [v / lam for v in st.snaps],
                                 "branch_points_at": [v / lam for v in st.branch_points]}
    return accept(refined(scene, result) if opts.adapt else result)


def _points(task):
    """Each point's record, scene and options (None where the configuration is invalid)."""
    axes = [Axis.from_dict(a) for a in task["axes"]]
    out = []
    for i, idx in task["points"]:
        rec = _record(i, point_values(axes, idx))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                scene, opts = _scene_point(task["raw"], axes, idx)
            except ConfigError as err:
                rec.update(status="invalid", message=str(err))
                scene = opts = None
        notes = [f"warning: {' '.join(str(w.message).split())}" for w in caught]
        out.append((rec, scene, opts, notes))
    return out


def run_walk_chunk(task: Dict[str, Any]) -> List[Dict[str, Any]]:
    """Compute one walked chunk: ``task`` as :func:`actuator_design.study.worker.run_chunk` (its
    ``points`` in walk order) plus ``emit``, the point indices to return (all by default).

    Returns
    -------
    list of dict
        One journal record per emitted point (the worker's record format; ``time_s`` is the
        chunk's wall time divided by its points, except for points solved alone).
    """
    t0 = time.perf_counter()
    emit = set(task.get("emit") or [i for i, _ in task["points"]])
    outputs = task.get("outputs")
    include = wanted_keys(outputs)
    if include is not None:
        include = sorted(set(include) | {"success"})
    points = _points(task)
    good = [(rec, s, o, n) for rec, s, o, n in points if s is not None]
    records: Dict[int, dict] = {rec["index"]: rec for rec, s, _, _ in points if s is None}
    _walk(good, include, outputs, records, graded_options, get_solver, path_from_rest)
    for (i, idx), (rec, scene, opts, notes) in zip(task["points"], points):
        if i not in records:  # off the ray or past a failed path: alone, from rest
            _alone(rec, scene, opts, notes, include, outputs, records, graded_options, get_solver,
                   path_from_rest, lambda i=i, idx=idx: _lone_solve(task, i, idx))
    share = (time.perf_counter() - t0) / max(1, len(points))
    out = []
    for rec, _, _, _ in points:
        if rec["index"] in emit:
            r = records[rec["index"]]
            r.setdefault("time_s", share)
            out.append(r)
    return out


def _walk(good, include, outputs, records, graded_options, get_solver, path_from_rest) -> bool:
    """Walk the chunk's points as one ray when they are one (records filled in); False otherwise.

    Each point is solved on the mesh a lone ``solve`` chooses for it (grading towards boundary
    layers grows with the load): the points of one mesh share one path from rest.
    """
    if len(good) < 2 or any(o != good[0][2] for _, _, o, _ in good):
        return False
    opts0 = good[0][2]
    if opts0.accuracy is not None or opts0.start != "rest" or not opts0.ensure_stable:
        return False  # without stability checks a path's branch depends on its steps: alone
    probe = get_solver(good[-1][1], opts0)
    vecs = [probe.parameter_vector(s) for _, s, _, _ in good]
    c = _is_ray(vecs, list(probe._scale_lin) + list(probe._scale_sq))
    if c is None:
        return False
    meshes: Dict[Any, List[int]] = {}
    for j, (_, scene, _, _) in enumerate(good):
        meshes.setdefault(graded_options(scene, opts0) if opts0.adapt else opts0, []).append(j)
    for opts, members in meshes.items():
        _walk_mesh(good, c, members, opts, include, outputs, records, get_solver, path_from_rest)
    return True


def _walk_mesh(good, c, members, opts, include, outputs, records, get_solver, path_from_rest):
    """One path from rest on one mesh through the chunk's points ``members`` (load fractions ``c``)."""
    ref = max(members, key=lambda j: (c[j], j))
    if c[ref] <= 0.0:
        return  # only rest states: solved alone
    solver = get_solver(good[ref][1], opts)
    vecs = {j: solver.parameter_vector(good[j][1]) for j in members}
    order = sorted(members, key=lambda j: (c[j], j))
    stations, at = [], {}
    for j in order:
        lam = float(c[j] / c[ref])
        if not stations or lam > stations[-1][0]:
            stations.append((lam, vecs[j]))
        at[j] = len(stations) - 1
    stations[-1] = (1.0, stations[-1][1])
    t0 = time.perf_counter()
    path = path_from_rest(solver, vecs[ref], follow_stable=opts.ensure_stable, stations=stations)
    elapsed = (time.perf_counter() - t0) / max(1, len(stations))
    reached = [j for j in order if at[j] < len(path.visits)]  # the others are solved alone
    plain = [j for j in reached if path.visits[at[j]].newton]
    # the accuracy check of the Newton points at once (one evaluation of the loads)
    checks = balance_many(solver, np.array([vecs[j] for j in plain]),
                          np.array([path.visits[at[j]].z for j in plain]),
                          good[ref][1]) if plain else None
    row = {j: n for n, j in enumerate(plain)}
    for j in reached:
        rec, scene, _, notes = good[j]
        lam = max(stations[at[j]][0], 1e-300)
        st = path.visits[at[j]]
        check = None if checks is None or j not in row else tuple(v[row[j]] for v in checks)
        result = _station_result(scene, opts, solver, vecs[j], st, lam, True, elapsed, check,
                                 include is None or "eigenvalues" in include)
        records[rec["index"]] = _finish(rec, result, include, outputs, list(notes))


def _lone_solve(task, index, idx) -> Dict[str, Any]:
    """The point's record by the lone ``solve`` (mesh choice, from rest, straight-rod start)."""
    axes = [Axis.from_dict(a) for a in task["axes"]]
    return one_point(task["raw"], axes, [{"type": "solve"}], index, idx, task.get("outputs"))


def _alone(rec, scene, opts0, notes, include, outputs, records, graded_options, get_solver,
           path_from_rest, lone) -> None:
    """One point from rest on its own mesh; the lone ``solve`` when its path does not arrive."""

    if opts0.accuracy is None and opts0.start == "rest":
        opts = graded_options(scene, opts0) if opts0.adapt else opts0
        solver = get_solver(scene, opts)
        params = solver.parameter_vector(scene)
        t0 = time.perf_counter()
        path = path_from_rest(solver, params, follow_stable=opts.ensure_stable, stations=[(1.0, params)])
        if path.visits:
            result = _station_result(scene, opts, solver, params, path.visits[0], 1.0, False,
                                     time.perf_counter() - t0)
            records[rec["index"]] = _finish(rec, result, include, outputs, list(notes))
            return
    records[rec["index"]] = lone()
