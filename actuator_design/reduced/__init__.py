"""The reduced system (clamp eliminated) of a built NLP and one numerical toolkit on it.

* :mod:`.system` — :class:`ReducedSystem`: gradient, Hessian, parameter derivatives, directional
  third derivatives, the tip map and its Jacobians, cached per (structure, transcription, names);
* :mod:`.kernel` — :class:`FastKernel`: buffered gradient/Hessian evaluation, LAPACK Newton steps;
* :mod:`.positional` — the dense Hessian of an energy that reads positions, assembled as Φᵀ K Φ;
* :mod:`.newton` — the equilibrium Newtons (damped, fast) and Newton on augmented systems;
* :mod:`.linalg` — bordered solve, inertia, lowest eigenpairs (banded or dense storage);
* :mod:`.stability` — the one stability rule and the verdicts made by it (THEORY §7);
* :mod:`.fold` — the fold locator (Moore–Spence).
"""
from actuator_design.reduced.fold import FoldPoint, locate_fold
from actuator_design.reduced.linalg import (bordered_solve, inertia, lowest_eigenpairs, lu_det_sign,
                                            mass_scaled, null_vector, signed_distance_to_singularity)
from actuator_design.reduced.newton import RawSolution, damped_newton, fast_newton, newton
from actuator_design.reduced.system import ReducedSystem, SystemEvaluator, reduced_system, substituted_energy

__all__ = ["ReducedSystem", "SystemEvaluator", "reduced_system", "substituted_energy",
           "RawSolution", "damped_newton", "fast_newton", "newton", "bordered_solve", "inertia",
           "lowest_eigenpairs", "lu_det_sign", "mass_scaled", "null_vector",
           "signed_distance_to_singularity", "FoldPoint", "locate_fold"]
