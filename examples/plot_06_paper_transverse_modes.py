"""
Paper: buckling in a transverse field, modes 1–3
================================================

θ'' + h² sin 2θ = 0 (φ = 90°, p = 0; THEORY §6). The straight rod is continued in h ∈ [0, 6.5]; its
branch points are located on the branch and the buckled modes bifurcating there are followed by
branch switching. The branch points are compared with the closed form
h_crit^(m) = (2m − 1) π / (2√2) (the paper's h_crit^(1) ≃ 1.11) and each mode's tip angle with the
elliptic closed form (thin black).
"""
import math

import numpy as np

import actuator_design as ad
from actuator_design.reference.closed_forms import critical_field_transverse, transverse_mode
from actuator_design.viz.landscape import plot_branches

res = ad.continue_branch(ad.default_scene(h=0.0, phi=math.pi / 2), "h", 0.0, 6.5, switch=True,
                         ds_max=0.1)
for bp in res.branch.branch_points:
    m = min(range(1, 6), key=lambda k: abs(critical_field_transverse(k) - bp.value))
    print(f"branch point h = {bp.value:.8f}; closed form h_crit^({m}) = {critical_field_transverse(m):.8f}")

reference = []
for m in (1, 2, 3):
    hh = np.linspace(critical_field_transverse(m) + 1e-6, 6.5, 200)
    beta = np.array([transverse_mode(h, m).beta for h in hh])
    reference += [(hh, beta, f"closed form, mode {m}" if m == 1 else None), (hh, -beta, None)]

# %%
plot_branches([res.branch] + res.secondary, param_label="field h", reference=reference,
              title="transverse field: tip angle against h, modes 1-3")
