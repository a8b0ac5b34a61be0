"""Paper, transverse field (φ = 90°, p = 0): field–tip-angle diagram, first three modes, h_crit^(m).

θ'' + h² sin 2θ = 0 (THEORY §6). The straight rod is continued in h ∈ [0, 6.5] (so
h_crit^(3) < 6.5 < h_crit^(4)); its branch points are located on the collocation branch and the
bifurcating modes are followed by branch switching. Printed: the branch points against
(2m − 1)π/(2√2) and the paper's h_crit^(1) ≃ 1.11, and each mode's tip angle against the elliptic
closed form. Saves ``paper_transverse_modes.png``.

Run: ``python problems/paper_transverse_modes.py [--out DIR]``.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from actuator_design.continuation.follow import continue_branch
from actuator_design.io.save import write_output_set
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.model.scene import default_scene
from actuator_design.viz.landscape import plot_branches
from actuator_design.viz.style import png_bytes

PUBLISHED = {1: 1.11}  # the paper's text quotes h_crit^(1) ≃ 1.11 and the formula (2m − 1)π/(2√2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="directory for the figure (default: current)")
    args = ap.parse_args(argv)
    res = continue_branch(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0, 6.5, switch=True, ds_max=0.1)
    print(f"{'mode':5s} {'branch point (collocation)':>27s} {'(2m-1)pi/(2 sqrt 2)':>20s} {'published':>10s}")
    for m, bp in enumerate(res.branch.branch_points, start=1):
        ref = critical_field_transverse(m)
        print(f"{m:5d} {bp.value:27.12f} {ref:20.12f} {PUBLISHED.get(m, float('nan')):10.2f}"
              f"   (difference {bp.value - ref:+.1e})")
    print("tip angle |θ(1)| on each mode against the elliptic closed form (max over the branch):")
    refs = []
    for m in (1, 2, 3):
        hs = [h for b in res.secondary if f"{critical_field_transverse(m):.9g}"[:6] in b.origin for h in b.lam]
        branch = [b for b in res.secondary if f"{critical_field_transverse(m):.9g}"[:6] in b.origin]
        err = max(float(np.max(np.abs(np.abs(b.tip_angle) - [transverse_mode(h, m).beta for h in b.lam])))
                  for b in branch)
        stable = all(np.all(b.morse_index == m - 1) for b in branch)
        print(f"  mode {m}: {sum(len(b) for b in branch)} points, h up to {max(hs):.3g}, max error "
              f"{err:.1e} rad, Morse index {m - 1} along the branch: {stable}")
        hh = np.linspace(critical_field_transverse(m) + 1e-6, 6.5, 200)
        beta = np.array([transverse_mode(h, m).beta for h in hh])
        refs += [(hh, beta, f"closed form, mode {m}" if m == 1 else None), (hh, -beta, None)]
    ax = plot_branches([res.branch] + res.secondary, param_label="field h",
                       title="transverse field: first three modes", reference=refs)
    path, = write_output_set(Path(args.out), {"paper_transverse_modes.png": png_bytes(ax)})
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
