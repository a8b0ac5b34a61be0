"""
Paper: the field-free cantilever's bifurcation diagram
======================================================

θ'' + p cos θ = 0, θ(0) = 0, θ'(1) = 0 (THEORY §5–6 with h = 0): every branch of the tip load
p ∈ [0, 60] against the tip angle, traced by continuation from all equilibria found at a few loads,
with every fold located. The paper's critical loads are p₁ ≈ 10.33 and p₂ ≈ 50.97 (between them
the rod has three equilibria); they are printed beside the computed ones.
"""
import actuator_design as ad
from actuator_design.viz.landscape import plot_branches

res = ad.critical_points(ad.default_scene(h=0.0, p=0.0), "p", (0.0, 60.0))
for fold in res.folds:
    print(f"fold at p = {fold['value']:.6f} (equilibria {fold['equilibria_below']} -> "
          f"{fold['equilibria_above']})")
print("paper: 10.33, 50.97")

# %%
plot_branches(res.branches, param_label="tip load p",
              title="field-free cantilever: load against tip angle")
