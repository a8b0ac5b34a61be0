"""
A physical strip in millimetres and millitesla
==============================================

``configs/isotropic_mre_strip.yaml``: a 30 × 10 × 1 mm silicone strip of carbonyl-iron spheres
(10 vol%), in a 40 mT field at 60°. The particles alone are isotropic; the slender body is easier to
magnetise along its axis (its own demagnetisation, THEORY §10), so the strip bends towards the
field. Results come back dimensionless (rod lengths, the field group h) and are shown here in the
YAML's units: mm, mT (μ0 H), J.
"""
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import actuator_design as ad
from actuator_design.io.user_units import user_units
from actuator_design.viz.shape import plot_shape
from actuator_design.viz.units import parameter_axis

ROOT = Path(ad.__file__).resolve().parents[1]
scene, options, raw = ad.load_scene(ROOT / "configs" / "isotropic_mre_strip.yaml")
units = user_units(scene, raw)

state = ad.solve(scene, options)
print(f"tip = ({units.length(state.tip['x']):.3f}, {units.length(state.tip['y']):.3f}) mm "
      f"at mu0 H = {units.field_mT(scene.h):.3g} mT; stable: {state.stable}")

# %%
# The tip's rise against the field: continuation in h, drawn against μ0 H in mT.
branch = ad.continue_branch(scene, "h", units.h_from_mT(0.0), units.h_from_mT(120.0)).branch
fig, (ax_shape, ax_tip) = plt.subplots(1, 2, figsize=(11, 4.4))
plot_shape(state, ax=ax_shape, units=units)
ax_tip.plot(branch.lam, np.array([units.length(y) for y in branch.tips[:, 2]]))
ax_tip.set_ylabel("tip deflection y / mm")
parameter_axis(ax_tip, "h", units, "h")
ax_tip.grid(alpha=0.3)
fig.tight_layout()
