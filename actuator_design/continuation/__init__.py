"""Continuation in the shape of BifurcationKit.jl: ``continuation(problem, algorithm, settings, events)``.

* :class:`BifurcationProblem` — the reduced system G(u, λ) = 0 in one lens parameter, a start;
* :class:`SegmentProblem` — the same along a loading-schedule segment (several parameters move);
* :class:`StatePath` — a path of full states z(λ) (from rest, along a tolerance box's segment);
* algorithms :class:`PALC` (pseudo-arclength, passes folds), :class:`Natural` (steps in λ) and
  :class:`Secant` (natural continuation of a :class:`StatePath`, secant predictor);
* :class:`ContinuationSettings` — frozen, validates itself;
* events :class:`Fold`, :class:`BranchPoint`, :class:`UserEvent` — located in one place; and for
  :class:`Secant`, :class:`Snap` and :class:`StabilityLoss`.

Loading paths, branches and fold curves of :mod:`actuator_design.analysis` run on it.
"""
from actuator_design.continuation.engine import PALC, ContinuationBranch, Natural, continuation
from actuator_design.continuation.events import (BranchPoint, BranchState, EventPoint, Fold, Snap,
                                                 StabilityLoss, UserEvent)
from actuator_design.continuation.problem import BifurcationProblem, FoldCurveProblem
from actuator_design.continuation.secant import Secant, SecantRun, StatePath
from actuator_design.continuation.segment import LensSegment, SegmentProblem
from actuator_design.continuation.settings import ContinuationSettings

__all__ = ["continuation", "BifurcationProblem", "FoldCurveProblem", "SegmentProblem", "LensSegment", "PALC", "Natural", "ContinuationSettings",
           "ContinuationBranch", "Fold", "BranchPoint", "UserEvent", "EventPoint", "BranchState",
           "Secant", "SecantRun", "StatePath", "Snap", "StabilityLoss"]
