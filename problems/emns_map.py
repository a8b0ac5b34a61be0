"""A synthetic calibration map of an eight-coil electromagnetic navigation system, by magpylib.

Eight air-core solenoids (radius 25 mm, 30 mm long, 500 turns) lie in the rod's plane on a circle
of 60 mm about the workspace centre (10 mm along the rod), their axes pointing at it, 45° apart.
The map gives each coil's field per ampere on a grid of the workspace: x from −15 to 35 mm, y from
−25 to 25 mm (5 mm steps) and z = −5, 0, 5 mm, as ``x [mm], y [mm], z [mm], c<k>_bx [mT/A], ...``.

    python problems/emns_map.py configs/emns_8coil_map.csv

The map is what a lab's calibration would give; magpylib's field of the same coils is the
independent reference the tests compare the map's fit with.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from actuator_design.model.sources import CoilSource, magpylib_field

MU0 = 4e-7 * math.pi
CENTRE_MM = (10.0, 0.0)


def coils(current: float = 1.0, kind: str = "solenoid"):
    """The eight solenoids (SI), each carrying ``current`` A; ``kind="loop"``: each a single loop of
    500 turns at the solenoid's centre (a cheaper map for tests)."""
    out = []
    for k in range(8):
        a = k * math.pi / 4
        pos = (1e-3 * (CENTRE_MM[0] + 60.0 * math.cos(a)), 1e-3 * (CENTRE_MM[1] + 60.0 * math.sin(a)))
        out.append(CoilSource(kind, 0.025, pos, a + math.pi, current, turns=500,
                              length=0.030 if kind == "solenoid" else 0.0))
    return out


def grid(step_mm: float = 5.0, layers_mm=(-5.0, 0.0, 5.0)) -> np.ndarray:
    """The map's points, (n, 3) in mm."""
    xs = np.arange(-15.0, 35.0 + 1e-9, step_mm)
    ys = np.arange(-25.0, 25.0 + 1e-9, step_mm)
    return np.array([(x, y, z) for z in layers_mm for y in ys for x in xs])


def map_text(step_mm: float = 5.0, layers_mm=(-5.0, 0.0, 5.0), noise_mT_per_A: float = 0.0, seed: int = 0,
             kind: str = "solenoid", z_shift_mm: float = 0.0) -> str:
    """The CSV text of the map (B per ampere in mT/A), with Gaussian noise of that size if asked;
    ``z_shift_mm``: the field sampled that far above the points written (a map whose z = 0 is not
    the coils' plane of symmetry)."""
    pts = grid(step_mm, layers_mm)
    rng = np.random.default_rng(seed)
    cols = [pts]
    for c in coils(1.0, kind):
        b = magpylib_field([c], (pts + [0.0, 0.0, z_shift_mm]) * 1e-3) * MU0 * 1e3  # mT per A
        cols.append(b + noise_mT_per_A * rng.standard_normal(b.shape))
    table = np.column_stack(cols)
    head = ["x [mm]", "y [mm]", "z [mm]"] + [f"c{k + 1}_b{a} [mT/A]" for k in range(8) for a in "xyz"]
    lines = ["# eight-coil electromagnetic navigation system, field per ampere (problems/emns_map.py)",
             ", ".join(head)]
    lines += [", ".join(f"{v:.9g}" for v in row) for row in table]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    with open(sys.argv[1] if len(sys.argv) > 1 else "emns_8coil_map.csv", "w") as f:
        f.write(map_text())
