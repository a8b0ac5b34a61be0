"""The low-overhead kernel of the equilibrium Newtons: gradient, Hessian and Newton steps of the
reduced energy in the free unknowns through CasADi's buffer interface and direct LAPACK calls.

Built by :class:`~actuator_design.equilibrium.solver.EquilibriumSolver` (which compiles the two CasADi
functions) and used by :mod:`.newton` and the stability verdict.
"""
from __future__ import annotations

from typing import Optional

import casadi as ca
import numpy as np
from scipy.linalg import lapack

from actuator_design.reduced.linalg import lowest_eigenpairs as _lowest_eigenpairs
from actuator_design.reduced.linalg import rounding_floor

__all__ = ["FastKernel"]


class FastKernel:
    """Gradient, Hessian and Newton steps in the free unknowns with minimal per-call overhead.

    Two CasADi functions, ``[θ_free, params] -> ∇Ê`` and ``-> (∇Ê, ∇²Ê)``, are called through their
    buffer interface (no argument conversion: inputs and outputs are preallocated float64 arrays
    shared by both), and the Newton system is factorised and solved with direct LAPACK calls chosen
    from the Hessian's sparsity: ``getrf/getrs`` (dense), ``gttrf/gttrs`` (tridiagonal) or
    ``gbtrf/gbtrs`` (banded, bandwidth ≪ n). The gradient alone costs a fraction of the Hessian,
    which lets :meth:`EquilibriumSolver.solve_fast` reuse a factorisation over several steps.

    Not thread-safe (one set of buffers per solver); processes build their own.

    Parameters
    ----------
    f_g, f_gh : casadi.Function
        ``[θ_free (n,), params (n_p,)] -> [g (n,), r]`` and ``-> [g (n,), r, H (n, n) sparse]``,
        r = max_i |g_i| / m_i.
    mass : ndarray, shape (n,)
        Lumped mass of the free nodes: the residual is max_i |g_i| / m_i.
    hessian : PositionalHessian, optional
        The structured Hessian of an energy that reads positions
        (:class:`~actuator_design.reduced.positional.PositionalHessian`); ``f_gh`` may then be
        ``None``. The Hessian is dense and evaluated by it, the gradient by ``f_g`` — once per
        point: a Hessian requested at the point of the last gradient reuses that gradient.
    """

    def __init__(self, f_g: ca.Function, f_gh: Optional[ca.Function], mass: np.ndarray,
                 hessian=None):
        self.n = n = int(f_g.size1_in(0))
        self.z = np.zeros(n)
        self.p = np.zeros(int(f_g.nnz_in(1)))
        self.g = np.zeros(n)
        self.r = np.zeros(1)
        self.structured = hessian is not None
        self._g_current = False  # the gradient in self.g belongs to (self.z, self.p)
        sp = ca.Sparsity.dense(n, n) if self.structured else f_gh.sparsity_out(2)
        self.hnz = np.zeros(sp.nnz())
        self._buf_g, self._eval_g = f_g.buffer()
        bufs = [self._buf_g]
        if self.structured:
            # the (symmetric) Hessian is written in C order into the column-major nonzeros
            self._hessian = hessian  # owns the CasADi function the evaluator's buffer points into
            self._eval_h = hessian.bind(self.z, self.p, self.hnz.reshape((n, n)))
        else:
            self._buf_gh, self._eval_gh = f_gh.buffer()
            bufs.append(self._buf_gh)
            self._buf_gh.set_res(2, memoryview(self.hnz))
        for buf in bufs:
            buf.set_arg(0, memoryview(self.z))
            buf.set_arg(1, memoryview(self.p))
            buf.set_res(0, memoryview(self.g))
            buf.set_res(1, memoryview(self.r))
        rows, cols = (np.asarray(v, dtype=np.intp) for v in sp.get_triplet())
        self.rows, self.cols = rows, cols
        self.inv_mass = 1.0 / np.asarray(mass, float)
        bw = int(np.max(np.abs(rows - cols), initial=0))
        self.bandwidth = bw
        self._lu = None
        if bw <= 1 and n > 2:
            self.kind = "tridiagonal"
            diag, lower, upper = rows == cols, rows == cols + 1, cols == rows + 1
            self._idx_d = np.flatnonzero(diag)[np.argsort(rows[diag])]
            self._idx_l = np.flatnonzero(lower)[np.argsort(cols[lower])]
            self._idx_u = np.flatnonzero(upper)[np.argsort(rows[upper])]
        elif n >= 64 and 4 * bw < n:
            self.kind = "banded"
            self._ab = np.zeros((3 * bw + 1, n), order="F")
            self._ab_rows = 2 * bw + rows - cols  # LAPACK gbtrf storage: ab[kl+ku+i-j, j]
        else:
            self.kind = "dense"
            # a structurally dense Hessian comes column by column: view it as a Fortran matrix
            self._H = (self.hnz.reshape((n, n), order="F") if sp.nnz() == n * n
                       else np.zeros((n, n), order="F"))
            self._H_is_view = sp.nnz() == n * n

    # -- evaluation ---------------------------------------------------------------------------
    def set_params(self, params: np.ndarray) -> None:
        self.p[:] = params
        self._g_current = False

    def evaluate(self, zr: np.ndarray, hessian: bool = True) -> float:
        """Evaluate ∇Ê (and ∇²Ê) at ``zr`` (free unknowns); returns max_i |g_i|/m_i."""
        if self.structured:
            if not (hessian and self._g_current and (self.z == zr).all()):
                self.z[:] = zr
                self._eval_g()
                self._g_current = True
            if hessian:
                self._eval_h()
            return float(self.r[0])
        self.z[:] = zr
        if hessian:
            self._eval_gh()
        else:
            self._eval_g()
        return float(self.r[0])

    def rounding_floor(self, zr: np.ndarray) -> float:
        """The residual that rounding alone produces at ``zr`` (last evaluated H;
        :func:`~actuator_design.reduced.linalg.rounding_floor`). For fine meshes (midpoint N ≳ 1000)
        it reaches 1e-10."""
        return rounding_floor(np.bincount(self.rows, weights=np.abs(self.hnz), minlength=self.n), self.inv_mass, zr)

    def gradient_rounding(self, zr: np.ndarray) -> float:
        """The rounding of the gradient's largest entry |g_i| at ``zr`` (last evaluated H; not divided
        by the masses): 16 ε max_i Σ_j |H_ij| · max(1, |zr|∞)."""
        return rounding_floor(np.bincount(self.rows, weights=np.abs(self.hnz), minlength=self.n),
                              np.ones(self.n), zr)

    def hessian_dense(self) -> np.ndarray:
        """The last evaluated Hessian as a dense array, shape (n, n)."""
        H = np.zeros((self.n, self.n))
        H[self.rows, self.cols] = self.hnz
        return H

    def factorize(self) -> bool:
        """LU-factorise the last evaluated Hessian; False when it is singular."""
        h = self.hnz
        if self.kind == "dense":
            H = self._H
            if not self._H_is_view:
                H[self.rows, self.cols] = h
            lu, piv, info = lapack.dgetrf(H)
            self._lu = (lu, piv)
        elif self.kind == "tridiagonal":
            dl, d, du, du2, piv, info = lapack.dgttrf(h[self._idx_l], h[self._idx_d], h[self._idx_u])
            self._lu = (dl, d, du, du2, piv)
        else:
            ab = self._ab
            ab[self._ab_rows, self.cols] = h
            lu, piv, info = lapack.dgbtrf(ab, self.bandwidth, self.bandwidth)
            self._lu = (lu, piv)
        if info != 0:
            self._lu = None
        return self._lu is not None

    def solve(self) -> Optional[np.ndarray]:
        """The Newton step H⁻¹ g for the current gradient and the last factorisation."""
        if self._lu is None:
            return None
        if self.kind == "dense":
            x, info = lapack.dgetrs(self._lu[0], self._lu[1], self.g)
        elif self.kind == "tridiagonal":
            x, info = lapack.dgttrs(*self._lu, self.g)
        else:
            bw = self.bandwidth
            x, info = lapack.dgbtrs(self._lu[0], bw, bw, self.g, self._lu[1])
        if info != 0:
            return None
        return x.ravel()  # non-finite values are caught by the callers' residual tests

    def newton_step(self) -> Optional[np.ndarray]:
        """Factorise the last evaluated Hessian and return H⁻¹ g (``None`` if singular)."""
        return self.solve() if self.factorize() else None

    def lowest_eigenpairs(self, k: int):
        """Smallest ``k`` eigenvalues of M^-1/2 H M^-1/2 (last evaluated H), ascending, and the
        eigenvector of the smallest, shape (n,): :func:`~actuator_design.reduced.linalg.lowest_eigenpairs`
        on banded storage for band Hessians (n ≥ 64), dense otherwise."""
        banded = self.kind in ("tridiagonal", "banded") and self.n >= 64
        return _lowest_eigenpairs(self.rows, self.cols, self.hnz, self.inv_mass, k, banded,
                                  self.bandwidth)
