"""The LDLᵀ stability certificate of the design NLPs: the pivots of a symmetric matrix as CasADi expressions, all > 0
exactly when it is positive definite (Sylvester); the reduced Hessian's bandwidth, and the limit on a dense
certificate's size.

The single-pose, shape and schedule NLPs (:mod:`actuator_design.inverse.nlp`, :mod:`actuator_design.inverse.shape`,
:mod:`actuator_design.schedules.schedule_ocp_nlp`) lift the Schur complement at the element joints
(:class:`SegmentedLDL`, every state of an NLP: :class:`Certificate`). The scenario NLP
(:mod:`actuator_design.robust.design_robust`) takes the same :class:`Certificate` in its nested banded form
(``bandwidth``: :func:`_ldl_pivots`, nothing lifted) with a quasi-Newton Hessian: with the segmented certificate (exact or quasi-Newton Hessian) a two-pose design without a
tolerance box (targets (0.5, 0.5) and (0.6, 0.4)) no longer found its shared layout."""
from __future__ import annotations

from functools import lru_cache
from typing import List

import casadi as ca
import numpy as np

__all__ = ["SegmentedLDL", "Certificate", "certified_hessian", "_ldl_function", "_ldl_pivots", "_bandwidth", "CertificateTooLarge",
           "check_certificate_size", "MAX_DENSE_CERTIFICATE_WORK", "CERTIFICATE_REFUSED"]


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


#: Most expression work a certified NLP may need for dense reduced Hessians: c·n·(n³/3 + I), with
#: n unknowns, I the instructions of the reduced Hessian's function and c the copies (scenarios):
#: the nested pivots of a dense matrix and their Jacobian. Measured with a dipole field's
#: positional term: n = 20 (1.7e6) built in 6 s and 1.2 GB, n = 40 (1.1e7) in 45 s and 7 GB; the
#: shipped dipole example, n = 80 (8.7e7), exhausted 24 GB. Banded Hessians are lifted at cuts
#: (:class:`SegmentedLDL`) and not bounded here.
MAX_DENSE_CERTIFICATE_WORK = 4e6


#: How the refusal's message (and a refused solve's status) begins.
CERTIFICATE_REFUSED = "the stability certificate was not built"


class CertificateTooLarge(ValueError):
    """The stability certificate of a dense reduced Hessian would exceed
    :data:`MAX_DENSE_CERTIFICATE_WORK`; the message says why, in one line."""


#: An NLP with a quasi-Newton Hessian builds only the pivots' Jacobian: about this fraction of the
#: work of an exact Hessian's (an elastic bed under the rod, n = 40: three scenario copies built in
#: 4.9 s and 1.1 GB, one exact-Hessian design NLP in 9.6 s and 1.4 GB).
QUASI_NEWTON_SHARE = 0.25


def check_certificate_size(sv, n: int, copies: int = 1, exact_hessian: bool = True) -> None:
    """Raise :class:`CertificateTooLarge` when the certificate of ``copies`` dense n × n reduced
    Hessians of the solver ``sv`` would be too big to build (banded ones always pass);
    ``exact_hessian`` False for an NLP that approximates its Hessian (:data:`QUASI_NEWTON_SHARE`)."""
    if n < 2 or _bandwidth(sv, n) < n - 1:
        return
    work = copies * n * (n ** 3 / 3.0 + sv.f_grad_hess.n_instructions())
    work *= 1.0 if exact_hessian else QUASI_NEWTON_SHARE
    if work > MAX_DENSE_CERTIFICATE_WORK:
        raise CertificateTooLarge(
            f"{CERTIFICATE_REFUSED}: the reduced Hessian is dense ({n} unknowns"
            f"{f', {copies} scenarios' if copies > 1 else ''}: an energy term couples every point to every "
            f"other) and its LDLT pivots would need ~{work:.1e} expression operations (limit "
            f"{MAX_DENSE_CERTIFICATE_WORK:.0e}, gigabytes of memory): a design is judged by the stability of the "
            "solution found without it (fewer --elements or a lower --degree allow the certificate)")


def certified_hessian(sv, n: int) -> dict:
    """The IPOPT Hessian setting of a certified NLP that may approximate its Hessian (the shape NLP):
    exact for a banded reduced Hessian, whose segmented certificate is block sparse (measured on 36
    certified shape solves: converged and stable 25 times, against 16 with the banded pivots and a
    quasi-Newton Hessian); limited-memory for a dense one, whose nested pivots' exact Hessian would
    need gigabytes (:data:`QUASI_NEWTON_SHARE`, :func:`check_certificate_size` with
    ``exact_hessian=False``)."""
    dense = n >= 2 and _bandwidth(sv, n) >= n - 1
    return {"hessian_approximation": "limited-memory"} if dense else {}


#: A cut lifts the Schur complement when at most this many of its entries were changed since the
#: last cut (1 at an element boundary of the LGL transcription: the shared node's diagonal)...
LIFT_MAX_ENTRIES = 1
#: ... and at least this many columns were eliminated since the last cut.
LIFT_MIN_COLUMNS = 4


