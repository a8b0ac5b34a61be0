"""Benchmark of the optimal-control schedule (issue 19 item 3) against the greedy one, in one run.

The shipped example's four waypoints (``configs/study_design_schedule.yaml``), three pairs of
actuator limits (field-group rate ḣ per second, rotation rate) and both objectives. For each: the
optimised and the greedy schedule's duration T (s) and field effort ∫h² dt (h² s), whether the
optimised one was reported (verified and no worse), and the compute time of each, with their
ratio (the greedy schedule is the peer: it is computed once per run and timed here). The issue's
budget is 30 s for 4 waypoints and 40 nodes on 2 cores. Not a test (it measures time)::

    python problems/bench_schedule_ocp.py [--nodes 40] [--json rows.json]
"""
from __future__ import annotations

import argparse
import json
import math
import time

from actuator_design.schedules.schedule import field_schedule
from actuator_design.schedules.schedule_ocp import RateLimits, optimal_schedule

WAYPOINTS = [(0.985, 0.161), (0.935, 0.326), (0.861, 0.465), (0.782, 0.563)]
#: (ḣ_max per second, rotation rate in deg/s)
LIMITS = [(1.0, 30.0), (0.5, 90.0), (5.0, 10.0)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nodes", type=int, default=40, help="time nodes (default 40)")
    parser.add_argument("--json", metavar="FILE", help="write the rows to this file")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    greedy = field_schedule(WAYPOINTS)
    greedy_s = time.perf_counter() - t0
    if not greedy.success:
        print(f"no greedy schedule: {greedy.message}")
        return 1
    rows = []
    print(f"greedy schedule: {greedy_s:.2f} s to compute; {args.nodes} nodes for the optimal-control problem")
    print(f"{'limits':>16} {'objective':>9} {'used':>5} {'T / s':>8} {'T greedy':>9} {'effort':>8} "
          f"{'greedy':>8} {'compute / s':>11} {'ratio':>6}")
    for h_rate, rot in LIMITS:
        for objective in ("time", "energy"):
            t1 = time.perf_counter()
            res = optimal_schedule(WAYPOINTS, RateLimits(h_rate, math.radians(rot)), objective=objective,
                                   nodes=args.nodes, greedy=greedy)
            spent = time.perf_counter() - t1
            row = {"h_rate_per_s": h_rate, "rotation_deg_per_s": rot, "objective": objective,
                   "optimal": res.optimal, "success": res.success, "time_s": res.time_s,
                   "greedy_time_s": res.greedy_time_s, "effort_h2_s": res.effort, "greedy_effort_h2_s": res.greedy_effort,
                   "compute_s": spent, "greedy_compute_s": greedy_s, "ratio": spent / greedy_s, "status": res.status}
            rows.append(row)
            print(f"{h_rate:>6g}/s {rot:>5g}deg/s {objective:>9} {'yes' if res.optimal else 'no':>5} {res.time_s:>8.4f} "
                  f"{res.greedy_time_s:>9.4f} {res.effort:>8.4g} {res.greedy_effort:>8.4g} {spent:>11.2f} "
                  f"{spent / greedy_s:>6.1f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0 if all(r["success"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
