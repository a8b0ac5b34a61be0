"""
Paper: how many equilibria, over field and load (axial field)
=============================================================

φ = 0: the number of equilibria (and of stable ones) over h² ∈ [0, 20] and p ∈ [0, 60] by the
vectorised shooting scan, with the critical curves p_crit^(k)(h²) — folds of the collocation NLP
continued in h² — drawn over it (the paper reads "p_crit ≃ 5 for h² = 20"). A coarse grid keeps the
example quick; ``problems/paper_multiplicity_map.py --n 200`` draws the full figure.
"""
import numpy as np

import actuator_design as ad
from actuator_design.continuation.critical import critical_curves
from actuator_design.analysis.multiplicity import multiplicity_map
from actuator_design.viz.landscape import plot_landscape_map

scene = ad.default_scene(h=0.0, p=0.0)
m = multiplicity_map(scene, "h2", np.linspace(0, 20, 41), "p", np.linspace(0, 60, 41), workers=1,
                     progress=False)
curves = critical_curves(scene, "p", "h2", (0.0, 60.0), (0.0, 20.0))
for c in curves:
    print(f"fold curve: p = {np.interp(0.0, c.mu, c.lam):.4f} at h2 = 0, "
          f"{np.interp(20.0, c.mu, c.lam):.4f} at h2 = 20")

# %%
plot_landscape_map(m, curves, title="axial field: number of equilibria")
