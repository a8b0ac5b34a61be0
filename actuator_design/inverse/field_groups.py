"""The field is one physical field (THEORY §5, §9): h ∝ H, h_pos ∝ H and h_r ∝ H, so a design that
varies h moves every other group the field drives with it, in the design NLPs (:mod:`actuator_design.inverse.nlp`,
:mod:`actuator_design.robust.design_robust`) and in the forward scenes they stand for. The groups are read from the
parameter lens (every slot whose ``field_power`` f ≠ 0 besides the field magnitude, ∝ (h/h0)^f), so
a plug-in term's field-driven values follow too."""
from __future__ import annotations

import casadi as ca

from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens

__all__ = ["couple_field_groups", "coupled_scene", "remanence_only"]



def couple_field_groups(P, P0, h, slices) -> None:
    """Write the groups the field drives besides h into the NLP parameter vector ``P`` (CasADi SX,
    in place): g = h·g0/h0 for g in (h_r, h_pos), with g0, h0 the base scene's values in ``P0``
    (unchanged where h0 = 0)."""
    h0 = P0[slices["h"]]
    for p, f in lens.field_groups(magnitude=False):
        g = p.slot
        if g in slices:
            moved = h * P0[slices[g]] / h0 if f == 1 else (h / h0) ** f * P0[slices[g]]
            P[slices[g]] = ca.if_else(h0 > 0, moved, P0[slices[g]])


def remanence_only(scene: Scene) -> bool:
    """A rod with remanence and no soft coupling (h_r > 0, h = 0): the field acts through h_r alone,
    so it has no h to design (THEORY §9)."""
    return lens.remanent_group(scene, stored=True) > 0 and not scene.h > 0


def coupled_scene(base: Scene, sc: Scene) -> Scene:
    """``sc`` (``base`` with a designed h) with h_r and h_pos moved with h like the field they share,
    as :func:`couple_field_groups` does in the NLP."""
    if not base.h > 0:
        return sc

    return lens.scale_field(sc, sc.h / base.h, source=base, magnitude=False)
