"""The stability rule, in one place (THEORY §7; issue 18: one home per concern).

A state is judged by the smallest eigenvalues λ of the reduced Hessian against the lumped mass,
i.e. of M^-1/2 H M^-1/2, with the scale τ = tol · max(1, |λ0|):

* :func:`classify_spectrum` — the rule: Morse index #(λ < −τ), stable when λ0 > τ, marginal when
  |λ0| ≤ τ (a marginal eigenvalue is no direction of descent, and no proof of stability either);
* :func:`certified_stable` — the rule's "stable" at the cost of one Cholesky factorisation of
  M^-1/2 H M^-1/2 − τ I (success proves every eigenvalue > τ); failure only says the eigenvalues
  must decide;
* :func:`kernel_verdict` — the full :class:`StabilityVerdict` of a state, with the eigenvector a
  branch-point kick needs (``EquilibriumSolver.stability``);
* :func:`is_unstable`, :func:`verdict_of` — the cheap verdicts of states met along a loading path,
  no eigenvectors: most states there are plainly stable, so the Cholesky certificate is tried
  first and the lowest eigenvalues (one LAPACK ``dsyevr`` call) are computed only when it fails.
  :class:`StabilityCheck` keeps what was learnt.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np
from scipy.linalg import lapack

__all__ = ["STABILITY_TOL", "classify_spectrum", "morse_index", "ldl_negatives", "certified_stable", "StabilityVerdict", "kernel_verdict",
           "StabilityCheck", "is_unstable", "lowest_eigenvalues", "verdict_of"]

#: Relative tolerance of the stability rule (:func:`classify_spectrum`).
STABILITY_TOL = 1e-9
#: reduced systems up to this size are checked densely; bigger ones use ``solver.stability``
DENSE_MAX = 200

_dsyevr, _dpotrf, _dsytrf = lapack.dsyevr, lapack.dpotrf, lapack.dsytrf
#: per kernel: the flat indices of its Hessian's nonzeros in a dense matrix, and their mass scaling
_PATTERN: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def classify_spectrum(lam, tol: float = STABILITY_TOL) -> Tuple[int, bool, bool]:
    """The stability rule: (Morse index, stable, marginal) from the smallest eigenvalues ``lam``
    (ascending) of the reduced Hessian against the mass (module doc). Every stability verdict of
    the package is made by this rule."""
    lam = np.asarray(lam, float)
    scale = tol * max(1.0, abs(float(lam[0])))
    return int(np.sum(lam < -scale)), bool(lam[0] > scale), bool(abs(lam[0]) <= scale)


def _ldl_inertia(ldu: np.ndarray, ipiv: np.ndarray) -> int:
    """Number of negative eigenvalues of D in a Bunch–Kaufman LDLᵀ = A (``dsytrf``/``dsysv``
    output, upper storage): that of A by Sylvester's law of inertia."""
    d = np.diagonal(ldu)
    one = ipiv > 0
    if one.all():  # 1×1 pivots only: the signs of D's diagonal
        return int(np.count_nonzero(d < 0))
    neg = int(np.count_nonzero(d[one] < 0))
    # a 2×2 block sits at (k, k+1) when ipiv[k] = ipiv[k+1] < 0; the blocks do not interleave, so
    # the sorted negative entries pair up two by two
    ks = np.flatnonzero(~one)
    a, c, b = d[ks[0::2]], d[ks[1::2]], ldu[ks[0::2], ks[1::2]]
    det = a * c - b * b
    return neg + int(np.count_nonzero(det < 0)) + 2 * int(np.count_nonzero((det >= 0) & (a + c < 0)))


def ldl_negatives(A: np.ndarray) -> int:
    """Number of negative eigenvalues of a symmetric dense A from the inertia of its
    Bunch–Kaufman LDLᵀ factorisation (Sylvester's law of inertia)."""
    ldu, ipiv, _ = _dsytrf(A)
    return _ldl_inertia(ldu, ipiv)


