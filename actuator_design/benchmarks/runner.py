"""Methods, timing protocol and table of the forward benchmark (issue 4, item 2).

Protocol, for every (problem, method):

1. **build** — construct what the method needs once (CasADi functions, IPOPT, JIT code, matrices);
   timed separately as ``build_s``.
2. **cold solve** at the nominal scene from the problem's guess (robustly: IPOPT for collocation)
   — this selects the branch; not timed.
3. **warm re-solves** — ``repeats`` solves at slightly perturbed parameters (relative wobble of
   1e-3 … 4e-3 in h or p, alternating sign), each started from the previous solution; the median
   wall time is ``time_s``. What is timed: the method's solve from (previous solution, new
   parameters) to the tip (x(1), y(1), θ(1)); packing the parameters is not timed (it is the same
   for every method). ``api-fast`` rows time the public :func:`~actuator_design.equilibrium.pipeline.solve`
   instead, including parameter packing, the stability verdict and the result object.
4. **error** — max(|Δx(1)|, |Δy(1)|, |Δθ(1)|) against the problem's independent reference, at the
   nominal scene, for both the cold solve and a last warm solve back at the nominal parameters
   (the larger is reported); ``converged`` is false if any solve failed.
"""
from __future__ import annotations

import gc
import math
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from actuator_design.benchmarks import problems as P
from actuator_design.benchmarks.bvp import bvp_from_scene, solve_bvp_peer
from actuator_design.benchmarks.floor import NumpyNewton
from actuator_design.benchmarks.problems import PROBLEMS, Problem, shooting_params_from_scene
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.solver import get_solver
from actuator_design.parallel import _progress, map_parallel
from actuator_design.reference.shooting import solve_shooting

__all__ = ["Method", "default_methods", "run_problem", "run_benchmark", "format_table",
           "target_summary", "perturbation"]

#: tolerance sweep of the peer
BVP_TOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)


def perturbation(k: int) -> float:
    """Relative parameter wobble of the k-th warm re-solve: ±1e-3 … ±4e-3, alternating."""
    return 1e-3 * ((k % 4) + 1) * (-1.0) ** k


def _tip_error(tip, ref) -> float:
    return float(np.max(np.abs(np.asarray(tip, float) - np.asarray(ref, float))))


# -- runners ------------------------------------------------------------------------------------
class _Collocation:
    """The project's solvers on one transcription: ``mode`` in fast / newton / ipopt / api."""

    def __init__(self, prob: Problem, options, mode: str):
        self.options, self.mode = options, mode
        # one build per scene structure and resolution, shared by methods and problems (as in
        # the library); build_s reports what that build cost when it was made
        self.solver = get_solver(prob.scene, options)
        self.n = int(self.solver.transcription.nodes.size)
        self.note = self.solver.jit_note

    @property
    def build_s(self) -> float:
        """What building this structure and resolution cost (IPOPT included once it is built)."""
        return self.solver.build_time

    def params(self, scene):
        return scene if self.mode == "api" else self.solver.parameter_vector(scene)

    def cold(self, scene, guess):
        r = solve(scene, replace(self.options, method="ipopt", ensure_stable=False),
                  initial=guess(self.solver.transcription.nodes), solver=self.solver)
        return (r.tip["x"], r.tip["y"], r.tip["angle"]), r.z, bool(r.success)

    def solve(self, prm, z):
        sv = self.solver
        if self.mode == "api":
            r = solve(prm, self.options, initial=z, solver=sv)
            return (r.tip["x"], r.tip["y"], r.tip["angle"]), r.z, bool(r.success)
        if self.mode == "fast":
            raw = sv.solve_fast(z, prm)
        elif self.mode == "newton":
            raw = sv.solve_newton(z, prm)
        else:
            raw = sv.solve_ipopt(z, prm)
        _, th, x, y = sv.summary(raw.z, prm)
        return (x, y, th), raw.z, raw.converged


class _Floor:
    """Plain dense numpy Newton on the same LGL system (uniform fields)."""

    def __init__(self, prob: Problem, elements: int, degree: int):
        self.nn = NumpyNewton(elements, degree)
        self.n = int(self.nn.tr.nodes.size)
        self._opts = SolverOptions(elements=elements, degree=degree)
        self._get = lambda: get_solver(prob.scene, self._opts)
        self.note = ""

    def params(self, scene):
        return self.nn.prepare(scene)

    def cold(self, scene, guess):
        r = solve(scene, replace(self._opts, ensure_stable=False), initial=guess(self.nn.tr.nodes))
        return (r.tip["x"], r.tip["y"], r.tip["angle"]), r.z, bool(r.success)

    def solve(self, prep, z):
        z, ok, _ = self.nn.solve(z, prep)
        thq = self.nn.G @ z
        w = self.nn.w
        return (float(w @ np.cos(thq)), float(w @ np.sin(thq)), float(z[-1])), z, ok


