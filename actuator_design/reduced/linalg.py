"""Linear algebra of the reduced system: bordered solves, inertia and lowest eigenpairs (THEORY §7).

One place for every spectral question the analyses ask of the reduced Hessian H (n × n) and the
lumped mass M (n,):

* :func:`lowest_eigenpairs` — the k smallest eigenvalues of M^-1/2 H M^-1/2 and the eigenvector
  of the smallest, choosing banded storage (LAPACK's banded symmetric solver plus inverse
  iteration) for long band matrices and LAPACK ``syevr`` on dense storage otherwise;
* :func:`inertia` — Morse index (number of negative eigenvalues) by the inertia of a
  Bunch–Kaufman LDLᵀ factorisation (Sylvester's law) and the smallest eigenvalue alone;
* :func:`signed_distance_to_singularity` — (−1)^index · min|μ|, continuous through an eigenvalue
  crossing zero: the test function that locates folds and branch points;
* :func:`bordered_solve` — [[A, B], [Cᵀ, D]] x = r for a dense or banded A;
* :func:`lu_det_sign` — sign of a determinant from an LU factorisation.
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np
import scipy.linalg
from scipy.linalg import blas, lapack

from actuator_design.reduced.stability import _ldl_inertia, classify_spectrum, ldl_negatives

__all__ = ["lowest_eigenpairs", "lowest_eigenpairs_dense", "lowest_eigenpair", "lowest_eigenpair_banded",
           "banded_negatives", "inertia", "ldl_negatives", "signed_distance_to_singularity", "bordered_solve",
           "lu_det_sign", "mass_scaled", "null_vector", "rounding_floor", "rounding_floors", "FLOOR_EXCUSE",
           "FLOOR_STEP", "within_rounding_floor"]

_dsytrf, _dsyevr, _dsysv, _dpotrf = lapack.dsytrf, lapack.dsyevr, lapack.dsysv, lapack.dpotrf
_dgbsv, _dpbtrf, _dsbmv = lapack.dgbsv, lapack.dpbtrf, blas.dsbmv
_EPS = float(np.finfo(float).eps)


#: a residual above tolerance is excused by rounding only up to this multiple of the tolerance (a huge
#: Hessian, e.g. a rod touching a dipole's singularity, must not excuse a large residual)
FLOOR_EXCUSE = 1e4


def rounding_floors(abs_rowsum: np.ndarray, inv_mass: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The residual |g_i| / m_i that rounding alone produces at each unknown:
    16 ε (Σ_j |H_ij|) / m_i · max(1, |z|∞), shape (n,).

    The gradient's entries are sums of terms of size |H_ij| |z_j|, so they carry a rounding error
    of a few ε times that; divided by the small masses of a graded mesh's end elements it can
    exceed an absolute tolerance of 1e-10 there (and only there).

    Parameters
    ----------
    abs_rowsum : ndarray, shape (n,)
        Σ_j |H_ij| of the Hessian.
    inv_mass : ndarray, shape (n,)
        1 / m_i.
    z : ndarray
        The point (rad).
    """
    return 16.0 * _EPS * abs_rowsum * inv_mass * max(1.0, float(np.abs(z).max(initial=0.0)))


def rounding_floor(abs_rowsum: np.ndarray, inv_mass: np.ndarray, z: np.ndarray) -> float:
    """The largest of :func:`rounding_floors`: the floor of max_i |g_i| / m_i."""
    return float(np.max(rounding_floors(abs_rowsum, inv_mass, z)))


#: a Newton step (rad) below which a point whose residual is within its rounding floor is converged
FLOOR_STEP = 1e-9


