"""Cheap stability verdicts for states met along a loading path (THEORY §7), no eigenvectors.

``solver.stability`` computes the lowest eigenpairs of M^-1/2 H M^-1/2 with the eigenvector a
branch-point kick needs. Most states of a loading path are plainly stable, and a study point asks
only whether it is: :func:`is_unstable` first tries a Cholesky factorisation of
M^-1/2 H M^-1/2 − τ I (success proves every eigenvalue > τ, so the state is stable, not marginal,
Morse index 0: the same verdict ``solver.stability`` gives with its tolerance τ·max(1, |λ0|)), and
only when that fails computes the lowest eigenvalues (one LAPACK ``dsyevr`` call) to decide as
``solver.stability`` does. :class:`StabilityCheck` keeps what was learnt, and
:func:`verdict_of` turns it into a :class:`~actuator_design.equilibrium.solver.StabilityVerdict`, computing
the eigenvalues only when they are asked for.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import List, Optional

import numpy as np
from scipy.linalg import lapack

from actuator_design.equilibrium.solver import StabilityVerdict
from actuator_design.reduced.linalg import STABILITY_TOL, certified_stable, classify_spectrum

__all__ = ["StabilityCheck", "is_unstable", "lowest_eigenvalues", "verdict_of"]

#: reduced systems up to this size are checked densely; bigger ones use ``solver.stability``
DENSE_MAX = 200
#: default tolerance of the verdict, as ``EquilibriumSolver.stability``
TOL = STABILITY_TOL

_dsyevr = lapack.dsyevr
#: per kernel: the flat indices of its Hessian's nonzeros in a dense matrix, and their mass scaling
_PATTERN: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class StabilityCheck:
    """What a check established: ``certified`` (all eigenvalues > τ: stable), or the lowest
    eigenvalues (shape (≤3,), ascending)."""

    certified: bool
    eigenvalues: Optional[np.ndarray] = None


def _scaled_hessian(solver, z: np.ndarray, params: np.ndarray) -> Optional[np.ndarray]:
    """M^-1/2 H M^-1/2 at ``z`` as a dense (n, n) array, or None for big systems."""
    ker = solver.kernel
    if ker.n > DENSE_MAX:
        return None
    ker.set_params(params)
    ker.evaluate(np.asarray(z, float)[1:])
    flat, scale = _PATTERN.get(ker, (None, None))
    if flat is None:
        ms = np.sqrt(ker.inv_mass)
        flat, scale = ker.rows * ker.n + ker.cols, ms[ker.rows] * ms[ker.cols]
        _PATTERN[ker] = (flat, scale)
    A = np.zeros((ker.n, ker.n))
    A.flat[flat] = ker.hnz * scale
    return A


def _lowest(A: np.ndarray, k: int = 3) -> np.ndarray:
    return _dsyevr(A, compute_v=0, range="I", il=1, iu=min(k, A.shape[0]))[0][:k]


def lowest_eigenvalues(solver, z: np.ndarray, params: np.ndarray, k: int = 3) -> Optional[np.ndarray]:
    """The k smallest eigenvalues of M^-1/2 H M^-1/2 at ``z``, ascending, or None for big systems."""
    A = _scaled_hessian(solver, z, params)
    return None if A is None else _lowest(A, k)


def is_unstable(solver, z: np.ndarray, params: np.ndarray, tol: float = TOL,
                out: Optional[List[StabilityCheck]] = None) -> bool:
    """``solver.stability(z, params).morse_index > 0``, decided as cheaply as possible (module
    doc). ``out``: a list that receives the :class:`StabilityCheck`."""
    A = _scaled_hessian(solver, z, params)
    if A is None:
        return solver.stability(z, params, tol=tol).morse_index > 0
    if certified_stable(A, tol):
        if out is not None:
            out.append(StabilityCheck(True))
        return False
    lam = _lowest(A)
    if out is not None:
        out.append(StabilityCheck(False, lam))
    return classify_spectrum(lam, tol)[0] > 0


def verdict_of(solver, z: np.ndarray, params: np.ndarray, check: Optional[StabilityCheck] = None,
               need_eigenvalues: bool = True, tol: float = TOL):
    """A :class:`~actuator_design.equilibrium.solver.StabilityVerdict` at ``z`` without the eigenvector.

    From ``check`` when it suffices (a certified state without ``need_eigenvalues`` gets an empty
    ``eigenvalues`` array), else from the lowest three eigenvalues (``solver.stability`` for big
    systems).
    """
    if check is not None and check.certified and not need_eigenvalues:
        return StabilityVerdict(eigenvalues=np.zeros(0), eigenvector=None, morse_index=0,
                                stable=True, marginal=False)
    lam = check.eigenvalues if check is not None and check.eigenvalues is not None else \
        lowest_eigenvalues(solver, z, params)
    if lam is None:
        return solver.stability(z, params, tol=tol)
    morse, stable, marginal = classify_spectrum(lam, tol)
    return StabilityVerdict(eigenvalues=lam, eigenvector=None, morse_index=morse, stable=stable,
                            marginal=marginal)
