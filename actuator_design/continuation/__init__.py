"""Continuation in the shape of BifurcationKit.jl: ``continuation(problem, algorithm, settings, events)``.

* :class:`BifurcationProblem` — the reduced system G(u, λ) = 0 in one lens parameter, a start;
* :class:`SegmentProblem` — the same along a loading-schedule segment (several parameters move);
* algorithms :class:`PALC` (pseudo-arclength, passes folds) and :class:`Natural` (steps in λ);
* :class:`ContinuationSettings` — frozen, validates itself;
* events :class:`Fold`, :class:`BranchPoint`, :class:`UserEvent` — located in one place.

Loading paths, branches and fold curves of :mod:`actuator_design.analysis` run on it.
"""
from actuator_design.continuation.engine import PALC, ContinuationBranch, Natural, continuation
from actuator_design.continuation.events import BranchPoint, BranchState, EventPoint, Fold, UserEvent
from actuator_design.continuation.fold_problem import FoldCurveProblem
from actuator_design.continuation.problem import BifurcationProblem
from actuator_design.continuation.segment import LensSegment, SegmentProblem
from actuator_design.continuation.settings import ContinuationSettings

__all__ = ["continuation", "BifurcationProblem", "FoldCurveProblem", "SegmentProblem", "LensSegment", "PALC", "Natural", "ContinuationSettings",
           "ContinuationBranch", "Fold", "BranchPoint", "UserEvent", "EventPoint", "BranchState"]
