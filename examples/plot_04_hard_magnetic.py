"""
A hard-magnetic cantilever, and soft against hard over the field angle
======================================================================

``configs/hard_magnetic_cantilever.yaml``: an NdFeB-filled silicone strip (20 × 5 × 1 mm,
μ0 M_r = 0.1 T) magnetised along its axis, in a 10 mT field across it (THEORY §9). The remanent
magnetisation rotates with the rod and the field twists it: θ'' = h_r sin(θ + β − φ).

The second panel turns a field of fixed strength through a full revolution for three dimensionless
rods: a soft rod responds to the field *axis* (period 180°), a hard one to its *direction*
(period 360°).
"""
import math
from dataclasses import replace
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import actuator_design as ad
from actuator_design.analysis.field_angle_response import field_angle_response
from actuator_design.model.profiles import constant_profile
from actuator_design.io.user_units import user_units
from actuator_design.viz.shape import plot_shape

ROOT = Path(ad.__file__).resolve().parents[1]
scene, options, raw = ad.load_scene(ROOT / "configs" / "hard_magnetic_cantilever.yaml")
units = user_units(scene, raw)
state = ad.solve(scene, options)
print(f"h_r = {scene.h_r:.4g}; tip = ({units.length(state.tip['x']):.3f}, "
      f"{units.length(state.tip['y']):.3f}) mm, stable: {state.stable}")

hard = replace(ad.default_scene(h=0.0), h_r=1.5, magnetization=constant_profile(0.0))
scenes = {"soft (h = 1.2)": ad.default_scene(h=1.2), "hard (h_r = 1.5)": hard,
          "both": replace(ad.default_scene(h=1.2), h_r=1.5, magnetization=constant_profile(0.0))}
phi = np.linspace(0.0, 2.0 * math.pi, 73)
response = field_angle_response(scenes, phi)

fig, (ax_shape, ax_angle) = plt.subplots(1, 2, figsize=(11.5, 4.6))
plot_shape(state, ax=ax_shape, units=units)
for label in scenes:
    ax_angle.plot(np.degrees(response.phi), np.degrees(response.tip_angle[label]), label=label)
ax_angle.set_xlabel("field angle φ / deg")
ax_angle.set_ylabel("tip angle θ(1) / deg")
ax_angle.legend(fontsize=8)
ax_angle.grid(alpha=0.3)
fig.tight_layout()