def within_rounding_floor(g: np.ndarray, H: np.ndarray, u: np.ndarray, mass: np.ndarray, tol: float) -> bool:
    """Whether every |g_i| / m_i at ``u`` is within ``tol`` plus that unknown's own rounding floor
    (:func:`rounding_floors`, at most :data:`FLOOR_EXCUSE` × tol): the small end elements of a
    graded mesh put an absolute 1e-10 below what rounding allows at their nodes. The Newton
    correctors accept such a point only after a step below :data:`FLOOR_STEP` from it.

    Parameters
    ----------
    g, u, mass : ndarray, shape (n,)
        Gradient, point (rad) and lumped masses.
    H : ndarray, shape (n, n)
        Hessian at ``u``.
    """
    floors = rounding_floors(np.abs(H).sum(axis=1), 1.0 / mass, u)
    return bool(np.all(np.abs(g) / mass <= tol + np.minimum(floors, FLOOR_EXCUSE * tol)))


def mass_scaled(H: np.ndarray, inv_sqrt_mass: np.ndarray) -> np.ndarray:
    """Symmetrised M^-1/2 H M^-1/2, shape (n, n), from a dense H and m^-1/2 (n,)."""
    A = inv_sqrt_mass[:, None] * H * inv_sqrt_mass[None, :]
    return 0.5 * (A + A.T)


def lowest_eigenpairs(rows: np.ndarray, cols: np.ndarray, values: np.ndarray, inv_mass: np.ndarray,
                      k: int, banded: bool, bandwidth: int) -> Tuple[np.ndarray, np.ndarray]:
    """The ``k`` smallest eigenvalues of M^-1/2 H M^-1/2, ascending, and the eigenvector of the
    smallest, shape (n,) (unit Euclidean norm, in the mass-scaled coordinates).

    Parameters
    ----------
    rows, cols, values : ndarray, shape (nnz,)
        H in triplet form (both triangles).
    inv_mass : ndarray, shape (n,)
        1 / m_i.
    k : int
    banded : bool
        Use banded storage (O(n·bw²) per call): eigenvalues by LAPACK's banded symmetric solver
        without vectors, the eigenvector by shifted inverse iteration with a banded Cholesky
        solve. Otherwise the k smallest pairs by LAPACK ``syevr`` on dense storage.
    bandwidth : int
        max |i − j| over the nonzeros.
    """
    n = inv_mass.size
    ms = np.sqrt(inv_mass)
    vals = values * ms[rows] * ms[cols]
    k = min(k, n)
    if banded:
        bw = bandwidth
        upper = rows <= cols
        a_band = np.zeros((bw + 1, n))
        a_band[bw + rows[upper] - cols[upper], cols[upper]] = vals[upper]
        lam = scipy.linalg.eig_banded(a_band, lower=False, select="i", select_range=(0, k - 1),
                                      eigvals_only=True)
        shifted = a_band.copy()
        gap = lam[1] - lam[0] if k > 1 else 1.0
        shifted[bw] -= lam[0] - max(1e-3 * gap, 1e-10 * max(1.0, abs(lam[0])))
        v = np.ones(n) / math.sqrt(n)
        try:
            for _ in range(3):  # inverse iteration: (A − σ) is positive definite for σ < λ0
                v = scipy.linalg.solveh_banded(shifted, v, check_finite=False)
                v /= np.linalg.norm(v)
        except np.linalg.LinAlgError:
            A = np.zeros((n, n))
            A[rows, cols] = vals
            lam_d, V = np.linalg.eigh(0.5 * (A + A.T))
            return lam_d[:k], V[:, 0]
        return lam, v
    A = np.zeros((n, n))
    A[rows, cols] = vals
    A = 0.5 * (A + A.T)
    # only the k smallest pairs (LAPACK syevr): 3-5x cheaper than a full eigh at n = 40, and much
    # less exposed to BLAS thread contention on a loaded machine
    lam, V = scipy.linalg.eigh(A, subset_by_index=[0, k - 1], driver="evr", check_finite=False)
    return lam, V[:, 0]


def lowest_eigenpairs_dense(H: np.ndarray, inv_mass: np.ndarray, k: int = 1):
    """:func:`lowest_eigenpairs` for a dense H (n, n): the k smallest eigenvalues of
    M^-1/2 H M^-1/2 and the eigenvector of the smallest in the original coordinates,
    v = M^-1/2 u with |u| = 1, shape (n,)."""
    n = inv_mass.size
    rows, cols = np.divmod(np.arange(n * n), n)
    lam, u = lowest_eigenpairs(rows, cols, np.asarray(H, float).ravel(), inv_mass, k, False, n - 1)
    return lam, np.sqrt(inv_mass) * u