class _SolveBVP:
    """scipy ``solve_bvp`` (the peer) at tolerance ``tol``, warm-started from the previous mesh."""

    def __init__(self, prob: Problem, tol: float):
        self.tol = tol
        self.n = 0
        self.note = "" if prob.uniform else "finite-difference Jacobian"

    def params(self, scene):
        return bvp_from_scene(scene)

    def cold(self, scene, guess):
        sol = solve_bvp_peer(bvp_from_scene(scene), self.tol, guess_theta=guess)
        self.n = sol.n_nodes
        return sol.tip, sol, sol.success

    def solve(self, bvp, warm):
        sol = solve_bvp_peer(bvp, self.tol, initial=warm)
        self.n = max(self.n, sol.n_nodes)
        return sol.tip, sol, sol.success


class _Shooting:
    """The uniform-field shooting solver (DOP853 rtol 1e-12 + Newton on θ'(0)), warm from the
    previous θ'(0)."""

    def __init__(self, prob: Problem):
        self.gamma0 = prob.gamma_guess
        self.n = 0
        self.note = ""

    def params(self, scene):
        return shooting_params_from_scene(scene)

    def cold(self, scene, guess):
        sol = solve_shooting(shooting_params_from_scene(scene), gamma_guess=self.gamma0)
        self.n = int(sol.s_nodes.size)
        return sol.tip, sol.gamma, sol.converged

    def solve(self, params, gamma):
        sol = solve_shooting(params, gamma_guess=gamma)
        return sol.tip, sol.gamma, sol.converged


# -- methods ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Method:
    """One benchmarked configuration.

    Attributes
    ----------
    name : str
        Method family, e.g. ``"lgl-fast"``, ``"solve_bvp"``.
    label : str
        Resolution or tolerance, e.g. ``"E=1 d=12"``, ``"tol=1e-8"``.
    peer : bool
        True for methods that are not the project's (scipy ``solve_bvp``).
    make : callable
        ``make(problem) -> runner`` (the build; timed).
    applies : callable
        ``applies(problem) -> bool``.
    """

    name: str
    label: str
    peer: bool
    make: Callable = field(repr=False)
    applies: Callable = field(default=lambda p: True, repr=False)


def _needs_positions(prob: Problem) -> bool:
    return not prob.uniform or prob.scene.distributed_load is not None


#: largest resolutions built for scenes whose energy needs positions (dipole, distributed load):
#: their Hessian is dense and its symbolic construction grows like n³
MAX_POSITIONAL = {"lgl": 41, "midpoint": 50}


def _colloc(name, mode, transcription, elements, degree=10, jit=False, only_paper=False):
    opts = SolverOptions(transcription=transcription, elements=elements, degree=degree,
                         method="fast" if mode in ("fast", "api") else mode, jit=jit,
                         ensure_stable=False)
    label = f"E={elements} d={degree}" if transcription == "lgl" else f"N={elements}"

    n_nodes = elements * degree + 1 if transcription == "lgl" else elements + 1

    def applies(p):
        if only_paper and not p.name.startswith(("paper", "elastica")):
            return False
        return not (_needs_positions(p) and n_nodes > MAX_POSITIONAL[transcription])
    return Method(name, label, False, lambda p: _Collocation(p, opts, mode), applies)


