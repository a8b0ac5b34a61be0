"""Which analyses know contact: ``solve`` (:mod:`actuator_design.contact.equilibrium`), ``path``
(:mod:`actuator_design.contact.path`), ``design --target-force``
(:mod:`actuator_design.contact.design`), ``design --target-tip`` for one pose (a rod
kept clear of the obstacles, :mod:`actuator_design.contact.clearance`), ``stiffness`` (by differences of contact solves),
``continue`` (the free branch up to its first touch, :mod:`actuator_design.continuation.follow`)
and ``validate`` do; the others would ignore a
scene's obstacles (a branch through them, a stiffness without the support) and refuse such a scene
in one line instead (issue 20: continuation and design with contact)."""
from __future__ import annotations

import functools

__all__ = ["refuse_contact", "no_contact"]


def refuse_contact(scene, what: str) -> None:
    """Raise ``ValueError`` naming ``what`` when ``scene`` has obstacles."""
    if getattr(scene, "obstacles", ()):
        raise ValueError(f"{what}: this scene has obstacles (contact), which only solve, path, stiffness, "
                         "continue (on from the first touch by a loading path) and design (--target-tip, one pose, or --target-force) "
                         "model so far; "
                         f"{what} would ignore them: remove scene.obstacles, or use solve")


def no_contact(what: str):
    """Decorator: :func:`refuse_contact` on the function's scene (its first argument or ``scene=``;
    a result's scene when given a result)."""
    def wrap(fn):
        @functools.wraps(fn)
        def inner(*args, **kwargs):
            for cand in (args[0] if args else None, kwargs.get("scene"), kwargs.get("target")):
                refuse_contact(getattr(cand, "scene", cand), what)
            return fn(*args, **kwargs)
        return inner
    return wrap
