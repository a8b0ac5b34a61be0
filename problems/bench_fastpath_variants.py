"""Which Newton implementation is fastest for warm re-solves? (issue 4, item 3)

Usage::

    .venv/bin/python problems/bench_fastpath_variants.py [--elements 1 --degree 12] [--repeats 200]

Same scene (the paper's transverse case, φ = π/2, h = 1.5), same LGL collocation system, same warm
starts (the previous solution, parameter h wobbled by 1e-3 … 4e-3), same convergence tolerance
(residual ≤ 1e-10); prints the median time per solve and the tip error against THEORY §6:

* ``classic``     — ``f_grad_hess(z, p)`` through CasADi's Python call + ``numpy.linalg.solve``
                    (what ``method="newton"`` cost before the fast path);
* ``rootfinder``  — CasADi ``rootfinder`` ("newton" and "kinsol") on ∇Ê = 0, exact Jacobian;
* ``fused-k``     — one CasADi function doing k full Newton steps with a symbolic dense solve;
* ``fast``        — :meth:`EquilibriumSolver.solve_fast` (buffered VM evaluation, LAPACK,
                    Hessian reuse), and with ``jit=True`` (compiled C);
* ``numpy-floor`` — plain dense numpy Newton on the same system (benchmarks/floor.py).
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

import casadi as ca
import numpy as np

from actuator_design.benchmarks.floor import NumpyNewton
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reference.closed_forms import transverse_mode
from actuator_design.model.scene import default_scene
from actuator_design.equilibrium.solver import EquilibriumSolver


def _median_time(step, states, repeats):
    times = []
    z = states[0]
    for k in range(repeats):
        t = time.perf_counter()
        z = step(z, k)
        times.append(time.perf_counter() - t)
    return statistics.median(times), z


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--elements", type=int, default=1)
    ap.add_argument("--degree", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=200)
    ap.add_argument("--no-jit", action="store_true", help="skip the compiled variants")
    args = ap.parse_args(argv)

    h0 = 1.5
    base = default_scene(h=h0, phi=0.5 * math.pi)
    opts = SolverOptions(elements=args.elements, degree=args.degree, method="fast")
    t0 = time.perf_counter()
    sv = EquilibriumSolver(base, opts)
    build_vm = time.perf_counter() - t0
    nodes = sv.transcription.nodes
    scenes = [base.with_values(h=h0 * (1 + 1e-3 * ((k % 4) + 1) * (-1) ** k)) for k in range(args.repeats)]
    params = [sv.parameter_vector(s) for s in scenes]
    P0 = sv.parameter_vector(base)
    z0 = sv.solve_fast(0.8 * np.sin(0.5 * math.pi * nodes), P0).z
    ref = transverse_mode(h0, 1)
    mass = sv.transcription.mass[1:]
    tol = 1e-10

    def tip_error(z):
        _, th, x, y = sv.summary(z, P0)
        return max(abs(x - 1 - ref.u1), abs(y - ref.v1), abs(th - ref.beta))

    rows = []

    def record(name, step, build):
        med, _ = _median_time(step, [z0], args.repeats)
        zf = step(z0, -1)
        rows.append((name, med, tip_error(zf), build))

    # classic: CasADi call + numpy solve
    fgh = sv.f_grad_hess

    def classic(z, k):
        P = P0 if k < 0 else params[k]
        z = z.copy()
        for _ in range(30):
            _, g, H = fgh(z[1:], P)
            g = np.asarray(g).ravel()
            if np.max(np.abs(g / mass)) <= tol:
                break
            z[1:] -= np.linalg.solve(np.asarray(H), g)
        return z
    record("classic (Function call + numpy)", classic, build_vm)

    # CasADi rootfinder on the gradient
    zr, Ps = ca.SX.sym("zr", nodes.size - 1), ca.SX.sym("P", P0.size)
    g_sym = sv.f_grad_hess(zr, Ps)[1]
    G = ca.Function("G", [zr, Ps], [g_sym])
    for plugin in ("newton", "kinsol"):
        try:
            t = time.perf_counter()
            rf = ca.rootfinder(f"rf_{plugin}", plugin, G, {"abstol": tol * float(np.min(mass))}
                               if plugin == "newton" else {"abstol": tol * float(np.min(mass))})
            b = time.perf_counter() - t

            def rfstep(z, k, rf=rf):
                P = P0 if k < 0 else params[k]
                out = np.asarray(rf(z[1:], P)).ravel()
                return np.concatenate(([z[0]], out))
            record(f"rootfinder {plugin}", rfstep, b)
        except Exception as exc:  # a plugin may be missing from the CasADi build
            print(f"rootfinder {plugin}: {type(exc).__name__}: {exc}", file=sys.stderr)

    # fused k Newton steps in one CasADi call (symbolic dense solve)
    for kk in (2, 3):
        zc = zr
        for _ in range(kk):
            _, gk, Hk = sv.f_grad_hess(zc, Ps)
            zc = zc - ca.solve(Hk, gk)
        t = time.perf_counter()
        fused = ca.Function(f"fused{kk}", [zr, Ps], [zc])
        b = time.perf_counter() - t

        def fstep(z, k, fused=fused):
            P = P0 if k < 0 else params[k]
            return np.concatenate(([z[0]], np.asarray(fused(z[1:], P)).ravel()))
        record(f"fused {kk} Newton steps (VM)", fstep, b)

    record("fast (buffer + LAPACK, VM)", lambda z, k: sv.solve_fast(z, P0 if k < 0 else params[k]).z,
           build_vm)
    if not args.no_jit:
        t = time.perf_counter()
        svj = EquilibriumSolver(base, SolverOptions(elements=args.elements, degree=args.degree, jit=True))
        bj = time.perf_counter() - t
        record(f"fast (buffer + LAPACK, {svj.jit_note or 'JIT'})",
               lambda z, k: svj.solve_fast(z, P0 if k < 0 else params[k]).z, bj)

    nn = NumpyNewton(args.elements, args.degree)
    preps = [nn.prepare(s) for s in scenes]
    prep0 = nn.prepare(base)
    record("numpy floor (dense numpy Newton)",
           lambda z, k: nn.solve(z, prep0 if k < 0 else preps[k], tol=tol)[0], 0.0)

    print(f"# warm re-solves, transverse h=1.5, LGL E={args.elements} d={args.degree}, "
          f"{args.repeats} repeats, residual tol {tol:g}")
    print(f"{'variant':44s} {'median_us':>10s} {'tip_error':>10s} {'build_s':>8s}")
    for name, med, err, b in rows:
        print(f"{name:44s} {1e6 * med:10.1f} {err:10.2e} {b:8.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