def default_methods(quick: bool = False) -> List[Method]:
    """The benchmarked configurations (``quick``: a subset for smoke runs, ~10× cheaper)."""
    if quick:
        lgl = [(1, 8), (1, 12), (4, 10)]
        mid = [25, 100, 400]
        tols = (1e-4, 1e-6, 1e-8, 1e-10)
    else:
        lgl = [(1, 6), (1, 8), (1, 10), (1, 12), (1, 14), (1, 16), (1, 20), (2, 10), (4, 10),
               (8, 10), (16, 8)]
        mid = [25, 50, 100, 200, 400, 800, 1600]
        tols = BVP_TOLS
    out: List[Method] = []
    out += [_colloc("lgl-fast", "fast", "lgl", e, d) for e, d in lgl]
    out += [_colloc("midpoint-fast", "fast", "midpoint", n) for n in mid]
    out += [_colloc("lgl-newton", "newton", "lgl", e, d) for e, d in ([(1, 12)] if quick else [(1, 12), (4, 10)])]
    out += [_colloc("lgl-ipopt", "ipopt", "lgl", e, d) for e, d in ([(1, 12)] if quick else [(1, 12), (4, 10)])]
    out += [_colloc("midpoint-ipopt", "ipopt", "midpoint", n) for n in ([25, 100] if quick else [25, 100, 400, 1600])]
    out += [_colloc("api-fast", "api", "lgl", 1, 12)]
    if not quick:
        out += [_colloc("lgl-fast-jit", "fast", "lgl", e, d, jit=True, only_paper=True) for e, d in [(1, 12), (2, 10)]]
    for e, d in ([(1, 8), (1, 12)] if quick else [(1, 6), (1, 8), (1, 10), (1, 12), (2, 10), (4, 10)]):
        out.append(Method("numpy-floor", f"E={e} d={d}", False,
                          (lambda e_, d_: lambda p: _Floor(p, e_, d_))(e, d),
                          lambda p: p.uniform and p.scene.distributed_load is None))
    out.append(Method("shooting", "rtol=1e-12", False, lambda p: _Shooting(p),
                      lambda p: p.uniform and p.reference_kind == "closed_form"))
    for tol in tols:
        out.append(Method("solve_bvp", f"tol={tol:g}", True, (lambda t: lambda p: _SolveBVP(p, t))(tol)))
    return out


def _row(prob, method, runner, error, times, build, ok, why=""):
    return {"problem": prob.name, "method": method.name, "label": method.label,
            "n": int(getattr(runner, "n", 0)) if runner is not None else 0,
            "error": float(error), "time_s": float(np.median(times)) if len(times) else float("nan"),
            "time_min_s": float(np.min(times)) if len(times) else float("nan"),
            "build_s": float(build), "peer": bool(method.peer), "converged": bool(ok),
            "note": "; ".join(x for x in (getattr(runner, "note", ""), why) if x)}


def run_one(prob: Problem, method: Method, repeats: int = 15) -> Dict[str, object]:
    """Build, cold-solve, time ``repeats`` warm re-solves and measure the error of one method."""
    ref = prob.reference_tip()
    t0 = time.perf_counter()
    try:
        runner = method.make(prob)
    except Exception as exc:  # a method that cannot be built is reported, not fatal
        return _row(prob, method, None, np.inf, [], time.perf_counter() - t0, False,
                    f"build failed: {type(exc).__name__}: {exc}")
    build = time.perf_counter() - t0
    tip, warm, ok = runner.cold(prob.scene, prob.guess)
    build = getattr(runner, "build_s", build)
    err = _tip_error(tip, ref) if ok else np.inf
    if not ok:
        return _row(prob, method, runner, err, [], build, False, "cold solve failed")
    scenes = [prob.perturb(prob.scene, perturbation(k)) for k in range(repeats)] + [prob.scene]
    params = [runner.params(s) for s in scenes]
    times = []
    gc_was = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        for k, prm in enumerate(params):
            t = time.perf_counter()
            tip, new, good = runner.solve(prm, warm)
            dt = time.perf_counter() - t
            if k < repeats:
                times.append(dt)
            ok = ok and bool(good)
            if good:
                warm = new
    finally:
        if gc_was:
            gc.enable()
    err = max(err, _tip_error(tip, ref)) if good else np.inf
    return _row(prob, method, runner, err, times, build, ok)


def run_problem(prob: Problem, methods: Sequence[Method], repeats: int = 15,
                progress: bool = False) -> List[Dict[str, object]]:
    """All applicable methods on one problem (sequentially: timings are not disturbed)."""
    from tqdm import tqdm
    todo = [m for m in methods if m.applies(prob)]
    bar = tqdm(todo, desc=prob.name, file=sys.stderr, disable=not (progress and sys.stderr.isatty()),
               leave=False)
    return [run_one(prob, m, repeats) for m in bar]


def _run_problem_task(args):
    name, quick, repeats = args
    return run_problem(PROBLEMS[name], default_methods(quick), repeats)


def _reference_task(name):
    return PROBLEMS[name].reference_tip()


