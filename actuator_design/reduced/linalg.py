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
from scipy.linalg import lapack

__all__ = ["lowest_eigenpairs", "lowest_eigenpairs_dense", "inertia", "signed_distance_to_singularity", "bordered_solve",
           "lu_det_sign", "mass_scaled", "null_vector"]

_dsytrf, _dsyevr = lapack.dsytrf, lapack.dsyevr


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
    ldu, ipiv, info = _dsytrf(A)
    d, off = np.diag(ldu), np.diag(ldu, 1)
    neg, k = 0, A.shape[0] - 1
    while k >= 0:  # upper storage: a 2×2 block sits at (k−1, k) when ipiv[k] = ipiv[k−1] < 0
        if ipiv[k] > 0 or k == 0:
            neg += d[k] < 0
            k -= 1
        else:
            a, b, c = d[k - 1], off[k - 1], d[k]
            det = a * c - b * b
            neg += 1 if det < 0 else (2 if a + c < 0 else 0)
            k -= 2
    w = _dsyevr(A, compute_v=0, range="I", il=1, iu=1)[0]
    return int(neg), float(w[0])


def signed_distance_to_singularity(A: np.ndarray) -> Tuple[int, float, float]:
    """(Morse index, smallest eigenvalue, (−1)^#(μ<0) · min|μ|) of a symmetric dense A.

    The last is continuous along a path and vanishes exactly where an eigenvalue crosses zero;
    the index counts μ < −1e-9 max(1, |μ_0|) only (a marginal eigenvalue is not a direction of
    descent)."""
    mu = np.linalg.eigvalsh(A)
    scale = 1e-9 * max(1.0, abs(mu[0]))
    idx = int(np.sum(mu < -scale))
    return idx, float(mu[0]), float((-1) ** int(np.sum(mu < 0)) * np.min(np.abs(mu)))


def null_vector(H: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Eigenvector of (H, M) whose eigenvalue is closest to zero, M-normalised (vᵀMv = 1), (n,)."""
    ms = 1.0 / np.sqrt(mass)
    w, V = np.linalg.eigh(mass_scaled(H, ms))
    v = ms * V[:, int(np.argmin(np.abs(w)))]
    return v / math.sqrt(float(v @ (mass * v)))


def lu_det_sign(lu: np.ndarray, piv: np.ndarray) -> float:
    """Sign of det A from ``scipy.linalg.lu_factor``'s (lu, piv)."""
    d = np.sign(np.diag(lu)).prod()
    swaps = np.count_nonzero(piv != np.arange(piv.size))
    return float(d * (-1.0) ** swaps)


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
