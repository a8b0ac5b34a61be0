"""The reduced Hessian of an energy that reads positions, assembled from its structure.

A positional term (a non-uniform field, a distributed load) makes the reduced Hessian dense: θ at
every node moves every later position r(s) = ∫₀ˢ (cos θ, sin θ). Differentiating the whole
discrete energy twice symbolically gives an expression graph of O(n³) operations (≈ 50 000 for the
point dipole at degree 12, ≈ 0.2 ms per evaluation). The energy has a simpler structure:

    Ê(u) = F(v(u)),  F(v) = Σ_q w_q V(v_q) + T(v_tip),
    v = (θ_q, κ_q, θ(1), x_q, y_q, x(1), y(1)),

a sum of one density V per quadrature point q (weights w_q) plus the tip energy T (THEORY §4), of
the point kinematics v of the free unknowns u (θ_q, κ_q linear in u; the positions linear in
cos θ_q, sin θ_q). By the chain rule

    ∇²Ê = Φᵀ K Φ,   Φ = ∂v/∂u,   K = ∇²_v F + S,   S = ∇²_θq (μ · r(θ_q)) at μ = ∂F/∂r,

where ∇²_v F is block diagonal (one 4 × 4 block per point, 3 × 3 at the tip) and S — the curvature
of the positions in θ weighted by the force ∂F/∂r — is diagonal for the spectral and midpoint
rules. Φ's rows for θ_q, κ_q, θ(1) are constant; only its position rows change with u. One CasADi
call evaluates K's nonzeros and Φ's position rows (O(n_q) + O(n n_q) operations instead of O(n³));
a sparse and a dense product assemble the Hessian. The gradient is Φᵀ ∇F, the products by Φᵀ in
reverse mode (:meth:`PositionalHessian.gradient_function`: a matrix graph whose dense products run
as C loops). A field enters the per-point derivatives through its jet (ĥ, ∂ĥ/∂r, ∂²ĥ/∂r²), in
closed form for the point dipole. The structure is verified when built (pointwise densities, a
field read at the point itself); otherwise :func:`positional_hessian` returns ``None`` and the
solver differentiates the whole energy as before.
"""
from __future__ import annotations

import copy
from typing import Dict, Optional, Tuple

import casadi as ca
import numpy as np
from scipy import sparse

from actuator_design.physics.fields import FieldModel
from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.physics.term_protocol import node_field_sources

__all__ = ["PositionalHessian", "positional_hessian", "MAPPED_ABOVE"]

#: Per-point derivative functions larger than this (CasADi instructions) are mapped over the points
#: in a matrix graph instead of inlined at every point (the point dipole: ~600; a fitted magnet: ~20 000).
MAPPED_ABOVE = 4000


class _FieldAtPoint(FieldModel):
    """A field model whose value at the point is the given symbols ĥ = (h[0], h[1]): the terms'
    densities as functions of (θ, κ, x, y, ĥ), for the chain rule through the field's jet."""

    def __init__(self, h: ca.SX):
        self.h = h

    def value(self, x, y, P):
        return self.h[0], self.h[1]


def _density(terms, kin, Pd):
    V = 0
    for t in terms:
        d = t.density(kin, Pd)
        V = V if d is None else V + d
    return ca.SX(V)


def _same_values(f: ca.Function, g: ca.Function, tries: int = 2) -> bool:
    """Whether f and g (same inputs, scalar output) agree to rounding at random inputs: the point
    (θ, κ, x, y) within 0.3 of the clamp, every other input in [0.5, 1.5] (e.g. a dipole at least
    0.2 away from the point)."""
    rng = np.random.default_rng(1)
    for _ in range(tries):
        args = [0.1 * rng.standard_normal(f.size_in(i)) if i < 4 else rng.uniform(0.5, 1.5, f.size_in(i))
                for i in range(f.n_in())]
        a, b = float(f(*args)), float(g(*args))
        if not (np.isfinite(a) and np.isfinite(b) and abs(a - b) <= 1e-12 * (1.0 + abs(a))):
            return False
    return True


