"""The Lagrangian's Hessian and the rows' Jacobian of a contact NLP, assembled from their parts.

IPOPT's ``nlp_hess_l`` differentiates Σ_j λ_j d(r_j(θ)) twice through every constrained point,
whatever λ_j is; for a curved lumen (a distance with a branch per segment) one evaluation took
about 1 ms, and Newton's rounds on the contact set call it 10–20 times per solve. The same
matrices follow from the chain rule with small pieces (:mod:`actuator_design.contact.equilibrium`):

    ∂row_j/∂θ = ∇d(r_j) · ∂r_j/∂θ,
    ∇²(Σ λ_j row_j) = Σ_j λ_j (∂r_j/∂θ)ᵀ ∇²d(r_j) (∂r_j/∂θ) + ∇²_θ(wᵀX + vᵀY),
                      w = λ ∂d/∂x, v = λ ∂d/∂y,

with the positions' Jacobian and the last term (diagonal for the spectral and midpoint
transcriptions: positions are sums of cos θ and sin θ) from one small function each, and d with
its first and second derivatives at the m points from the obstacle's own expression. A self-contact
pair row (|r_a − r_b|² − 4 gap²)/(4 gap) is the same with d the squared distance over 4 gap; a
corner pair's plane row ρ (r_a − r_b)·n(θ_B) − 2 gap (:func:`~actuator_design.contact.contact_nlp.corner_body`)
adds the turning of the body point's normal with θ_B, which is linear in θ.

Newton's KKT matrix (:meth:`ContactNLP.kkt`) adds the energy's Hessian from the solver's kernel,
which has the clamp's θ eliminated: its row and column 0 carry the rows' part only. The clamp's
own row fixes that θ, so they change the clamp row's multiplier, never a step. IPOPT's
``hess_lag`` (:class:`HessianCallback`) adds the whole energy Hessian.

The buffers of these functions are shared, as the kernel's are: not thread-safe (each process
builds its own solvers).
"""
from __future__ import annotations

import weakref
from typing import Tuple

import casadi as ca
import numpy as np

__all__ = ["Buffered", "RowDerivatives", "HessianCallback"]


class Buffered:
    """A CasADi function with dense outputs called through its buffer interface: arguments copied
    into, and results read from, preallocated float64 arrays (a sparse result converted with
    ``.full()`` cost ~0.2 ms a call, more than the evaluation).

    Calling it returns its own result arrays (shapes of the outputs, column-major): the next call
    overwrites them. ``source`` is the function given (its instructions are what it costs).
    """

    def __init__(self, f: ca.Function):
        self.source = f
        ins = f.mx_in()
        f = ca.Function(f.name(), ins, [ca.densify(o) for o in f.call(ins)])
        self.args = [np.zeros(f.nnz_in(i)) for i in range(f.n_in())]
        self.res = [np.zeros(f.size_out(i), order="F") for i in range(f.n_out())]
        self._buf, self._eval = f.buffer()
        for i, a in enumerate(self.args):
            self._buf.set_arg(i, memoryview(a))
        for i, r in enumerate(self.res):
            self._buf.set_res(i, memoryview(r.reshape(-1, order="F")))

    def __call__(self, *args):
        if len(args) != len(self.args):
            raise TypeError(f"{self.source.name()} takes {len(self.args)} arguments, {len(args)} given")
        for a, v in zip(self.args, args):
            v = np.asarray(v, float)
            if v.size != a.size:
                raise ValueError(f"{self.source.name()}: an argument of {v.size} values where {a.size} are expected")
            a[:] = v.ravel(order="F")
        self._eval()
        return self.res


