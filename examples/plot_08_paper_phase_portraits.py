"""
Paper: phase portraits
======================

(θ, θ') portraits with the level lines of the first integral H and every equilibrium's trajectory
(stable solid, unstable dashed), as in the paper's phase-diagram figures: the field-free elastica at
p = 55 (above p_crit^(2) ≈ 51: five equilibria) and the transverse field at h = 6 (between
h_crit^(3) and h_crit^(4): the straight rod and modes 1–3 with their mirrors).
"""
import math

import actuator_design as ad
from actuator_design.analysis.phase import phase_portrait
from actuator_design.viz.phase import phase_figure

options = ad.SolverOptions(elements=10, degree=16)
elastica = phase_portrait(ad.default_scene(h=0.0, phi=0.0, p=55.0), None, options,
                          theta_range=(-5.5, 2.5))
transverse = phase_portrait(ad.default_scene(h=6.0, phi=math.pi / 2, p=0.0), None, options)
for name, portrait in (("elastica, p = 55", elastica), ("transverse, h = 6", transverse)):
    print(f"{name}: {len(portrait.trajectories)} equilibria, "
          f"{sum(t.stable for t in portrait.trajectories)} stable")

# %%
phase_figure([elastica, transverse])
