"""Continuation in the shape of BifurcationKit.jl: ``continuation(problem, algorithm, settings, events)``.

* :class:`BifurcationProblem` — the reduced system G(u, λ) = 0 in one lens parameter, a start;
* algorithms :class:`PALC` (pseudo-arclength, passes folds) and :class:`Natural` (steps in λ);
* :class:`ContinuationSettings` — frozen, validates itself;
* events :class:`Fold`, :class:`BranchPoint`, :class:`UserEvent` — located in one place.

Loading paths, branches and fold curves of :mod:`actuator_design.analysis` run on it.
"""
from .engine import PALC, ContinuationBranch, Natural, continuation
from .events import BranchPoint, BranchState, EventPoint, Fold, UserEvent
from .fold_problem import FoldCurveProblem
from .problem import BifurcationProblem
from .settings import ContinuationSettings

__all__ = ["continuation", "BifurcationProblem", "FoldCurveProblem", "PALC", "Natural", "ContinuationSettings",
           "ContinuationBranch", "Fold", "BranchPoint", "UserEvent", "EventPoint", "BranchState"]
