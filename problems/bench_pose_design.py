"""Benchmark of the design over a magnet's pose (issue 19 item 2), in one run.

Targets on the shipped stage scene (``configs/magnet_pose_design.yaml``): each is the tip that a
given pose of the magnet produces from rest (a forward ``solve`` on magpylib fitted with the magnet
there as a fixed magnet: the peer, timed in the same run), designed back from the configured pose
(25 mm, −15 mm, 90°). For each: the status, the designed pose, its move (each coordinate's move
over its half travel, squared and summed) against the given pose's (a least-move design never
moves more), whether first-order optimality holds, the forward solves, and the design's time as a
ratio to the peer's forward solve. The last target is off the band of tips the strip reaches
(unreachable; the nearest tip is reported). Not a test (it measures time)::

    python problems/bench_pose_design.py [--json rows.json]
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from actuator_design.hardware.pose_design import design_pose
from actuator_design.hardware.pose_problem import pose_problem, scene_at_pose
from actuator_design.config import load_scene
from actuator_design.equilibrium.pipeline import solve

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "magnet_pose_design.yaml"
#: poses ((x, y) mm, axis deg) whose tips are designed back; the last target is a tip moved off the band
GIVEN = [((22.0, -14.0), 110.0), ((30.0, -13.0), 60.0), ((15.0, -20.0), 140.0), ((35.0, -25.0), 30.0),
         ((20.0, -12.5), 95.0)]
OFF_BAND = (0.9, 0.4)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", metavar="FILE", help="write the rows to this file")
    args = parser.parse_args(argv)
    scene = load_scene(CONFIG)[0]
    length = scene.scales.length
    rows = []
    print(f"{'given (mm, deg)':>24} {'status':>11} {'designed (mm, deg)':>26} {'move given':>10} {'move':>8} "
          f"{'least':>5} {'solves':>6} {'design s':>8} {'forward s':>9} {'ratio':>6}")
    for given in GIVEN + [None]:
        if given is None:
            target, forward_s, given_move, label = OFF_BAND, math.nan, math.nan, f"off band {OFF_BAND}"
        else:
            (x, y), a = given
            t0 = time.perf_counter()
            fwd = solve(scene_at_pose(scene, (x * 1e-3, y * 1e-3), math.radians(a)))
            forward_s = time.perf_counter() - t0
            target = (fwd.tip["x"], fwd.tip["y"])
            _, prob = pose_problem(scene, target)
            v = np.array([(x - 25.0) * 1e-3 / length, (y + 15.0) * 1e-3 / length, math.radians(a - 90.0)])
            given_move, label = float(np.dot(prob.cost, v * v)), f"({x:g}, {y:g}), {a:g}"
        t0 = time.perf_counter()
        d = design_pose(scene, target)
        design_s = time.perf_counter() - t0
        row = {"given": label, "target": list(target), "status": d.status, "position_mm": [v * 1e3 for v in d.position],
               "axis_angle_deg": math.degrees(d.axis_angle), "move_given": given_move, "move": d.move,
               "least_move": d.least_move, "tip_error": d.tip_error, "solves": d.solves, "design_s": design_s,
               "forward_s": forward_s, "ratio": design_s / forward_s}
        rows.append(row)
        pose = f"({d.position[0] * 1e3:.3f}, {d.position[1] * 1e3:.3f}), {math.degrees(d.axis_angle):.2f}"
        print(f"{label:>24} {d.status:>11} {pose:>26} {given_move:10.4f} {d.move:8.4f} {str(d.least_move):>5} "
              f"{d.solves:6d} {design_s:8.2f} {forward_s:9.3f} {row['ratio']:6.0f}"
              + (f"  (miss {d.tip_error:.2g})" if d.status != "success" else ""))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
