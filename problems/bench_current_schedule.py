"""Benchmark of the schedule over coil currents (issue 19 item 3): four waypoints, 40 time nodes,
two slew limits and both objectives on the two crossed Helmholtz pairs of
``configs/coils_schedule.yaml``. For each: the reported and the greedy schedule's duration (s) and
energy (J), whether the optimised one was reported, the compute time of its stages (greedy
currents, the optimal-control NLP, the verifying path), and the whole against the forward solve
of the scene (the peer, timed in the same run). Not a test (it measures time)::

    python problems/bench_current_schedule.py [--nodes 40] [--json rows.json]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from actuator_design.hardware.current_map import at_weights
from actuator_design.schedules.current_schedule import current_schedule
from actuator_design.config import load_scene
from actuator_design.equilibrium.pipeline import solve

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "coils_schedule.yaml"
WAYPOINTS = [(0.98, 0.18), (0.95, 0.29), (0.90, 0.40), (0.83, 0.5)]
SLEWS = (20.0, 5.0)  # A/s


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nodes", type=int, default=40, help="time nodes (default 40)")
    parser.add_argument("--json", metavar="FILE", help="write the rows to this file")
    args = parser.parse_args(argv)
    scene, options = load_scene(CONFIG)[:2]
    t0 = time.perf_counter()
    solve(at_weights(scene, np.ones(len(scene.field.sources))), options)
    forward = time.perf_counter() - t0
    print(f"forward solve (peer): {forward:.2f} s; {len(WAYPOINTS)} waypoints, {args.nodes} nodes")
    print(f"{'slew':>8} {'objective':>9} {'used':>5} {'T / s':>8} {'T greedy':>9} {'E / J':>8} {'E greedy':>9} "
          f"{'greedy s':>8} {'NLP s':>6} {'verify s':>8} {'total s':>7} {'x fwd':>6}")
    rows = []
    for slew in SLEWS:
        for objective in ("time", "energy"):
            res = current_schedule(scene, WAYPOINTS, slew, objective=objective, nodes=args.nodes, options=options)
            tm = res.timings
            row = {"slew_A_per_s": slew, "objective": objective, "success": res.success, "optimal": res.optimal,
                   "duration_s": res.duration, "greedy_duration_s": res.greedy_duration, "energy_J": res.energy,
                   "greedy_energy_J": res.greedy_energy, "timings_s": tm, "forward_s": forward,
                   "ratio": tm.get("total", float("nan")) / forward, "message": res.message}
            rows.append(row)
            print(f"{slew:>4g} A/s {objective:>9} {'yes' if res.optimal else 'no':>5} {res.duration:>8.4f} "
                  f"{res.greedy_duration:>9.4f} {res.energy:>8.4g} {res.greedy_energy:>9.4g} "
                  f"{tm.get('greedy', 0):>8.2f} {tm.get('solve', 0):>6.2f} {tm.get('verify', 0):>8.2f} "
                  f"{tm.get('total', 0):>7.2f} {row['ratio']:>6.1f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0 if all(r["success"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
