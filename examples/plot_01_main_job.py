"""
The main job: a field that puts the tip where you want it
==========================================================

``actuator-design design --target-tip 0.3,0.5`` through the Python API: on the built-in
dimensionless cantilever (THEORY §5), find the field magnitude h, the field angle φ and — because a
uniform field alone cannot curl the rod past vertical — a fibre layout α(s) that put the tip at
(0.3, 0.5) rod lengths, as a stable state that holds over a lab's tolerances (field ±5 %, angle
±2°) and is reached from rest along a field schedule that the tool verifies by a loading path.
"""
import actuator_design as ad
from actuator_design.viz.design import design_figure

result = ad.design((0.3, 0.5))
print(result.message)
print(f"h = {result.design['h']:.6g}, phi = {result.design['phi']:.6g} rad")
print(f"tip = ({result.achieved['x']:.6f}, {result.achieved['y']:.6f}) rod lengths, error {result.error:.1e}")
print(f"schedule: {len(result.schedule)} steps, ending at phi = {result.schedule[-1]['phi']:.6g} rad")

# %%
# The figure ``design --out`` writes: the designed shape with the field as the schedule leaves it,
# the fibre layout, the schedule from zero field, and the tip's spread over the tolerance box.
design_figure(result)