def _derivatives_through_jet(terms, p, fsyms, Pd, P, density):
    """(∇_p V, ∇²_p V) with the field through its jet, or ``None`` when no term reads a
    non-uniform field or a term does not read it at the point itself (automatic differentiation
    of V then)."""
    th, kap, x, y = ca.vertsplit(p)
    readers = [t for t in terms if isinstance(getattr(t, "field", None), FieldModel)
               and not t.field.is_uniform]
    if not readers or len({t.field.structure() for t in readers}) != 1:
        return None
    hv = ca.SX.sym("h", 2)
    proxy = _FieldAtPoint(hv)
    with_proxy = []
    for t in terms:
        if t in readers:
            t = copy.copy(t)
            t.field = proxy
        with_proxy.append(t)
    V = _density(with_proxy, PlanarKinematics(th, kap, fsyms, positions=(x, y)), Pd)
    h, J, T = readers[0].field.jet(x, y, Pd)
    if not _same_values(density, ca.Function("density_jet", [th, kap, x, y, *fsyms.values(), P],
                                             [ca.substitute(V, hv, h)])):
        return None
    Vp, Vh = ca.gradient(V, p), ca.gradient(V, hv)
    Vpp, Vph, Vhh = ca.hessian(V, p)[0], ca.jacobian(Vp, hv), ca.hessian(V, hv)[0]
    E = ca.horzcat(ca.SX(2, 2), J)  # ∂ĥ/∂(θ, κ, x, y)
    VphE = ca.mtimes(Vph, E)
    grad = Vp + ca.mtimes(E.T, Vh)
    hess = (Vpp + VphE + VphE.T + ca.mtimes(E.T, ca.mtimes(Vhh, E))
            + ca.diagcat(ca.SX(2, 2), Vh[0] * T[0] + Vh[1] * T[1]))
    grad, hess = ca.substitute([grad, hess], [hv], [h])
    return grad, hess


def _point_functions(terms, layout, P):
    """The density V of all terms at one point and its derivatives, and the tip energy T.

    The field enters V through its jet (:meth:`~actuator_design.physics.fields.FieldModel.jet`):
    with p = (θ, κ, x, y), ĥ = ĥ(x, y), E = ∂ĥ/∂p = [0 0 J],

        ∇_p V = V_p + Eᵀ V_ĥ,
        ∇²_p V = V_pp + V_pĥ E + Eᵀ V_ĥp + Eᵀ V_ĥĥ E + Σ_i V_ĥi T_i  (T_i in the (x, y) block),

    so closed-form field derivatives replace the automatic differentiation of the field.

    Returns
    -------
    density : Function (θ, κ, x, y, *fields, P) -> V, fields in ``node_field_sources`` order
    derivatives : Function (p (4,), *fields, P) -> (∇_p V (4,), ∇²_p V nonzeros)
    hess_sparsity : Sparsity of ∇²_p V (4 × 4)
    tip : Function (θ(1), x(1), y(1), P) -> T
    names : list of str
        The per-point field names.
    """
    p = ca.SX.sym("p", 4)
    th, kap, x, y = ca.vertsplit(p)
    names = list(node_field_sources(terms))
    fsyms = {name: ca.SX.sym(name) for name in names}
    Pd = {**layout.symbols(P), **fsyms}
    kin = PlanarKinematics(th, kap, fsyms, positions=(x, y))
    V = _density(terms, kin, Pd)
    density = ca.Function("density", [th, kap, x, y, *fsyms.values(), P], [V])
    jet = _derivatives_through_jet(terms, p, fsyms, Pd, P, density)
    grad, hess = jet if jet is not None else (ca.gradient(V, p), ca.hessian(V, p)[0])
    derivatives = ca.Function("point_derivatives", [p, *fsyms.values(), P],
                              [grad, ca.vertcat(*hess.nonzeros())], {"cse": True})
    tip_kin = PlanarTip(theta=th, x=x, y=y)
    T_tip = 0
    for t in terms:
        e = t.tip(tip_kin, Pd)
        T_tip = T_tip if e is None else T_tip + e
    tip = ca.Function("tip_energy", [th, x, y, P], [ca.SX(T_tip)])
    return density, derivatives, hess.sparsity(), tip, names


def _hessian_entries(expr: ca.SX, wrt: ca.SX) -> Tuple[ca.SX, ca.SX, np.ndarray, np.ndarray]:
    """(∇ expr, ∇² expr nonzeros, their rows, cols) in ``wrt``."""
    H = ca.hessian(expr, wrt)[0]
    rows, cols = H.sparsity().get_triplet()
    return (ca.gradient(expr, wrt), ca.vertcat(*H.nonzeros()), np.asarray(rows, np.intp),
            np.asarray(cols, np.intp))