def inertia(A: np.ndarray) -> Tuple[int, float]:
    """(Morse index, smallest eigenvalue) of a symmetric dense A, cheaply: the index from the
    inertia of a Bunch–Kaufman LDLᵀ factorisation (Sylvester's law of inertia), the smallest
    eigenvalue alone by LAPACK ``dsyevr``."""
    neg = ldl_negatives(A)
    w = _dsyevr(A, compute_v=0, range="I", il=1, iu=1)[0]
    return neg, float(w[0])


def lowest_eigenpair(A: np.ndarray, start: Optional[np.ndarray] = None,
                     max_solves: int = 3) -> Tuple[float, np.ndarray, bool]:
    """The smallest eigenvalue μ_0 of a symmetric dense A (n, n), its unit eigenvector (n,) and
    whether A is certified positive definite.

    With a ``start`` vector close to the eigenvector (the previous point's, along a branch),
    Rayleigh-quotient iteration (cubic convergence; a few LDLᵀ solves of A − σI; the first shift
    is the start's Rayleigh quotient lowered by 4τ) to a residual r = ‖Av − σv‖ ≤ 1e-12 ‖A‖_F,
    so that σ is within r of an eigenvalue. That it is the smallest (to within 6τ + 2r) is
    certified by Sylvester's law of inertia up to τ = 32 n ε ‖A‖_F, the backward error of the
    factorisations: by the LDLᵀ inertia of the first solve's A − s_1 I (no eigenvalue below s_1
    and σ ≤ s_1 + 5τ + r — a Rayleigh quotient is never below μ_0 —, or exactly one and
    σ + r < s_1 − τ), otherwise by a Cholesky factorisation of A − (σ − τ) I (it succeeds only when
    no eigenvalue lies below σ − τ). When neither certifies (no start, the iteration found a
    higher eigenvalue after two eigenvalues crossed, no convergence) the smallest pair comes from
    LAPACK ``dsyevr``.

    Returns
    -------
    (mu0, v, positive_definite)
        ``positive_definite`` is True only when certified (σ > 6τ + 2r); False says nothing.
    """
    n = A.shape[0]
    if start is not None and n > 1:
        fro = math.sqrt(float(np.einsum("ij,ij->", A, A)))
        tau, res_tol = 32.0 * n * _EPS * fro, 1e-12 * fro
        diag = np.arange(n) * (n + 1)
        v = start / math.sqrt(float(start @ start))
        Av = A @ v
        sig = float(v @ Av)
        s1 = below1 = None  # first shift and the number of eigenvalues below it
        for solve in range(max_solves + 1):
            r = Av - sig * v
            rn = float(np.sqrt(r @ r))
            if rn <= res_tol:
                if below1 == 0 and sig <= s1 + 5.0 * tau + rn or below1 == 1 and sig + rn + tau < s1:
                    return sig, v, sig > 6.0 * tau + 2.0 * rn
                S = A.copy()
                S.flat[diag] -= sig - tau
                if _dpotrf(S, lower=0, clean=0, overwrite_a=1)[1] == 0:
                    return sig, v, sig > 6.0 * tau + 2.0 * rn
                break
            if solve == max_solves:
                break
            shift = sig - 4.0 * tau if s1 is None else sig
            S = A.copy()
            S.flat[diag] -= shift
            ldu, ipiv, w, info = _dsysv(S, v, overwrite_a=1)
            if s1 is None:
                s1, below1 = shift, _ldl_inertia(ldu, ipiv)
            nw = float(np.sqrt(w @ w))
            if info != 0 or not 0.0 < nw < math.inf:  # σ is an eigenvalue to machine precision
                break
            v = w / nw
            Av = A @ v
            sig = float(v @ Av)
    w, V = _dsyevr(A, compute_v=1, range="I", il=1, iu=1)[:2]
    return float(w[0]), V[:, 0].copy(), False