def morse_index(A: np.ndarray, lam, tol: float = STABILITY_TOL) -> int:
    """The rule's Morse index #(λ < −τ) of A = M^-1/2 H M^-1/2 (n, n) over its whole spectrum, given
    its smallest eigenvalues ``lam`` (ascending): counted among them when one is above −τ, else
    (every one computed is below −τ: there may be more) from the LDLᵀ inertia of A + τ I
    (Sylvester's law). The lowest three alone capped the index at 3 (the straight rod at h = 10,
    φ = 90° has index 5)."""
    lam = np.asarray(lam, float)
    index = classify_spectrum(lam, tol)[0]
    if index < lam.size or lam.size >= A.shape[0]:
        return index
    scale = tol * max(1.0, abs(float(lam[0])))
    return ldl_negatives(A + scale * np.eye(A.shape[0]))


def certified_stable(A: np.ndarray, tol: float = STABILITY_TOL) -> bool:
    """Whether A − τ I has a Cholesky factor, A = M^-1/2 H M^-1/2 (n, n) dense: then every
    eigenvalue exceeds τ and :func:`classify_spectrum` calls the state stable (Morse index 0, not
    marginal) — the rule's verdict at the cost of one factorisation. False says only that the
    eigenvalues must decide. ``A`` is not modified."""
    return _dpotrf(A - tol * np.eye(A.shape[0]), lower=0, clean=0, overwrite_a=1)[1] == 0


@dataclass
class StabilityVerdict:
    """Inertia of the reduced Hessian (THEORY §7).

    eigenvalues : smallest generalised eigenvalues of (H_r, M_r), ascending; they approximate the
        eigenvalues of the second-variation operator −(bη')' + q η with η(0) = 0, free end.
    eigenvector : the eigenvector of the smallest one (full node vector, 0 at the clamp), or None
        from the cheap verdicts.
    morse_index : number of eigenvalues < −tol.
    stable : all eigenvalues > tol.
    """

    eigenvalues: np.ndarray
    eigenvector: np.ndarray
    morse_index: int
    stable: bool
    marginal: bool


def kernel_verdict(kernel, z: np.ndarray, params: np.ndarray, k: int = 3,
                   tol: float = STABILITY_TOL) -> StabilityVerdict:
    """The verdict at ``z`` (full node vector, shape (n + 1,)) from a
    :class:`~actuator_design.reduced.kernel.FastKernel`: its k lowest eigenvalues and the
    eigenvector of the smallest, scaled to max-norm 1."""
    kernel.set_params(params)
    kernel.evaluate(np.asarray(z, float)[1:])
    lam, v0 = kernel.lowest_eigenpairs(k)
    vec = np.zeros(np.size(z))
    vec[1:] = np.sqrt(kernel.inv_mass) * v0
    vec /= np.max(np.abs(vec))
    morse, stable, marginal = classify_spectrum(lam, tol)
    if morse >= min(k, len(lam)) and len(lam) < kernel.n:  # every eigenvalue computed is negative
        ms = np.sqrt(kernel.inv_mass)
        morse = morse_index(ms[:, None] * kernel.hessian_dense() * ms[None, :], lam, tol)
    return StabilityVerdict(eigenvalues=lam[:k], eigenvector=vec, morse_index=morse, stable=stable,
                            marginal=marginal)


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


def is_unstable(solver, z: np.ndarray, params: np.ndarray, tol: float = STABILITY_TOL,
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
               need_eigenvalues: bool = True, tol: float = STABILITY_TOL) -> StabilityVerdict:
    """A :class:`StabilityVerdict` at ``z`` without the eigenvector.

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
    if morse == len(lam):  # every eigenvalue computed is negative: the whole spectrum counts
        A = _scaled_hessian(solver, z, params)
        morse = morse_index(0.5 * (A + A.T), lam, tol)
    return StabilityVerdict(eigenvalues=lam, eigenvector=None, morse_index=morse, stable=stable,
                            marginal=marginal)