class PositionalHessian:
    """Evaluates the reduced Hessian Φᵀ K Φ of a positional energy into a given array.

    Parameters
    ----------
    transcription : Transcription
    terms : list of EnergyTerm
    layout : ParamLayout
    P : SX, shape (n_p,)
        The NLP parameter vector symbol (the solver's ``discrete.params``).
    energy : casadi.Function, optional
        ``(z (n + 1,), P) -> Ê``, the transcribed energy: checked at random points against the
        pointwise sum Σ_q w_q V_q + T (a term whose density couples points is refused).

    Raises
    ------
    ValueError
        The energy does not have the pointwise structure (the caller falls back to the symbolic
        Hessian).
    """

    def __init__(self, transcription, terms, layout, P, energy: Optional[ca.Function] = None):
        tr = transcription
        nq = tr.quadrature_points.size
        self.n = n = tr.nodes.size - 1
        u = ca.SX.sym("u", n)
        z = ca.vertcat(P[layout.slices["theta0"]], u)
        thq, kq = tr.point_values(z)
        lin = ca.vertcat(thq, kq, z[-1])
        phi_lin = ca.jacobian(lin, u)
        if ca.depends_on(phi_lin, u):
            raise ValueError("the point values are not linear in the unknowns")

        def positions(theta_q):
            xq, yq = tr.point_positions(theta_q)
            xt, yt = tr.tip_position(theta_q)
            return ca.vertcat(xq, yq, xt, yt)

        pos = positions(thq)
        xq, yq, xt, yt = pos[:nq], pos[nq:2 * nq], pos[2 * nq], pos[2 * nq + 1]
        density, point, hess_sp, tip, names = _point_functions(terms, layout, P)
        fields = [P[layout.slices[name]] for name in names]
        w = np.asarray(tr.quadrature_weights, float)

        # index in v = (θ_q, κ_q, θ(1), x_q, y_q, x(1), y(1)) of a point's (θ, κ, x, y), the tip's
        point_index = lambda q: np.array([q, nq + q, 2 * nq + 1 + q, 3 * nq + 1 + q])
        tip_index = np.array([2 * nq, 4 * nq + 1, 4 * nq + 2])
        m = 4 * nq + 3
        entries: Dict[Tuple[int, int], ca.SX] = {}

        def add(index, values, rows, cols, scale=1.0):
            for k, (r, c) in enumerate(zip(index[rows], index[cols])):
                key = (int(r), int(c))
                entries[key] = entries.get(key, 0) + scale * values[k]

        rV, cV = (np.asarray(a, np.intp) for a in hess_sp.get_triplet())
        if point.n_instructions() > MAPPED_ABOVE:
            self._build_mapped(tr, layout, P, u, z, lin, positions, density, point, tip, names, fields, w,
                               point_index, tip_index, m, rV, cV, energy)
            return
        fth, fk, fx, fy = [], [], [], []  # w_q ∂V/∂(θ, κ, x, y) at each point
        F = 0
        for q in range(nq):
            g_q, h_q = point(ca.vertcat(thq[q], kq[q], xq[q], yq[q]), *[f[q] for f in fields], P)
            add(point_index(q), ca.vertsplit(h_q), rV, cV, w[q])
            fth.append(w[q] * g_q[0])
            fk.append(w[q] * g_q[1])
            fx.append(w[q] * g_q[2])
            fy.append(w[q] * g_q[3])
            F = F + w[q] * density(thq[q], kq[q], xq[q], yq[q], *[f[q] for f in fields], P)
        pt = ca.SX.sym("pt", 3)
        gT, hT, rT, cT = _hessian_entries(tip(pt[0], pt[1], pt[2], P), pt)
        g_t, h_t = ca.Function("tip_derivatives", [pt, P], [gT, hT], {"cse": True})(
            ca.vertcat(z[-1], xt, yt), P)
        add(tip_index, ca.vertsplit(h_t), rT, cT)
        force = ca.vertcat(*fx, *fy, g_t[1], g_t[2])  # μ = ∂F/∂(x_q, y_q, x(1), y(1))
        F = F + tip(z[-1], xt, yt, P)
        # ∇Ê = Φᵀ ∇F, the products by Φᵀ in reverse mode
        self.u = u
        pv, fv = ca.SX.sym("p", 4), [ca.SX.sym(name) for name in names]
        point_gradient = ca.Function("point_gradient", [pv, *fv, P], [point(pv, *fv, P)[0]], {"cse": True})
        # what the matrix-graph gradient (gradient_function) is built from
        self._parts = dict(transcription=tr, layout=layout, names=names, positions=positions,
                           tip_gradient=ca.Function("tip_gradient", [pt, P], [gT]),
                           point_gradient=point_gradient)
        self.gradient = (ca.jtimes(lin, u, ca.vertcat(*fth, *fk, g_t[0]), True)
                         + ca.jtimes(pos, u, force, True))
        # S: the positions' curvature in θ_q weighted by the force μ
        th_s, mu_s = ca.SX.sym("th", nq), ca.SX.sym("mu", 2 * nq + 2)
        S = ca.hessian(ca.dot(mu_s, positions(th_s)), th_s)[0]
        S = ca.substitute(S, ca.vertcat(th_s, mu_s), ca.vertcat(thq, force))
        rS, cS = S.sparsity().get_triplet()
        add(np.arange(nq), S.nonzeros(), np.asarray(rS, np.intp), np.asarray(cS, np.intp))

        keys = sorted(entries)  # row-major: K's nonzeros are the data of a CSR matrix
        rows = np.array([k[0] for k in keys], np.intp)
        cols = np.array([k[1] for k in keys], np.intp)
        k_nz = ca.vertcat(*[entries[k] for k in keys])
        phi_pos_T = ca.densify(ca.jacobian(pos, u)).T  # (n, n_pos): C order (n_pos, n) in memory
        self._outputs = (u, P, k_nz, phi_pos_T)
        self.function = ca.Function("positional_hessian", [u, P], [k_nz, phi_pos_T], {"cse": True})
        if energy is not None:
            self._check_pointwise(ca.Function("pointwise_energy", [u, P], [F]), energy, P.numel(),
                                  layout.slices["theta0"].start)

        self._finish(tr, u, lin, P, rows, cols, m)

    def _finish(self, tr, u, lin, P, rows, cols, m) -> None:
        """K's CSR structure (rows, cols sorted row-major) and Φ's constant rows."""
        n = self.n
        phi_lin = ca.jacobian(lin, u)
        indptr = np.searchsorted(rows, np.arange(m + 1))
        # K sparse (per-point blocks); the CasADi call writes its nonzeros into the CSR data
        self._K = sparse.csr_matrix((np.zeros(len(rows)), cols, indptr), shape=(m, m))
        assert self._K.has_canonical_format  # sorted, no duplicates: scipy never rewrites its data
        self._k_nz = self._K.data
        n_lin = lin.numel()
        self._phi = np.zeros((m, n))  # C order: its position rows are one contiguous block
        P0 = ca.DM.zeros(P.numel())
        self._phi[:n_lin] = np.asarray(ca.evalf(ca.densify(ca.substitute(phi_lin, P, P0))))
        self._phi_pos = self._phi[n_lin:]

    def _build_mapped(self, tr, layout, P, u, z, lin, positions, density, point, tip, names, fields, w,
                      point_index, tip_index, m, rV, cV, energy) -> None:
        """The Hessian as a matrix graph (MX) whose per-point derivatives are one SX function
        mapped over the points, for fields whose jet is large (a fitted magnet or coil field:
        ~20 000 operations a point, where inlining them at every point and eliminating common
        subexpressions took ~10 s to build). Same numbers as the inlined graph, assembled by a
        constant sparse matrix: K's nonzeros = A · (w_q ∇²V_q nonzeros, tip's, S's)."""
        nq = tr.quadrature_points.size
        nv = rV.size
        pt = ca.SX.sym("pt", 3)
        gT, hT, rT, cT = _hessian_entries(tip(pt[0], pt[1], pt[2], P), pt)
        tip_derivatives = ca.Function("tip_derivatives", [pt, P], [gT, hT], {"cse": True})
        th_s, mu_s = ca.SX.sym("th", nq), ca.SX.sym("mu", 2 * nq + 2)
        S = ca.hessian(ca.dot(mu_s, positions(th_s)), th_s)[0]
        rS, cS = (np.asarray(a, np.intp) for a in S.sparsity().get_triplet())
        s_fn = ca.Function("position_curvature", [th_s, mu_s], [ca.vertcat(*S.nonzeros())])
        pos_sx = positions(tr.point_values(z)[0])
        phi_fn = ca.Function("position_rows", [u, P], [ca.densify(ca.jacobian(pos_sx, u)).T])
        # where each source value goes in K: sources = (h_q nonzeros for q = 0.., tip's, S's)
        keys_of = [(int(point_index(q)[rV[k]]), int(point_index(q)[cV[k]]), w[q]) for q in range(nq)
                   for k in range(nv)]
        keys_of += [(int(tip_index[r]), int(tip_index[c]), 1.0) for r, c in zip(rT, cT)]
        keys_of += [(int(r), int(c), 1.0) for r, c in zip(rS, cS)]
        keys = sorted({(r, c) for r, c, _ in keys_of})
        where = {k: i for i, k in enumerate(keys)}
        A = sparse.csr_matrix(([wt for _, _, wt in keys_of], ([where[(r, c)] for r, c, _ in keys_of],
                                                             np.arange(len(keys_of)))),
                              shape=(len(keys), len(keys_of)))
        A_dm = ca.DM(ca.Sparsity(A.shape[0], A.shape[1], A.tocsc().indptr.tolist(), A.tocsc().indices.tolist()),
                     A.tocsc().data)
        # the graph
        Pm, um = ca.MX.sym("P", layout.size), ca.MX.sym("u", self.n)
        zm = ca.vertcat(Pm[layout.slices["theta0"].start], um)
        thq, kq = tr.point_values(zm)
        pos = positions(thq)
        points = ca.horzcat(thq, kq, pos[:nq], pos[nq:2 * nq]).T
        fm = [Pm[layout.slices[name]].T for name in names]
        gq, hq = point.map(nq)(points, *fm, Pm)  # (4, n_q), (n_v, n_q)
        g_t, h_t = tip_derivatives(ca.vertcat(zm[-1], pos[2 * nq], pos[2 * nq + 1]), Pm)
        wT = ca.DM(w).T
        force = ca.vertcat((gq[2, :] * wT).T, (gq[3, :] * wT).T, g_t[1], g_t[2])
        k_nz = ca.mtimes(A_dm, ca.vertcat(ca.vec(hq), h_t, s_fn(thq, force)))
        phi_pos_T = phi_fn(um, Pm)
        self.u, self.gradient = u, None  # no SX gradient: gradient_function serves (no JIT path)
        pv, fv = ca.SX.sym("p", 4), [ca.SX.sym(name) for name in names]
        self._parts = dict(transcription=tr, layout=layout, names=names, positions=positions,
                           tip_gradient=ca.Function("tip_gradient", [pt, P], [gT]),
                           point_gradient=ca.Function("point_gradient", [pv, *fv, P], [point(pv, *fv, P)[0]]))
        self._outputs = (um, Pm, k_nz, phi_pos_T)
        self.function = ca.Function("positional_hessian", [um, Pm], [k_nz, phi_pos_T])
        if energy is not None:
            th_sx, k_sx = tr.point_values(z)
            F = sum((w[q] * density(th_sx[q], k_sx[q], pos_sx[q], pos_sx[nq + q], *[f[q] for f in fields], P)
                     for q in range(nq)), ca.SX(0))
            F = F + tip(z[-1], pos_sx[2 * nq], pos_sx[2 * nq + 1], P)
            self._check_pointwise(ca.Function("pointwise_energy", [u, P], [F]), energy, P.numel(),
                                  layout.slices["theta0"].start)
        rows = np.array([k[0] for k in keys], np.intp)
        cols = np.array([k[1] for k in keys], np.intp)
        self._finish(tr, u, lin, P, rows, cols, m)

    def gradient_function(self, inv_mass: np.ndarray) -> ca.Function:
        """``(u, P) -> (∇Ê (n,), max_i |∇Ê_i| inv_mass_i)`` as a matrix graph (MX): the point
        kinematics and the products by Φᵀ are dense matrix–vector products run as loops in C, the
        per-point derivatives one SX function mapped over the points (the same numbers as
        :attr:`gradient`, fewer interpreted operations)."""
        parts = self._parts
        tr, layout, names, positions = (parts[k] for k in ("transcription", "layout", "names", "positions"))
        tip_gradient, point_gradient = parts["tip_gradient"], parts["point_gradient"]
        nq = tr.quadrature_points.size
        P = ca.MX.sym("P", layout.size)
        u = ca.MX.sym("u", self.n)
        z = ca.vertcat(P[layout.slices["theta0"].start], u)
        thq, kq = tr.point_values(z)
        lin = ca.vertcat(thq, kq, z[-1])
        pos = positions(thq)
        points = ca.horzcat(thq, kq, pos[:nq], pos[nq:2 * nq]).T  # (4, n_q)
        fields = [P[layout.slices[name]].T for name in names]  # (1, n_q) each
        gq = point_gradient.map(nq)(points, *fields, P) * ca.repmat(
            ca.DM(tr.quadrature_weights).T, 4, 1)  # w_q ∂V/∂(θ, κ, x, y), (4, n_q)
        gt = tip_gradient(ca.vertcat(z[-1], pos[2 * nq], pos[2 * nq + 1]), P)
        g = (ca.jtimes(lin, u, ca.vertcat(gq[0, :].T, gq[1, :].T, gt[0]), True)
             + ca.jtimes(pos, u, ca.vertcat(gq[2, :].T, gq[3, :].T, gt[1], gt[2]), True))
        return ca.Function("grad_fast", [u, P], [g, ca.mmax(ca.fabs(g * ca.DM(inv_mass)))])

    def compile(self, options: dict) -> None:
        """Rebuild :attr:`function` with CasADi ``options`` (e.g. JIT compilation); call before
        :meth:`bind`. Raises what CasADi raises (no compiler)."""
        u, P, k_nz, phi_pos_T = self._outputs
        self.function = ca.Function("positional_hessian", [u, P], [k_nz, phi_pos_T], options)

    def _check_pointwise(self, pointwise: ca.Function, energy: ca.Function, n_p: int,
                         i_theta0: int) -> None:
        """Σ_q w_q V_q + T must be the transcribed energy (no term couples points): checked at
        random rods near the axis (θ0 = 0, |θ| ≲ 0.3) and parameters in [0.5, 1.5] (a dipole at
        least 0.2 away from the rod)."""
        rng = np.random.default_rng(0)
        for _ in range(2):
            u = 0.1 * rng.standard_normal(self.n)
            p = rng.uniform(0.5, 1.5, n_p)
            p[i_theta0] = 0.0
            a = float(pointwise(u, p))
            b = float(energy(np.concatenate(([0.0], u)), p))
            if not (np.isfinite(a) and np.isfinite(b) and abs(a - b) <= 1e-12 * (1.0 + abs(b))):
                raise ValueError("the energy is not a sum of pointwise densities")

    def bind(self, u: np.ndarray, p: np.ndarray, hessian_out: np.ndarray):
        """Bind the input arrays u (n,), p (n_p,) and the output array (n, n), C order.

        Returns the evaluator: a callable of no arguments that writes ∇²Ê at (u, p) into
        ``hessian_out``.
        """
        buf, ev = self.function.buffer()
        buf.set_arg(0, memoryview(u))
        buf.set_arg(1, memoryview(p))
        buf.set_res(0, memoryview(self._k_nz))
        buf.set_res(1, memoryview(self._phi_pos))
        K, phi, phi_T = self._K, self._phi, self._phi.T

        knz = self._k_nz

        def evaluate():
            ev()
            if K.data is not knz:  # the CasADi buffer writes into this very array
                raise RuntimeError("the sparse K matrix was rebuilt behind the evaluator")
            np.dot(phi_T, K @ phi, out=hessian_out)

        evaluate.owner = (self, buf)  # the function and the buffer must outlive the evaluator
        return evaluate


def positional_hessian(transcription, terms, layout, P,
                       energy: Optional[ca.Function] = None) -> Optional[PositionalHessian]:
    """A :class:`PositionalHessian`, or ``None`` when the energy does not have its structure."""
    try:
        return PositionalHessian(transcription, terms, layout, P, energy)
    except ValueError:
        return None
