"""
A loading path up and back: snaps and hysteresis
================================================

A quasi-static loading path follows the state a real rod is in as a load is ramped slowly: here the
transverse-field cantilever (h = 1.5, φ = 90°) with its tip load ramped from 1.5 down to −1.5 and
back to 1.5. Buckled up, the rod holds against a downward load until its branch folds, then snaps to the
mirror state; on the way back it snaps again at the mirror fold — a hysteresis loop, whose width
and released energies the path reports.
"""
import math

import actuator_design as ad
from actuator_design.continuation.loading import ramp
from actuator_design.viz.loading import path_figure

scene = ad.default_scene(h=1.5, phi=math.pi / 2, p=1.5)
path = ad.follow_path(scene, schedule=ramp("p", 1.5, -1.5, back=True))
for jump in path.jumps:
    print(f"snap at p = {jump.param:.5f}: energy released {jump.energy_released:.4g} B0/l")
print(f"hysteresis loop of width {path.hysteresis['width']:.5f} in p, area {path.hysteresis['area']:.5f}")

# %%
path_figure(path, title="tip load ramped down and back up: two snaps")
