"""
A published experiment re-fitted: Zhao et al. (JMPS 2019)
=========================================================

The hard-magnetic cantilever of Zhao, Kim, Chester, Sharma & Zhao, "Mechanics of hard-magnetic
soft materials", J. Mech. Phys. Solids 124 (2019): L = 17.2 mm, t = 0.84 mm, magnetised along its
length (B_r = μ0 M_r = 0.143 T), in a uniform field **anti-parallel** to its magnetisation. Its
maximum deflections δ/L at 5, 7, 10, 15, 25 and 40 mT, digitised from the paper's figure (±0.01), are
in ``problems/data/zhao2019_cantilever.csv``; ``configs/fit_zhao2019.yaml`` fits one parameter,
Young's modulus E, and reports its 95 % interval and the rms residual.

The 5 mT point sits just above the buckling field (h_r = π²/4, THEORY §9), where the straight rod
loses stability and a small imperfection matters: a field a degree off anti-parallel, or E at either
end of its interval, changes δ/L there far more than at higher fields. The second panel shows that
sensitivity: the model's δ/L near 5 mT for a perfect rod and for fields tilted by 0.5°, 1° and 2°.
"""
import math
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import actuator_design as ad

ROOT = Path(ad.__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "problems"))
from zhao2019_refit import (IMPERFECTIONS_DEG, MU0, SIGMA, L, buckling_field_mT,  # noqa: E402
                            fitted, upward)

result = fitted()
E = result.parameters["youngs_modulus"]
rms = result.rms["tip_deflection"]  # mm, the data column's unit
bc = buckling_field_mT(result)
print(f"E = {E['value'] / 1e6:.4f} MPa, 95 % interval [{E['ci'][0] / 1e6:.4f}, {E['ci'][1] / 1e6:.4f}] MPa")
print(f"rms residual = {rms:.4f} mm = {rms * 1e-3 / L:.4f} L (data ±{SIGMA} L)")
print(f"buckling field B_c = {bc['value']:.3f} mT [{bc['ci'][0]:.3f}, {bc['ci'][1]:.3f}]")

# %%
# Left: data and fitted model. Right: δ/L near the buckling field for a perfect rod and for a
# field tilted by a small angle towards the side the rod buckled to.
B_data = result.data.columns["field"] * MU0 * 1e3
delta = result.data.columns["tip_deflection"] / L
fig, (ax, ax_s) = plt.subplots(1, 2, figsize=(11.5, 4.4))
for g in result.curves["groups"]:
    ok = g["stable"]
    ax.plot(g["x"][ok] * MU0 * 1e3, g["y"]["tip_deflection"][ok] / L, "-", color="C0",
            label=f"model, E = {E['value'] / 1e6:.3g} MPa")
ax.errorbar(B_data, delta, yerr=SIGMA, fmt="o", color="k", capsize=3, label="Zhao et al. 2019 (±0.01)")
ax.axvline(bc["value"], color="C3", ls=":", label=f"buckling field {bc['value']:.2f} mT")
ax.set_xlabel("field B / mT (anti-parallel to the magnetisation)")
ax.set_ylabel("maximum deflection δ/L")
ax.set_ylim(0, 1)
ax.legend(fontsize=8, loc="lower right")

fields = np.linspace(bc["value"] * 1.01, 8.0, 10)
for eps in (0.0,) + tuple(IMPERFECTIONS_DEG):
    start, ys = None, []
    for b in fields[::-1]:  # from the buckled side down towards B_c, warm-started
        got = upward(E["value"], float(b), 180.0 - eps, start)
        ys.append(np.nan if got is None else got[0])
        start = None if got is None else got[2]
    ax_s.plot(fields, ys[::-1], marker=".", label="perfect rod" if eps == 0 else f"field {eps:g}° off")
ax_s.errorbar(B_data[B_data < 8.5], delta[B_data < 8.5], yerr=SIGMA, fmt="o", color="k", capsize=3)
ax_s.axvline(bc["value"], color="C3", ls=":")
ax_s.set_xlabel("field B / mT")
ax_s.set_ylabel("maximum deflection δ/L")
ax_s.set_title("near the buckling field a small imperfection matters", fontsize=10)
ax_s.legend(fontsize=8)
fig.tight_layout()