class SegmentedLDL:
    """The pivots of A = L D Lᵀ (no pivoting) on A's own sparsity, with the Schur complement
    lifted at cuts: the certificate of one state (:class:`Certificate`).

    On the LGL transcription the reduced Hessian is a chain of dense element blocks that share one
    node (THEORY §4). Eliminating a block's interior changes only the shared node's diagonal entry
    of what is left, so every later pivot depends on every earlier block through it: written as one
    expression (:func:`_ldl_pivots`) the Lagrangian's Hessian of the pivot rows is dense in all
    unknowns and CasADi takes ~0.4 s to build it (n = 40, issue 17). Here that entry becomes an NLP
    unknown v with the row v − S(…) = 0 wherever few entries were changed (a cut): each pivot
    then depends on one block and the v before it, and the Hessian is block sparse. The feasible
    set is unchanged (v is the Schur entry; the pivots are A's). A dense A has no cut: its pivots
    are the plain nested expressions.

    Parameters
    ----------
    A : casadi.SX, shape (n, n)
        Symmetric; its structural zeros are used (no fill is assumed beyond what elimination makes).

    Attributes
    ----------
    pivots : casadi.SX, shape (n,)
        D_j, each ≥ 0 ⇔ A ⪰ 0 (Sylvester, with the v rows satisfied).
    v : casadi.SX, shape (m,)
        The lifted Schur entries (m = 0 without cuts).
    schur : casadi.SX, shape (m,)
        S(A, earlier v): what each v stands for.
    rows : casadi.SX, shape (m,)
        v − S, pinned to 0.
    """

    def __init__(self, A: ca.SX):
        n = A.shape[0]
        rows_nz, cols_nz = A.sparsity().get_triplet()
        S = {(i, k): A[i, k] for i, k in zip(rows_nz, cols_nz) if i >= k}
        below = {j: set() for j in range(n)}  # column j's rows i > j that are nonzero (with fill)
        for i, k in S:
            if i > k:
                below[k].add(i)
        pivots, v, schur, changed, last_cut = [], [], [], set(), -1
        for j in range(n):
            d = S.pop((j, j), ca.SX(0))
            pivots.append(d)
            col = sorted(below.pop(j))
            for a, i in enumerate(col):  # S_ik −= S_ij S_kj / d over the column's pairs
                s_ij = S.pop((i, j))
                for k in col[a:]:
                    upd = s_ij * S[(k, j)] / d if k != i else s_ij * s_ij / d
                    lo, hi = (k, i) if k > i else (i, k)
                    S[(lo, hi)] = S.get((lo, hi), ca.SX(0)) - upd
                    changed.add((lo, hi))
                    if lo > hi:
                        below[hi].add(lo)
            changed = {e for e in changed if e in S}
            if changed and len(changed) <= LIFT_MAX_ENTRIES and j - last_cut >= LIFT_MIN_COLUMNS and j < n - 2:
                for e in sorted(changed):
                    u = ca.SX.sym(f"schur_{e[0]}_{e[1]}")
                    v.append(u)
                    schur.append(S[e])
                    S[e] = u
                changed, last_cut = set(), j
        self.pivots, self.v, self.schur = ca.vertcat(*pivots), ca.vertcat(*v), ca.vertcat(*schur)
        self.rows = self.v - self.schur
        self.m = len(v)

    def start(self, schur: ca.Function, *args) -> np.ndarray:
        """The lifted unknowns at a point, shape (m,): ``schur(*args, v)`` evaluates
        :attr:`schur` (each entry a function of the earlier v only, so m substitutions give all
        of them exactly)."""
        u = np.zeros(self.m)
        for _ in range(self.m):
            u = np.asarray(schur(*args, u), float).ravel()
        return u


class Certificate:
    """The stability certificate of every state a design NLP carries: one :class:`SegmentedLDL`
    per state's matrix M^-1/2 H_r M^-1/2 − μ I, stacked — or, with ``bandwidth``, each matrix's
    nested banded pivots (:func:`_ldl_pivots`, nothing lifted: the scenario NLP's form, see the
    module docstring).

    Parameters
    ----------
    matrices : sequence of casadi.SX, each shape (n, n)
    bandwidth : int, optional
        The matrices' bandwidth: nested pivots instead of lifted segments.

    Attributes
    ----------
    pivots, v, schur, rows : casadi.SX
        As :class:`SegmentedLDL`'s, the states' one after another.
    m : int
        Lifted Schur entries in all.
    """

    def __init__(self, matrices, bandwidth: int = None):
        if bandwidth is not None:
            self.pivots = ca.vertcat(*[ca.vertcat(*_ldl_pivots(A, bandwidth)) for A in matrices])
            self.v = self.schur = self.rows = ca.SX(0, 1)
            self.m, self._depth = 0, 0
            return
        parts = [SegmentedLDL(A) for A in matrices]
        self.pivots = ca.vertcat(*[c.pivots for c in parts])
        self.v = ca.vertcat(*[c.v for c in parts])
        self.schur = ca.vertcat(*[c.schur for c in parts])
        self.rows = self.v - self.schur
        self.m = int(sum(c.m for c in parts))
        self._depth = max((c.m for c in parts), default=0)  # substitutions that settle every chain

    def start(self, schur: ca.Function, *args) -> np.ndarray:
        """The lifted unknowns at a point, shape (m,) (as :meth:`SegmentedLDL.start`: each state's
        entries depend on its own earlier ones, so as many substitutions as the longest chain)."""
        u = np.zeros(self.m)
        for _ in range(self._depth):
            u = np.asarray(schur(*args, u), float).ravel()
        return u
