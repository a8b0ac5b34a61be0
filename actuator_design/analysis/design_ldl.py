"""The LDLᵀ stability certificate of the design NLPs (:mod:`.design_nlp`, :mod:`.design_robust`,
:mod:`.design_shape`): the pivots of a banded symmetric matrix as CasADi expressions, all > 0 exactly
when it is positive definite (Sylvester), and the reduced Hessian's bandwidth."""
from __future__ import annotations

from functools import lru_cache
from typing import List

import casadi as ca

__all__ = ["_ldl_function", "_ldl_pivots", "_bandwidth"]


@lru_cache(maxsize=32)
def _ldl_function(n: int, bandwidth: int) -> ca.Function:
    """``A (n, n) -> D (n,)``: the pivots of A = L D Lᵀ (no pivoting), for a symmetric A of the
    given bandwidth; built once per (n, bandwidth) (the Python loop costs ~0.15 s at n = 40)."""
    A = ca.SX.sym("A", n, n)
    L = [[None] * n for _ in range(n)]
    D: List[ca.SX] = []
    for j in range(n):
        lo = max(0, j - bandwidth)
        dj = A[j, j] - sum((L[j][k] ** 2 * D[k] for k in range(lo, j)), ca.SX(0))
        D.append(dj)
        for i in range(j + 1, min(n, j + bandwidth + 1)):
            lo_i = max(0, i - bandwidth)
            acc = A[i, j] - sum((L[i][k] * L[j][k] * D[k] for k in range(max(lo, lo_i), j)), ca.SX(0))
            L[i][j] = acc / dj
    return ca.Function("ldl_pivots", [A], [ca.vertcat(*D)])


def _ldl_pivots(A: ca.SX, bandwidth: int) -> List[ca.SX]:
    """Pivots D_j of A = L D Lᵀ (no pivoting) for a symmetric matrix with the given bandwidth.

    All pivots > 0 ⇔ A positive definite (Sylvester); entries outside the band stay zero in L.
    """
    n = A.shape[0]
    return ca.vertsplit(_ldl_function(n, int(bandwidth))(ca.densify(A)))


def _bandwidth(sv, n: int) -> int:
    """Bandwidth of the reduced Hessian of the solver ``sv`` (an ``EquilibriumSolver``) from its CasADi
    sparsity pattern (dense if positions are built)."""
    sp = sv.f_grad_hess.sparsity_out(2)
    rows, cols = sp.get_triplet()
    return int(max((abs(r - c) for r, c in zip(rows, cols)), default=0))
