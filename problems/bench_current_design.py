"""Benchmark of the design over coil currents (issue 19 item 2), in one run.

Targets on the shipped two-pair scene (``configs/coils_two_pairs_design.yaml``): each is the tip
that given currents produce from rest (a forward ``solve`` on magpylib refitted there: the peer,
timed in the same run), designed back from the configured 2 A, 2 A. For each: the status, the
designed currents against the given ones, the power against theirs (a least-power design never
needs more), the SQP iterations, the forward solves, and the design's time as a ratio to the
peer's forward solve. The last target lies beyond max_power (unreachable; the binding limit is
named). Not a test (it measures time)::

    python problems/bench_current_design.py [--json rows.json]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from actuator_design.hardware.current_design import design_currents, scene_at_currents
from actuator_design.config import load_scene
from actuator_design.equilibrium.pipeline import solve

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "coils_two_pairs_design.yaml"
#: currents (A) whose tips are designed back; the last needs 224 W > max_power 200 W
GIVEN = [(0.2345, 3.3778), (3.8027, 0.5721), (2.0544, -3.4532), (4.6991, 6.1913), (0.6544, 6.5261),
         (-6.8854, -7.2521)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", metavar="FILE", help="write the rows to this file")
    args = parser.parse_args(argv)
    scene = load_scene(CONFIG)[0]
    rows = []
    print(f"{'given / A':>18} {'status':>11} {'designed / A':>20} {'W given':>8} {'W':>8} {'iter':>4} "
          f"{'solves':>6} {'design s':>8} {'forward s':>9} {'ratio':>6}")
    for given in GIVEN:
        given = np.array(given)
        t0 = time.perf_counter()
        fwd = solve(scene_at_currents(scene, given))
        forward_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        d = design_currents(scene, (fwd.tip["x"], fwd.tip["y"]))
        design_s = time.perf_counter() - t0
        row = {"given_A": given.tolist(), "status": d.status, "currents_A": list(d.currents),
               "power_given_W": float(2.5 * given[0] ** 2 + 2.0 * given[1] ** 2), "power_W": d.power,
               "iterations": d.iterations, "solves": d.solves, "design_s": design_s, "forward_s": forward_s,
               "ratio": design_s / forward_s, "limits_active": d.limits_active}
        rows.append(row)
        print(f"{np.array2string(given, precision=4):>18} {d.status:>11} "
              f"{np.array2string(np.array(d.currents), precision=4):>20} {row['power_given_W']:8.2f} "
              f"{d.power:8.2f} {d.iterations:4d} {d.solves:6d} {design_s:8.2f} {forward_s:9.3f} {row['ratio']:6.0f}"
              + (f"  ({', '.join(d.limits_active)})" if d.limits_active else ""))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