def _band_general(a: np.ndarray, shift: float) -> np.ndarray:
    """a − shift·I from upper symmetric band storage (bw + 1, n) to LAPACK ``gbsv`` storage
    (3 bw + 1, n), rows bw..3 bw holding the band."""
    bw, n = a.shape[0] - 1, a.shape[1]
    ab = np.zeros((3 * bw + 1, n), order="F")
    ab[bw:2 * bw + 1] = a  # the upper triangle: ab[2bw + i − j, j] = a[bw + i − j, j]
    ab[2 * bw] -= shift
    for k in range(1, bw + 1):  # the lower triangle by symmetry: A[j + k, j] = A[j, j + k]
        ab[2 * bw + k, :n - k] = a[bw - k, k:]
    return ab


def lowest_eigenpair_banded(a: np.ndarray, start: Optional[np.ndarray] = None,
                            max_solves: int = 3) -> Tuple[float, np.ndarray, bool]:
    """:func:`lowest_eigenpair` for a symmetric band matrix in LAPACK's upper band storage
    a[bw + i − j, j] = A_ij (i ≤ j), shape (bw + 1, n); everything O(n·bw²).

    Rayleigh-quotient iteration from ``start`` with banded LU solves (``gbsv``), certified by a
    banded Cholesky factorisation (``pbtrf``) of A − (σ − τ) I; otherwise the smallest pair of
    LAPACK's banded eigensolver (``sbevx`` through ``scipy.linalg.eig_banded``).

    Returns
    -------
    (mu0, v, positive_definite)
        As :func:`lowest_eigenpair`.
    """
    bw, n = a.shape[0] - 1, a.shape[1]
    if start is not None and n > 1:
        fro = math.sqrt(float(np.sum(a[bw] ** 2) + 2.0 * np.sum(a[:bw] ** 2)))
        tau, res_tol = 32.0 * n * _EPS * fro, 1e-12 * fro
        v = start / math.sqrt(float(start @ start))
        Av = _dsbmv(bw, 1.0, a, v)
        sig = float(v @ Av)
        for solve in range(max_solves + 1):
            r = Av - sig * v
            rn = float(np.sqrt(r @ r))
            if rn <= res_tol:
                c = a.copy(order="F")
                c[bw] -= sig - tau
                if _dpbtrf(c, lower=0, overwrite_ab=1)[1] == 0:
                    return sig, v, sig > 6.0 * tau + 2.0 * rn
                break
            if solve == max_solves:
                break
            w, info = _dgbsv(bw, bw, _band_general(a, sig), v)[2:]
            nw = float(np.sqrt(w @ w))
            if info != 0 or not 0.0 < nw < math.inf:
                break
            v = w / nw
            Av = _dsbmv(bw, 1.0, a, v)
            sig = float(v @ Av)
    w, V = scipy.linalg.eig_banded(a, lower=False, select="i", select_range=(0, 0),
                                   check_finite=False)
    return float(w[0]), V[:, 0].copy(), False


def banded_negatives(a: np.ndarray) -> int:
    """Number of negative eigenvalues of a symmetric band matrix in upper band storage
    (bw + 1, n), by LAPACK's banded eigensolver restricted to (−∞, −tiny]."""
    w = scipy.linalg.eig_banded(a, lower=False, eigvals_only=True, select="v",
                                select_range=(-np.inf, -np.finfo(float).tiny), check_finite=False)
    return int(w.size)


