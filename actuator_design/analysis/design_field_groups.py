"""The field is one physical field (THEORY §5, §9): h ∝ H, h_pos ∝ H and h_r ∝ H, so a design that
varies h moves every other group the field drives with it, in the design NLPs (:mod:`.design_nlp`,
:mod:`.design_robust`) and in the forward scenes they stand for."""
from __future__ import annotations

from dataclasses import replace

import casadi as ca

from ..scene import Scene

__all__ = ["couple_field_groups", "coupled_scene", "remanence_only"]

#: the groups driven by the field besides h, each ∝ H (THEORY §5, §9)
_FIELD_DRIVEN = ("h_r", "h_pos")


def couple_field_groups(P, P0, h, slices) -> None:
    """Write the groups the field drives besides h into the NLP parameter vector ``P`` (CasADi SX,
    in place): g = h·g0/h0 for g in (h_r, h_pos), with g0, h0 the base scene's values in ``P0``
    (unchanged where h0 = 0)."""
    h0 = P0[slices["h"]]
    for g in _FIELD_DRIVEN:
        if g in slices:
            P[slices[g]] = ca.if_else(h0 > 0, h * P0[slices[g]] / h0, P0[slices[g]])


def remanence_only(scene: Scene) -> bool:
    """A rod with remanence and no soft coupling (h_r > 0, h = 0): the field acts through h_r alone,
    so it has no h to design (THEORY §9)."""
    return scene.h_r > 0 and not scene.h > 0


def coupled_scene(base: Scene, sc: Scene) -> Scene:
    """``sc`` (``base`` with a designed h) with h_r and h_pos moved with h like the field they share,
    as :func:`couple_field_groups` does in the NLP."""
    if not base.h > 0:
        return sc
    k = sc.h / base.h
    return replace(sc, h_r=base.h_r * k, h_pos=base.h_pos * k)
