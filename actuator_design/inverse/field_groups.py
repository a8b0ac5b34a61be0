"""The field is one physical field (THEORY §5, §9): h ∝ H, h_pos ∝ H and h_r ∝ H, so a design that
varies h moves every other group the field drives with it, in the design NLPs (:mod:`actuator_design.inverse.nlp`,
:mod:`actuator_design.robust.design_robust`) and in the forward scenes they stand for. The groups are read from the
parameter lens (every slot whose ``field_power`` f ≠ 0 besides the field magnitude, ∝ (h/h0)^f), so
a plug-in term's field-driven values follow too."""
from __future__ import annotations

import casadi as ca

from actuator_design.model.scene import Scene
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import term_class, write_keeps_terms

__all__ = ["couple_field_groups", "coupled_scene", "remanence_only"]



def _field_driven():
    """(lens parameter, f) of every slot driven by the field besides its magnitude (h_pos, h_r: f = 1,
    in registration order)."""
    out = {}
    for p in lens.parameters().values():
        if p.field_power and not p.field_magnitude and not p.per_point and p.slot not in out:
            out[p.slot] = p
    return [(p, p.field_power) for p in out.values()]


def couple_field_groups(P, P0, h, slices) -> None:
    """Write the groups the field drives besides h into the NLP parameter vector ``P`` (CasADi SX,
    in place): g = h·g0/h0 for g in (h_r, h_pos), with g0, h0 the base scene's values in ``P0``
    (unchanged where h0 = 0)."""
    h0 = P0[slices["h"]]
    for p, f in _field_driven():
        g = p.slot
        if g in slices:
            moved = h * P0[slices[g]] / h0 if f == 1 else (h / h0) ** f * P0[slices[g]]
            P[slices[g]] = ca.if_else(h0 > 0, moved, P0[slices[g]])


def remanence_only(scene: Scene) -> bool:
    """A rod with remanence and no soft coupling (h_r > 0, h = 0): the field acts through h_r alone,
    so it has no h to design (THEORY §9)."""
    return lens.remanent_group(scene) > 0 and not scene.h > 0


def coupled_scene(base: Scene, sc: Scene) -> Scene:
    """``sc`` (``base`` with a designed h) with h_r and h_pos moved with h like the field they share,
    as :func:`couple_field_groups` does in the NLP."""
    if not base.h > 0:
        return sc

    k = sc.h / base.h
    for p, f in _field_driven():
        value = p.get(base) * k ** f
        if p.term is None or term_class(p.term).present(sc) or write_keeps_terms(p, sc, value):
            sc = p.write(sc, value)
    return sc