def signed_distance_to_singularity(A: np.ndarray) -> Tuple[int, float, float]:
    """(Morse index, smallest eigenvalue, (−1)^#(μ<0) · min|μ|) of a symmetric dense A.

    The last is continuous along a path and vanishes exactly where an eigenvalue crosses zero;
    the index counts μ < −1e-9 max(1, |μ0|) only (a marginal eigenvalue is not a direction of
    descent). Only the #(μ<0) + 1 smallest eigenvalues are computed (``dsyevr``), #(μ<0) from
    the LDLᵀ inertia; should the two disagree (an eigenvalue at rounding distance from zero) the
    full spectrum decides."""
    n = A.shape[0]
    neg = ldl_negatives(A)
    mu = _dsyevr(A, compute_v=0, range="I", il=1, iu=min(n, neg + 1))[0][:min(n, neg + 1)]
    if not (np.all(mu[:neg] < 0) and (neg == n or mu[neg] >= 0)):
        mu = np.linalg.eigvalsh(A)
        neg = int(np.sum(mu < 0))
    idx = classify_spectrum(mu)[0]
    return idx, float(mu[0]), float((-1) ** neg * np.min(np.abs(mu[max(neg - 1, 0):neg + 1])))


def null_vector(H: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Eigenvector of (H, M) whose eigenvalue is closest to zero, M-normalised (vᵀMv = 1), (n,).

    The eigenvalue closest to zero is the largest negative or the smallest non-negative one;
    LDLᵀ inertia says which indices they have, and ``dsyevr`` computes those two pairs only (the
    full spectrum when the inertia and the eigenvalues disagree at rounding level)."""
    ms = 1.0 / np.sqrt(mass)
    A = mass_scaled(H, ms)
    n = A.shape[0]
    neg = ldl_negatives(A)
    il, iu = max(1, neg), min(n, neg + 1)
    w, V = _dsyevr(A, compute_v=1, range="I", il=il, iu=iu)[:2]
    w, V = w[:iu - il + 1], V[:, :iu - il + 1]
    if not ((neg == 0 or w[0] < 0) and (neg == n or w[-1] >= 0)):
        w, V = np.linalg.eigh(A)
    v = ms * V[:, int(np.argmin(np.abs(w)))]
    return v / math.sqrt(float(v @ (mass * v)))


def lu_det_sign(lu: np.ndarray, piv: np.ndarray) -> float:
    """Sign of det A from ``scipy.linalg.lu_factor``'s (lu, piv)."""
    d = np.diagonal(lu)
    if not d.all():
        return 0.0
    odd = (np.count_nonzero(d < 0) + np.count_nonzero(piv != np.arange(piv.size))) % 2
    return -1.0 if odd else 1.0


def bordered_solve(A, B: np.ndarray, C: np.ndarray, D: np.ndarray, r: np.ndarray,
                   bandwidth: Optional[int] = None) -> np.ndarray:
    """Solve the bordered system [[A, B], [Cᵀ, D]] x = r.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        Dense. With ``bandwidth`` given (≪ n) the solve is by block elimination with a banded LU
        of A (O(n·bw²)): x_2 = (D − Cᵀ A⁻¹ B)⁻¹ (r_2 − Cᵀ A⁻¹ r_1), x_1 = A⁻¹ (r_1 − B x_2);
        otherwise the (n + k)-square system is assembled and solved by LU (robust also when A
        alone is singular, as at a fold).
    B, C : ndarray, shape (n, k)
    D : ndarray, shape (k, k)
    r : ndarray, shape (n + k,)

    Returns
    -------
    ndarray, shape (n + k,)

    Raises
    ------
    numpy.linalg.LinAlgError
        Singular system.
    """
    n = A.shape[0]
    B, C, D = np.atleast_2d(B.T).T, np.atleast_2d(C.T).T, np.atleast_2d(D)
    if bandwidth is not None and 4 * bandwidth < n:
        bw = bandwidth
        ab = np.zeros((2 * bw + 1, n))
        for off in range(-bw, bw + 1):
            diag = np.diagonal(A, off)
            if off >= 0:
                ab[bw - off, off:] = diag
            else:
                ab[bw - off, :n + off] = diag
        rhs = np.column_stack([B, r[:n]])
        Y = scipy.linalg.solve_banded((bw, bw), ab, rhs, check_finite=False)
        S = D - C.T @ Y[:, :-1]
        x2 = np.linalg.solve(S, r[n:] - C.T @ Y[:, -1])
        return np.concatenate([Y[:, -1] - Y[:, :-1] @ x2, x2])
    J = np.block([[A, B], [C.T, D]])
    return np.linalg.solve(J, r)