class RowDerivatives:
    """The pieces of :meth:`ContactNLP.kkt` that do not need IPOPT's derivative functions.

    Parameters
    ----------
    z, X, Y, T : casadi.SX
        The NLP's unknowns (nodal θ, shape (n,)), the constrained points' positions and their angles
        θ (shape (m,); linear in z).
    obstacles : sequence of obstacles
        Each with ``distance(x, y)`` in CasADi.
    gap : float
        The contact gap (units of ℓ).
    slots : int
        Self-contact pair rows (after the obstacle rows).
    """

    def __init__(self, z, X, Y, T, obstacles, gap: float, slots: int):
        self.m, self.n, self.gap, self.slots = int(X.numel()), int(z.numel()), float(gap), int(slots)
        self.f_pos = Buffered(ca.Function("contact_positions", [z], [X, Y, ca.jacobian(X, z), ca.jacobian(Y, z)]))
        # θ at the clamp and the points is linear in z: its Jacobian is a constant
        self.JT0 = np.asarray(ca.evalf(ca.jacobian(ca.vertcat(z[0], T), z)), float)
        w, v = ca.SX.sym("w", self.m), ca.SX.sym("v", self.m)
        self.f_pos_hess = Buffered(ca.Function("positions_hessian", [z, w, v],
                                                [ca.hessian(ca.dot(w, X) + ca.dot(v, Y), z)[0]]))
        x, y = ca.SX.sym("x"), ca.SX.sym("y")
        self.f_obstacles, self._jets = [], []
        for ob in obstacles:
            d = ob.distance(x, y)
            hd = ca.hessian(d, ca.vertcat(x, y))[0]
            f = ca.Function("obstacle_jet", [x, y], [d, ca.gradient(d, ca.vertcat(x, y)), ca.vec(hd)])
            self.f_obstacles.append(Buffered(f.map(self.m)))
            self._jets.append(f)

    def functions(self):
        """The CasADi functions built (for :func:`~actuator_design.contact.cache.charge`)."""
        return [self.f_pos.source, self.f_pos_hess.source, *self._jets]  # a map shares its function

    def rows_hessian_jacobian(self, z: np.ndarray, pairs: np.ndarray, lam: np.ndarray,
                              jacobian: bool = True) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(∇²_θ Σ_j λ_j row_j, ∂rows/∂θ, rows) at ``z``: shapes (n, n), (n_rows, n) and (n_rows,)
        (without ``jacobian``, the Hessian alone and two empty arrays).

        Parameters
        ----------
        z : ndarray, shape (n,)
        pairs : (ndarray, ndarray, ndarray)
            (Sa − Sb, B, ρ) of the pair rows (:meth:`ContactNLP._pairs`): the one-hot selections'
            difference and a corner pair's body selection, shapes (slots, m + 1) (the clamp first,
            then the points), and its side, shape (slots,) (0: a point row).
        lam : ndarray, shape (n_rows,)
            The rows' multipliers (CasADi's sign).
        """
        X, Y, JX, JY = self.f_pos(z)
        X, Y = X.ravel(), Y.ravel()
        H = np.zeros((self.n, self.n))
        w, v = np.zeros(self.m), np.zeros(self.m)
        blocks, values = [], []
        for k, f in enumerate(self.f_obstacles):
            d, grad, hd = f(X, Y)
            dx, dy = grad[0], grad[1]
            if jacobian:
                values.append(d.ravel() - self.gap)
                blocks.append(dx[:, None] * JX + dy[:, None] * JY)
            lk = lam[k * self.m:(k + 1) * self.m]
            on = np.flatnonzero(lk)
            if on.size:
                a, b, c = lk[on] * hd[0, on], lk[on] * hd[1, on], lk[on] * hd[3, on]
                Jx, Jy = JX[on], JY[on]
                H += Jx.T @ (a[:, None] * Jx + b[:, None] * Jy) + Jy.T @ (b[:, None] * Jx + c[:, None] * Jy)
                w[on] += lk[on] * dx[on]
                v[on] += lk[on] * dy[on]
        if self.slots:
            diff, B, rho = pairs
            JX0, JY0 = np.vstack([np.zeros(self.n), JX]), np.vstack([np.zeros(self.n), JY])
            Dx, Dy = diff @ np.concatenate([[0.0], X]), diff @ np.concatenate([[0.0], Y])
            JDx, JDy = diff @ JX0, diff @ JY0
            # a plane row ρ D·n(θ_B) − 2 gap ρ² (ρ = 0: the point row alone), n = (−sin, cos), t = (cos, sin)
            th = B @ (self.JT0 @ z)
            Jth = B @ self.JT0
            nx, ny, tx, ty = -np.sin(th), np.cos(th), np.cos(th), np.sin(th)
            Dn, Dt = Dx * nx + Dy * ny, Dx * tx + Dy * ty
            point = 1.0 - rho ** 2
            if jacobian:
                blocks.append(point[:, None] * (Dx[:, None] * JDx + Dy[:, None] * JDy) / (2.0 * self.gap)
                              + rho[:, None] * (nx[:, None] * JDx + ny[:, None] * JDy - Dt[:, None] * Jth))
                values.append(point * (Dx * Dx + Dy * Dy - 4.0 * self.gap ** 2) / (4.0 * self.gap)
                              + rho * Dn - 2.0 * self.gap * rho ** 2)
            lp = lam[len(self.f_obstacles) * self.m:]
            on = np.flatnonzero(lp)
            if on.size:
                scale = lp[on] * point[on] / (2.0 * self.gap)
                H += JDx[on].T @ (scale[:, None] * JDx[on]) + JDy[on].T @ (scale[:, None] * JDy[on])
                # the plane rows' coupling of the points' motion with the body's turning
                lr = lp[on] * rho[on]
                tJ = tx[on, None] * JDx[on] + ty[on, None] * JDy[on]
                cross = tJ.T @ (lr[:, None] * Jth[on])
                H -= cross + cross.T + Jth[on].T @ ((lr * Dn[on])[:, None] * Jth[on])
                # the positions' own curvature, weighted by each pair's pull on its two points
                w += (diff[on].T @ (scale * Dx[on] + lr * nx[on]))[1:]
                v += (diff[on].T @ (scale * Dy[on] + lr * ny[on]))[1:]
        if np.any(w) or np.any(v):
            H += self.f_pos_hess(z, w, v)[0]
        if not blocks:
            return H, np.zeros((0, self.n)), np.zeros(0)
        return H, np.vstack(blocks), np.concatenate(values)


class HessianCallback(ca.Callback):
    """IPOPT's ``hess_lag`` for a contact NLP: σ∇²Ê + ∇²(λᵀg), the upper triangle, from
    ``assemble(z, P, σ, λ)`` (dense, shape (n, n)), through CasADi's buffer interface.

    Given to IPOPT, it spares the NLP's construction the symbolic Hessian of every constrained
    point's distance (a peg's NLP built in 26 ms instead of 106, a curved lumen's in 92 instead of
    334, self-contact's in 45 instead of 350), and each evaluation its cost.

    An exception inside (a bug, memory, Ctrl-C) would reach IPOPT only as a failed evaluation: it
    is kept and raised again by :meth:`raise_error`, which the caller runs after each solve.

    Parameters
    ----------
    name : str
    n, n_p, n_g : int
        Unknowns, parameters and rows of the NLP.
    assemble : bound method (z, P, sigma, lam_g) -> ndarray, shape (n, n)
        Held weakly (its object holds this callback: no reference cycle).
    """

    def __init__(self, name: str, n: int, n_p: int, n_g: int, assemble):
        ca.Callback.__init__(self)
        self.n, self.n_p, self.n_g = int(n), int(n_p), int(n_g)
        self.assemble, self.error = weakref.WeakMethod(assemble), None
        upper = ca.Sparsity.upper(self.n)
        self._upper = (np.asarray(upper.row(), int), np.asarray(upper.get_col(), int))
        self.construct(name, {})

    def get_n_in(self):
        return 4

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ("x", "p", "lam_f", "lam_g")[i]

    def get_name_out(self, i):
        return "triu_hess_gamma_x_x"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense((self.n, self.n_p, 1, self.n_g)[i])

    def get_sparsity_out(self, i):
        return ca.Sparsity.upper(self.n)

    def has_eval_buffer(self):
        return True

    def eval_buffer(self, arg, res):
        try:
            z, P, sigma, lam = (np.frombuffer(a, dtype=float) for a in arg)
            np.frombuffer(res[0], dtype=float)[:] = self.assemble()(z, P, float(sigma[0]), lam)[self._upper]
            return 0
        except BaseException as exc:  # noqa: BLE001 -- kept for raise_error, IPOPT sees a failure
            self.error = exc
            return 1

    def raise_error(self) -> None:
        """Raise what an evaluation since the last call raised, if anything."""
        if self.error is not None:
            exc, self.error = self.error, None
            raise exc
