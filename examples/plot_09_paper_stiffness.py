"""
Paper: the actuator's stiffness against the field
=================================================

An axial field stiffens the rod against a transverse tip load. The low-load stiffness has the closed
form s(h) = 4h³ / (2h − √2 tanh(√2 h)) (THEORY §6; s(0) = 3, the cantilever's 3 B0/ℓ³). The tool's
tangent stiffness of the equilibrium, computed from the reduced Hessian, is drawn over h with the
closed form as reference.
"""
import numpy as np

import actuator_design as ad
from actuator_design.analysis.stiffness import stiffness_field_curve
from actuator_design.reference.closed_forms import lowload_stiffness
from actuator_design.viz.loading import stiffness_figure

curve = stiffness_field_curve(ad.default_scene(h=0.0, phi=0.0), h_values=np.linspace(0.0, 3.0, 13))
worst = max(abs(k - lowload_stiffness(h)) / lowload_stiffness(h)
            for h, k in zip(curve.h, curve.vertical))
print(f"largest relative difference to the closed form: {worst:.2e}")

# %%
stiffness_figure(curve, title="low-load tip stiffness against the axial field")
