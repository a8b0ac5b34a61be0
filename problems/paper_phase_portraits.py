"""The paper's phase portraits (θ, θ') with the equilibria's trajectories highlighted.

Usage::

    .venv/bin/python problems/paper_phase_portraits.py [--out DIR]

1. Figure "phase diagram" of the paper (§4, low-field regime, 0-th order): the field-free
   cantilever elastica θ'' + p cos θ = 0 at p = 55 > p_crit^(2) ≈ 51, where the paper says five
   equilibria exist (four drawn). Checks printed: the number of equilibria, the first integral
   γ²/2 = p sin β (paper eq. 301) on every trajectory, and the spread of H along each.
2. Figure "bifurcation / phase diagram" (a) of the transverse case θ'' + h² sin 2θ = 0 for
   h_crit^(3) < h < h_crit^(4) (here h = 6): the straight rod and modes 1–3 with their mirrors;
   β = |θ(1)| and γ = θ'(0) of each mode against the elliptic-function closed form (THEORY §6),
   and the paper's rule that the curve of mode m meets the θ axis m times.

Figures go to DIR (default problems/output/paper_phase_portraits).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from actuator_design.analysis.phase import phase_portrait
from actuator_design.io.save import dumps_json, write_output_set
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.model.scene import default_scene
from actuator_design.viz.phase import phase_figure
from actuator_design.viz.style import png_bytes

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "problems" / "output" / "paper_phase_portraits"),
                    help="output directory for the figure and the data")
    args = ap.parse_args(argv)
    opts = SolverOptions(elements=10, degree=16)

    p = 55.0
    elastica = phase_portrait(default_scene(h=0.0, phi=0.0, p=p), None, opts, theta_range=(-5.5, 2.5))
    n = len(elastica.trajectories)
    print(f"1. Cantilever elastica, h = 0, p = {p:g} (paper: p > p_crit^(2) ~ 50.97 has five equilibria, "
          f"four drawn)")
    print(f"   computed: {n} equilibria ({sum(t.stable for t in elastica.trajectories)} stable)"
          + ("" if n == 5 else "  <-- DIFFERS from the paper's five"))
    for t in elastica.trajectories:
        rel = 0.5 * t.gamma ** 2 - p * math.sin(t.tip_angle)
        print(f"   gamma = {t.gamma:11.6f}, beta = theta(1) = {t.tip_angle:10.6f} rad, "
              f"gamma^2/2 - p sin(beta) = {rel:9.1e}, H spread {t.spread:.1e}, "
              + ("stable" if t.stable else f"unstable (index {t.morse_index})")
              + (", self-intersecting" if t.self_intersecting else ""))

    h = 6.0
    lo, hi = critical_field_transverse(3), critical_field_transverse(4)
    transverse = phase_portrait(default_scene(h=h, phi=0.5 * math.pi, p=0.0), None, opts)
    print(f"\n2. Transverse field, p = 0, h = {h:g} (h_crit^(3) = {lo:.6f} < h < h_crit^(4) = {hi:.6f}): "
          f"expected 7 equilibria (straight rod, modes 1-3 and mirrors)")
    print(f"   computed: {len(transverse.trajectories)} equilibria")
    for m in (1, 2, 3):
        mode = transverse_mode(h, m)
        hits = [t for t in transverse.trajectories if abs(abs(t.gamma) - mode.gamma) < 1e-4 * mode.gamma]
        for t in hits:
            print(f"   mode {m}: beta computed {abs(t.tip_angle):.12f}, closed form {mode.beta:.12f} "
                  f"(diff {abs(abs(t.tip_angle) - mode.beta):.1e}); gamma {t.gamma:+.10f} "
                  f"(closed form ±{mode.gamma:.10f}); meets the theta axis {t.crossings + 1} times "
                  f"(paper: m = {m}); " + ("stable" if t.stable else f"unstable (index {t.morse_index})"))
        if len(hits) != 2:
            print(f"   mode {m}: found {len(hits)} trajectories, expected 2  <-- DIFFERS")

    fig = phase_figure([elastica, transverse], titles=[
        f"cantilever elastica, h = 0, p = {p:g}: {n} equilibria (paper's phase diagram)",
        f"transverse field, h = {h:g}, p = 0: modes 1–3 and mirrors (paper's Fig. (a))"])
    png = png_bytes(fig, dpi=150)
    data = dumps_json({"elastica": elastica.to_dict(), "transverse": transverse.to_dict()}, indent=1) + "\n"
    out = Path(args.out)
    write_output_set(out, {"phase_portraits.png": png, "phase_portraits.json": data})
    print(f"\nwrote {out / 'phase_portraits.png'}, {out / 'phase_portraits.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
