"""Soft against hard magnetic response over the field angle (issue 12 item 4; THEORY §5, §9).

Usage::

    .venv/bin/python problems/soft_vs_hard_field_angle.py [--out DIR]

Three rods in a uniform field of fixed strength turned through a full revolution: soft-magnetic
(h = 1.2, straight fibres), hard-magnetic (h_r = 1.5, magnetisation along the rod) and both together.
The soft response repeats every 180° (the fibres align with the field *axis*); the hard one every
360° and reverses when the field is turned over (the magnetisation aligns with the field
*direction*). Writes ``soft_vs_hard.png`` and ``soft_vs_hard.csv`` into DIR (default
problems/output/soft_vs_hard_field_angle) and prints the tip angle at a few field angles.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from actuator_design.analysis.field_angle_response import field_angle_response
from actuator_design.io.save import write_output_set
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import default_scene
from actuator_design.viz.materials import angle_response_figure


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).parent / "output" / "soft_vs_hard_field_angle"))
    args = ap.parse_args(argv)
    hard = replace(default_scene(h=0.0), h_r=1.5, magnetization=constant_profile(0.0))
    scenes = {"soft (h = 1.2)": default_scene(h=1.2),
              "hard (h_r = 1.5)": hard,
              "soft + hard": replace(hard, h=1.2)}
    phi = np.linspace(0.0, 2.0 * math.pi, 145)
    res = field_angle_response(scenes, phi)
    rows = ["phi_deg," + ",".join(f"tip_angle_deg[{k}]" for k in scenes)]
    rows += [f"{math.degrees(p)!r}," + ",".join(repr(math.degrees(res.tip_angle[k][i])) for k in scenes)
             for i, p in enumerate(phi)]
    written = write_output_set(args.out, {"soft_vs_hard.png": angle_response_figure(res),
                                          "soft_vs_hard.csv": "\n".join(rows) + "\n"})
    for deg in (45, 135, 225, 315):
        i = int(np.argmin(np.abs(np.degrees(phi) - deg)))
        print(f"phi = {deg:3d} deg: " + ", ".join(f"{k} {math.degrees(res.tip_angle[k][i]):+.2f} deg" for k in scenes))
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
