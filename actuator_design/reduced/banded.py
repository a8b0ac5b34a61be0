"""Band algebra of the continuation problem (bordered systems) for long band Hessians (fine meshes).

For n ≥ 64 unknowns and a bandwidth bw < n/4 the reduced Hessian H is a band matrix, and the
bordered systems of the corrector and the tangent,

    [[H, b], [cᵀ, d]] x = r     (b = G_λ, (c, d) the arclength row),

are solved by block elimination with a banded LU of H (LAPACK ``gbtrf``, O(n·bw²)) instead of a
dense LU of the (n + 1)-square matrix (O(n³)):

    y = H⁻¹ b,  z = H⁻¹ r_u,  S = d − cᵀy,  x_λ = (r_λ − cᵀz) / S,  x_u = z − y x_λ,

followed by one step of iterative refinement on the bordered residual (block elimination alone
loses accuracy as H approaches a fold, where the bordered matrix stays regular; Govaerts 2000,
ch. 3). det [[H, b], [cᵀ, d]] = det H · S gives the determinant sign of branch-point detection.
A singular H (exactly at a fold) makes the caller fall back to its dense solve.
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np
from scipy.linalg import lapack

__all__ = ["BandedBordered", "use_band"]

_dgbtrf, _dgbtrs = lapack.dgbtrf, lapack.dgbtrs


def use_band(n: int, bandwidth: int) -> bool:
    """Whether band storage pays: n ≥ 64 unknowns and 4·bandwidth < n (the kernel's rule)."""
    return n >= 64 and 4 * bandwidth < n


class BandedBordered:
    """Banded LU of H and bordered solves with it, for one problem's band structure.

    Parameters
    ----------
    n, bandwidth : int
        Size of H and max |i − j| over its structural nonzeros.
    inv_sqrt_mass : ndarray, shape (n,)
        m_i^{-1/2}: :meth:`scaled_band` gives M^{-1/2} H M^{-1/2} in symmetric band storage.
    """

    def __init__(self, n: int, bandwidth: int, inv_sqrt_mass: np.ndarray):
        self.n, self.bw = n, bw = int(n), int(bandwidth)
        offsets = np.arange(-bw, bw + 1)
        I = (np.arange(n)[None, :] + offsets[:, None]).ravel()
        J = np.broadcast_to(np.arange(n), (2 * bw + 1, n)).ravel()
        keep = (I >= 0) & (I < n)
        self._I, self._J = I[keep], J[keep]  # every band entry (i, j), |i − j| ≤ bw
        self._ab = np.zeros((3 * bw + 1, n), order="F")  # gbtrf storage: ab[2bw + i − j, j]
        self._ab_rows = 2 * bw + self._I - self._J
        up = self._I <= self._J
        self._Iu, self._Ju = self._I[up], self._J[up]  # the upper half, i ≤ j
        self._sym_rows = bw + self._Iu - self._Ju  # symmetric upper band storage: [bw + i − j, j]
        self._scale = 0.5 * inv_sqrt_mass[self._Iu] * inv_sqrt_mass[self._Ju]
        self._vals = np.zeros(self._I.size)
        self._lu = None

    # -- factorisation ------------------------------------------------------------------------
    def factor(self, H: np.ndarray) -> bool:
        """Banded LU of the dense-stored band matrix H (n, n); False when singular."""
        self._vals = H[self._I, self._J]
        self._ab[self._ab_rows, self._J] = self._vals
        lu, piv, info = _dgbtrf(self._ab, self.bw, self.bw)
        self._lu = (lu, piv) if info == 0 else None
        return self._lu is not None

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """H⁻¹ rhs for rhs of shape (n,) or (n, k), with the last factorisation."""
        lu, piv = self._lu
        return _dgbtrs(lu, self.bw, self.bw, rhs, piv)[0]

    def det_sign(self) -> float:
        """Sign of det H from the last factorisation (U's diagonal and the row interchanges)."""
        lu, piv = self._lu
        d = lu[2 * self.bw]
        odd = (np.count_nonzero(d < 0) + np.count_nonzero(piv != np.arange(self.n))) % 2
        return -1.0 if odd else 1.0

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """H x with the band entries of the last factorisation's H, O(n·bw)."""
        return np.bincount(self._I, weights=self._vals * x[self._J], minlength=self.n)

    # -- bordered systems ---------------------------------------------------------------------
    def bordered(self, H: np.ndarray, b: np.ndarray, c: np.ndarray, d: float,
                 r: np.ndarray) -> Optional[Tuple[np.ndarray, float]]:
        """Solve [[H, b], [cᵀ, d]] x = r, shapes b, c (n,), r (n + 1,), by block elimination
        with one refinement step. Returns (x (n + 1,), sign of the bordered determinant), or
        None when H is singular or the Schur complement S vanishes (use a dense solve)."""
        n = self.n
        if not self.factor(H):
            return None
        Y = self.solve(np.column_stack([b, r[:n]]))
        y = Y[:, 0]
        S = float(d - c @ y)
        if not (S != 0.0 and math.isfinite(S)):
            return None

        def eliminate(z, rhs_l):  # z = H⁻¹ rhs_u
            xl = (rhs_l - float(c @ z)) / S
            return z - y * xl, xl

        xu, xl = eliminate(Y[:, 1], float(r[n]))
        # one step of iterative refinement on the bordered residual
        res_u = r[:n] - self.matvec(xu) - b * xl
        res_l = float(r[n] - c @ xu - d * xl)
        du, dl = eliminate(self.solve(res_u), res_l)
        x = np.append(xu + du, xl + dl)
        if not np.isfinite(x).all():
            return None
        return x, self.det_sign() * (1.0 if S > 0 else -1.0)

    # -- the mass-scaled Hessian ----------------------------------------------------------------
    def scaled_band(self, H: np.ndarray) -> np.ndarray:
        """Symmetrised M^{-1/2} H M^{-1/2} in LAPACK's upper symmetric band storage,
        shape (bw + 1, n): a[bw + i − j, j] for i ≤ j."""
        a = np.zeros((self.bw + 1, self.n), order="F")
        a[self._sym_rows, self._Ju] = (H[self._Iu, self._Ju] + H[self._Ju, self._Iu]) * self._scale
        return a
