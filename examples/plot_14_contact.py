"""
Contact: a guidewire tip in a bend, a strip in a channel
========================================================

Obstacles are frictionless unilateral constraints of the energy minimisation; their forces are the
constraints' multipliers. First a rod laid through a 70° bend of a lumen (a vessel, a catheter): it
presses on the inner wall of the arc and, with its tip, on the outer wall of the exit. Then a loading
path of a soft magnetic strip in a straight channel as the field turns from one wall to the other:
each touch-down and lift-off is located as an event (where the free rod just touches the wall).
"""
import math
from pathlib import Path

import actuator_design as ad
from actuator_design.viz.loading import path_figure
from actuator_design.viz.shape import plot_shape

bend = ad.Lumen(start=(-0.1, 0.0), angle=0.0, radius=0.06,
                pieces=(("straight", 0.3), ("arc", 0.5, math.radians(70)), ("straight", 0.6)))
rod = ad.solve(ad.Scene(field=None, obstacles=(bend,), contact_gap=0.01))
print(rod.message)
for point in rod.contact["points"]:
    if not point["weak"]:
        print(f"contact at s = {point['s']:.4f}: force ({point['force'][0]:.4f}, {point['force'][1]:.4f}) B0/l^2")

# %%
plot_shape(rod, title="a rod through a 70 deg bend: inner-wall and tip contacts")

# %%
# The strip in a channel 6 mm wide: the field (h = 1, 9.2 mT) switched on at -60° presses the tip on
# the lower wall, then turned to +60° lifts it off and lays it on the upper wall. The scene and its
# schedule are the shipped config's.
ROOT = Path(ad.__file__).resolve().parents[1]
scene, options, raw = ad.load_scene(ROOT / "configs" / "contact_channel_path.yaml")
path = ad.follow_path(scene, schedule=[{"h": 0.0, "phi": -math.pi / 3}, {"h": 1.0, "phi": -math.pi / 3},
                                       {"h": 1.0, "phi": math.pi / 3}])
for event in path.contact_events:
    print(f"{event['kind']} {'on' if event['kind'] == 'touch-down' else 'from'} {event['obstacle_text']} at h = {event['values']['h']:.6f}, "
          f"phi = {math.degrees(event['values']['phi']):.4f} deg")

# %%
path_figure(path, title="strip in a channel: touch-down, lift-off, touch-down")

# %%
# A gripper finger pressing an object: the field at which the strip of
# ``configs/contact_tip_on_floor.yaml``, loaded from rest, presses the floor with 50 µN — verified by
# a forward solve from rest and judged over the lab's tolerance box (field ±5 %, angle ±2°).
floor_scene, _, _ = ad.load_scene(ROOT / "configs" / "contact_tip_on_floor.yaml")
target = 50e-6 / floor_scene.scales.force  # 50 µN in the scene's force unit B0/l^2
grip = ad.design_contact_force(floor_scene, target, h_max=3.0)
mT = grip.h / floor_scene.h * 15.0  # the config's 15 mT is h = floor_scene.h
print(f"{grip.status}: mu0 H = {mT:.4f} mT presses with {grip.force * floor_scene.scales.force * 1e6:.3f} uN; "
      f"over the box {grip.box_force_range[0] * floor_scene.scales.force * 1e6:.2f} to "
      f"{grip.box_force_range[1] * floor_scene.scales.force * 1e6:.2f} uN")