def run_benchmark(names: Optional[Sequence[str]] = None, quick: bool = False, repeats: int = 15,
                  workers: int = 1) -> List[Dict[str, object]]:
    """The whole benchmark: references first (in parallel), then each problem.

    ``workers > 1`` runs problems in parallel processes (faster, but concurrent timings share the
    machine); the default 1 times one solve at a time.
    """
    names = list(names or PROBLEMS)
    refs = map_parallel(_reference_task, names, workers=max(workers, 2), desc="references")
    for n, r in zip(names, refs):  # seed the per-process cache with the parallel results
        P._REF_OVERRIDE[n] = tuple(r)
    rows: List[Dict[str, object]] = []
    if workers > 1:
        for chunk in map_parallel(_run_problem_task, [(n, quick, repeats) for n in names],
                                  workers=workers, desc="problems", chunksize=1):
            rows += chunk
    else:
        bar = _progress(len(names), "problems", None)
        for n in names:
            rows += run_problem(PROBLEMS[n], default_methods(quick), repeats)
            bar.update(1)
        bar.close()
    return rows


# -- reporting -------------------------------------------------------------------------------------
def format_table(rows, with_build: bool = True) -> str:
    """A fixed-width text table, one line per row."""
    head = f"{'problem':17s} {'method':15s} {'config':12s} {'n':>6s} {'error':>9s} {'time_ms':>9s}"
    if with_build:
        head += f" {'build_s':>8s}"
    head += "  peer  ok"
    lines = [head, "-" * len(head)]
    for r in rows:
        line = (f"{r['problem']:17s} {r['method']:15s} {r['label']:12s} {r['n']:6d} {r['error']:9.2e} "
                f"{1e3 * r['time_s']:9.4f}")
        if with_build:
            line += f" {r['build_s']:8.3f}"
        line += f"  {'yes' if r['peer'] else '   '}  {'ok' if r['converged'] else 'FAIL'}"
        if r.get("note"):
            line += f"  ({r['note']})"
        lines.append(line)
    return "\n".join(lines)


def _cheapest(rows, problem, method, max_error):
    cands = [r for r in rows if r["problem"] == problem and r["method"] == method and r["converged"]
             and r["error"] <= max_error and math.isfinite(r["time_s"])]
    return min(cands, key=lambda r: r["time_s"]) if cands else None


def target_summary(rows, accuracy: float = 1e-8) -> List[Dict[str, object]]:
    """Issue 4 item 3, per problem: the cheapest fast-path row with error ≤ ``accuracy``, the
    cheapest ``solve_bvp`` row at least as accurate (equal accuracy), the numpy floor on the same
    resolution, and the ratios."""
    out = []
    for prob in dict.fromkeys(r["problem"] for r in rows):
        fast = None
        for m in ("lgl-fast", "lgl-fast-jit"):
            c = _cheapest(rows, prob, m, accuracy)
            if c is not None and (fast is None or c["time_s"] < fast["time_s"]):
                fast = c
        if fast is None:
            out.append({"problem": prob, "fast": None})
            continue
        peer = _cheapest(rows, prob, "solve_bvp", max(fast["error"], accuracy))
        floor = next((r for r in rows if r["problem"] == prob and r["method"] == "numpy-floor"
                      and r["label"] == fast["label"]), None)
        out.append({
            "problem": prob, "fast": fast["method"] + " " + fast["label"], "fast_error": fast["error"],
            "fast_time_s": fast["time_s"], "meets_0.2ms": fast["time_s"] <= 2e-4,
            "solve_bvp": None if peer is None else peer["label"],
            "solve_bvp_time_s": None if peer is None else peer["time_s"],
            "speedup_vs_solve_bvp": None if peer is None else peer["time_s"] / fast["time_s"],
            "floor_time_s": None if floor is None else floor["time_s"],
            "fast_over_floor": None if floor is None else fast["time_s"] / floor["time_s"],
        })
    return out


def format_targets(summary) -> str:
    lines = [f"targets (tip error <= 1e-8): {'problem':17s} {'fast path':22s} {'error':>9s} {'ms':>8s} "
             f"{'solve_bvp':>12s} {'ms':>8s} {'speedup':>8s} {'floor ms':>9s} {'fast/floor':>10s}"]
    for s in summary:
        if s.get("fast") is None:
            lines.append(f"  {s['problem']:17s} no fast-path row reached 1e-8")
            continue
        f = lambda v, fmt: "-" if v is None else format(v, fmt)
        lines.append(
            f"  {s['problem']:17s} {s['fast']:22s} {s['fast_error']:9.1e} {1e3 * s['fast_time_s']:8.4f} "
            f"{f(s['solve_bvp'], '>12s')} {f(None if s['solve_bvp_time_s'] is None else 1e3 * s['solve_bvp_time_s'], '8.3f')} "
            f"{f(s['speedup_vs_solve_bvp'], '8.0f')} "
            f"{f(None if s['floor_time_s'] is None else 1e3 * s['floor_time_s'], '9.4f')} "
            f"{f(s['fast_over_floor'], '10.2f')}")
    return "\n".join(lines)
