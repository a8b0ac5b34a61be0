"""A robust design is one the user can reach: when the design made for the whole tolerance box is not
reachable from zero field without a snap, the robust stage takes the design made for the largest
smaller box that is, else the least-effort design, else keeps the robust one (its verification
then says so). The verification (a loading path from zero field) is the independent judge; the
selection is tested here with stand-ins for it, and end to end on a target where it matters."""
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
import pytest

from actuator_design.robust import design_robust_stage as stage


@dataclass
class _Choice:
    name: str
    notes: list = field(default_factory=list)
    scene: object = None


def _run(monkeypatch, reachable, holds=()):
    """``_reachable`` with the robust design (box 1.0) and rungs 0.25, 0.5, 0.75: ``reachable`` names
    the designs the stand-in verification reaches, ``holds`` those that hold over the whole box."""
    monkeypatch.setattr(stage, "_moved_choice",
                        lambda problem, choice, d, z, status: _Choice(f"rung {d}", scene=f"rung {d}"))
    monkeypatch.setattr(stage, "evaluate_robustness",
                        lambda scene, z, target, tol, options: SimpleNamespace(holds=scene in holds,
                                                                               worst_tip_error=0.01))
    calls = []

    def follow(ch):
        calls.append(ch.name)
        return SimpleNamespace(path=object() if ch.name in reachable else None, name=ch.name)

    problem = SimpleNamespace(settings=SimpleNamespace(tolerances=None), options=None, target=(0.3, 0.5))
    nominal, moved = _Choice("nominal"), _Choice("robust")
    ahead = SimpleNamespace(result=lambda: follow(moved))
    ladder = [(0.25, 0.25, np.zeros(3)), (0.5, 0.5, np.zeros(3)), (0.75, 0.75, np.zeros(3)), (1.0, 1.0, np.zeros(3))]
    out = stage._reachable(problem, nominal, moved, "robust robustness", 1.0, ladder, ahead, follow)
    return out, calls


def test_a_reachable_robust_design_stays(monkeypatch):
    (choice, rob, largest, verification), calls = _run(monkeypatch, {"robust"})
    assert choice.name == "robust" and largest == 1.0 and verification.result().name == "robust"
    assert calls == ["robust"]


def test_the_largest_reachable_smaller_box_is_taken_from_the_top(monkeypatch):
    (choice, rob, largest, verification), calls = _run(monkeypatch, {"rung 0.5", "rung 0.25"})
    assert choice.name == "rung 0.5" and largest == 0.5 and verification.result().name == "rung 0.5"
    assert calls == ["robust", "rung 0.75", "rung 0.5"]  # the full box's design is not tried twice
    assert "made for 50 % of it, is reached without one" in choice.notes[0]


def test_a_smaller_box_design_that_holds_over_the_whole_box_says_so(monkeypatch):
    (choice, rob, largest, _), _ = _run(monkeypatch, {"rung 0.75"}, holds={"rung 0.75"})
    assert choice.name == "rung 0.75" and largest == 1.0 and "holds over the whole box" in choice.notes[0]


def test_the_least_effort_design_when_no_box_design_is_reachable(monkeypatch):
    (choice, rob, largest, verification), calls = _run(monkeypatch, {"nominal"})
    assert choice.name == "nominal" and rob is None and largest == 0.0
    assert verification.result().name == "nominal" and calls[-1] == "nominal"
    assert "the least-effort design, reached without one, is kept" in choice.notes[0]


def test_the_robust_design_stays_when_nothing_is_reachable(monkeypatch):
    (choice, rob, largest, verification), calls = _run(monkeypatch, set())
    assert choice.name == "robust" and largest == 1.0 and verification.result().path is None
    assert calls == ["robust", "rung 0.75", "rung 0.5", "rung 0.25", "nominal"]


@pytest.mark.slow
def test_a_target_whose_full_box_design_snaps_gets_a_reachable_one_that_holds():
    """Target (0.3, 0.5), E ± 10 % on top of the default box: the design made for the whole box is
    reached from zero field only through a snap; the one made for a smaller box is reached and, by
    branch following, holds over the whole box. Checked by a loading path along the reported
    schedule (independent of the design's NLP) that must end on the target without a snap."""
    import actuator_design as ad
    from actuator_design.continuation.loading import follow_path
    from actuator_design.robust.tolerances import parse_tolerances
    res = ad.design((0.3, 0.5), settings=ad.DesignSettings(tolerances=parse_tolerances("youngs_modulus=10%")))
    from result_invariants import design_contradictions
    assert not design_contradictions(res.to_dict())
    assert res.success and res.robustness.holds and "is reached without one and holds over the whole box" in res.message
    path = follow_path(res.design_scene or res.scene, ad.SolverOptions(), res.schedule)
    assert path.snap_free and path.final.stable
    assert np.hypot(path.final.tip["x"] - 0.3, path.final.tip["y"] - 0.5) < 1e-6
