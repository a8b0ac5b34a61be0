"""
One actuator, two poses
=======================

A rod is built once — its fibre layout fixed — and driven to each pose by the field alone:
``design --target-tip "0.3,0.5;0.6,0.2"``. The tool designs one shared α(s) and one field (h, φ)
per pose, each exact at its nominal field, held over the tolerance box and verified from rest,
plus a schedule that visits the poses in order.
"""
import actuator_design as ad
from actuator_design.viz.design import poses_figure

result = ad.design_poses([(0.3, 0.5), (0.6, 0.2)])
print("success:", result.success, "—", result.message)
for k, pose in enumerate(result.poses, 1):
    print(f"pose {k}: h = {pose.design['h']:.5g}, phi = {pose.design['phi']:.5g} rad, "
          f"tip = ({pose.achieved['x']:.4f}, {pose.achieved['y']:.4f}), verified {pose.verified}")

# %%
poses_figure(result)
