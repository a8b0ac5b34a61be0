"""The plain forward solve as a registered analysis (one row per study point)."""
from __future__ import annotations

from actuator_design.equilibrium.pipeline import solve
from actuator_design.analysis.registration import register


@register("solve")
def run_solve(scene, options, **settings) -> dict:
    """One equilibrium: the ``solve --json`` contract without the shape (keeps study tables flat).

    A study whose only analysis is ``solve`` does not call this per point: it walks the grid's
    load rays (:mod:`actuator_design.study.walk`), with the same answer at each point."""
    if settings:
        raise ValueError(f"solve takes no settings, got {sorted(settings)}")
    out = solve(scene, options).to_dict()
    out.pop("shape")
    return out
