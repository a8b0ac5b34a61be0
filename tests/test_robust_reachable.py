"""A robust design is one the user can reach: when no snap-free schedule from zero field reaches the
design made for the whole tolerance box, the design falls back on the least-effort design when it
holds over the box, then on the designs made for smaller boxes (largest first), then on the
least-effort design, and keeps the robust one when none is reached (its verification then says
so). The verification (a loading path from zero field) is the judge; the order is tested here with
stand-ins for it, and end to end on a target where it matters (slow)."""
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
    point: object = None


def _run(monkeypatch, reached, holds=(), least_holds=False, raises=()):
    """``reachable`` after the robust design (made for the whole box) was not reached, with the
    homotopy's designs for 0.75, 0.5 and 0.25 of the box: ``reached`` names the designs the
    stand-in verification reaches, ``holds`` those that hold over the whole box, ``raises`` those
    whose verification fails numerically."""
    monkeypatch.setattr(stage, "evaluate_robustness", lambda scene, z, target, tol, options:
                        SimpleNamespace(holds=scene in holds, worst_tip_error=0.01))
    monkeypatch.setattr(stage, "_report", lambda problem, least, cand, rob, largest, nominal, attempts, unreached:
                        (cand, SimpleNamespace(largest_box=largest, robustness=rob, unreached=unreached)))
    calls = []

    def follow(ch):
        calls.append(ch.name)
        if ch.name in raises:
            raise np.linalg.LinAlgError("singular matrix")
        return SimpleNamespace(path=object() if ch.name in reached else None, name=ch.name)

    problem = SimpleNamespace(settings=SimpleNamespace(tolerances=None), options=None, target=(0.3, 0.5))
    robust, least = _Choice("robust"), _Choice("least-effort")
    rungs = [(f, _Choice(f"rung {f}", scene=f"rung {f}", point=SimpleNamespace(z=None))) for f in (0.75, 0.5, 0.25)]
    fallbacks = [(None, least)] + rungs if least_holds else rungs + [(None, least)]
    report = SimpleNamespace(fallbacks=fallbacks, largest_box=1.0, nominal=None, attempts=[])
    out = stage.reachable(problem, robust, report, follow(robust), follow)
    return out, calls


def test_the_largest_reached_smaller_box_is_taken_from_the_top(monkeypatch):
    (choice, report, verification), calls = _run(monkeypatch, {"rung 0.5", "rung 0.25"})
    assert choice.name == "rung 0.5" and report.largest_box == 0.5 and verification.name == "rung 0.5"
    assert calls == ["robust", "rung 0.75", "rung 0.5"]
    assert "made for 50 % of it, is reached without one" in choice.notes[-1] and report.unreached == 1.0


def test_a_smaller_box_design_that_holds_over_the_whole_box_says_so(monkeypatch):
    (choice, report, _), _ = _run(monkeypatch, {"rung 0.75"}, holds={"rung 0.75"})
    assert choice.name == "rung 0.75" and report.largest_box == 1.0
    assert "holds over the whole box" in choice.notes[-1]


def test_a_least_effort_design_that_holds_comes_before_the_smaller_boxes(monkeypatch):
    (choice, report, verification), calls = _run(monkeypatch, {"least-effort", "rung 0.75"}, least_holds=True)
    assert choice.name == "least-effort" and calls == ["robust", "least-effort"]
    assert "the least-effort design, reached without one, is kept" in choice.notes[-1]


def test_a_fallback_whose_verification_fails_numerically_is_not_reached(monkeypatch):
    (choice, _, _), calls = _run(monkeypatch, {"rung 0.5"}, raises={"rung 0.75"})
    assert choice.name == "rung 0.5" and calls == ["robust", "rung 0.75", "rung 0.5"]


def test_the_robust_design_stays_when_nothing_is_reached(monkeypatch):
    (choice, report, verification), calls = _run(monkeypatch, set())
    assert choice.name == "robust" and verification.path is None and report.largest_box == 1.0
    assert calls == ["robust", "rung 0.75", "rung 0.5", "rung 0.25", "least-effort"]
    assert "nor the least-effort design" in choice.notes[-1]


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


def test_a_report_on_a_kept_design_names_the_robust_one_it_could_not_reach():
    from actuator_design.robust.robustness import FoldDistance, Robustness
    from actuator_design.robust.tolerances import Tolerances
    rob = Robustness(tolerances=Tolerances(), worst_tip_error=0.01, discretisation_error=0.0, worst_angle_error=None,
                     stable_over_box=False, min_eigenvalue=-1.0, corners=[],
                     fold_distance=FoldDistance(None, None, None, None, {}), spread=np.zeros((1, 2)),
                     failures=["the branch is lost"])
    said = stage.RobustReport(rob, 0.0, unreached=1.0).sentence()
    assert "no design reached from zero field without a snap holds over any part of it" in said
    assert "(one made for 100 % of it was found)" in said
    assert "no design found holds" in stage.RobustReport(rob, 0.0).sentence()
