"""The shape design NLP certifies stability as the single-pose one does (issue 18: one certificate):
a segmented LDLᵀ certificate (:class:`Certificate`) with an exact Hessian; a certified solve's
answer is checked here by an independent method — the eigenvalues of the state's reduced Hessian
(``EquilibriumSolver.stability``) — not by the pivots themselves."""
import dataclasses

import casadi as ca
import numpy as np

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.inverse.ldl import Certificate
from actuator_design.inverse.nlp import get_design_nlp
from actuator_design.inverse.settings import DesignSettings
from actuator_design.inverse.shape import ShapeDesignNLP
from actuator_design.model.scene import UniformField, default_scene
from actuator_design.reference.shooting import ShootingParams, solve_shooting

OPTIONS = SolverOptions()


def _scene(h, phi):
    return dataclasses.replace(default_scene(h=h), field=UniformField(phi=phi))


def test_stacked_certificates_give_each_matrix_its_leading_minor_ratios():
    """Two banded matrices certified together: the pivots are each matrix's ratios of leading
    principal minors det A_k / det A_(k-1) (Sylvester, computed by numpy), the lifted entries
    started from zero by as many substitutions as the longer chain."""
    rng = np.random.default_rng(7)
    mats = []
    for n, shift in ((13, 0.3), (9, -0.2)):
        A = np.zeros((n, n))
        for i in range(0, n - 4, 4):  # blocks of 5 sharing a node (the LGL pattern)
            Q = rng.normal(size=(5, 5))
            A[i:i + 5, i:i + 5] += Q @ Q.T / 5
        A -= (np.linalg.eigvalsh(A)[0] - shift) * np.eye(n)
        mats.append(A)
    syms = [ca.SX.sym(f"A{i}", ca.sparsify(ca.DM(A)).sparsity()) for i, A in enumerate(mats)]
    cert = Certificate(syms)
    assert cert.m > 0
    args = [ca.sparsify(ca.DM(A)) for A in mats]
    v = cert.start(ca.Function("s", [*syms, cert.v], [cert.schur]), *args)
    piv = np.asarray(ca.Function("p", [*syms, cert.v], [cert.pivots, cert.rows])(*args, v)[0]).ravel()
    rows = np.asarray(ca.Function("r", [*syms, cert.v], [cert.rows])(*args, v)).ravel()
    ref = np.concatenate([[np.linalg.det(A[:k + 1, :k + 1]) / (np.linalg.det(A[:k, :k]) if k else 1.0)
                           for k in range(len(A))] for A in mats])
    assert np.allclose(piv, ref, rtol=1e-8, atol=1e-10)
    assert np.max(np.abs(rows)) < 1e-12  # the lifted entries are the Schur entries
    for A, p in zip(mats, np.split(piv, [len(mats[0])])):
        assert np.all(p > 0) == (np.linalg.eigvalsh(A)[0] > 0)


def test_a_certified_shape_fit_holds_its_margin():
    """A shape fit asked for more stability than its start has: the certified solve converges to a
    state with λ_min ≥ μ (eigenvalues), closer to the points than the start (a case whose outcome
    holds for inputs moved by 1e-12 … 1e-6; the quasi-Newton certificate before failed it)."""
    ref = solve_shooting(ShootingParams(h=2.0, phi=0.6), 0.5)
    S = [0.25, 0.5, 0.75, 1.0]
    pts = np.array([[s, float(ref.x(s)), float(ref.y(s))] for s in S])
    scene = _scene(1.6, 0.5)
    nlp = get_design_nlp(scene, ("h", "phi", "alpha"), OPTIONS, 4)
    sv = nlp.solver
    start = solve(scene, OPTIONS)
    P = sv.parameter_vector(scene)
    margin = 1.05 * sv.stability(start.z, P).eigenvalues[0]
    shape = ShapeDesignNLP(nlp, pts[:, 0])

    def rms(z, P):
        xs, ys = (np.asarray(v, float).ravel() for v in shape.f_points(z[1:], P))
        return float(np.sqrt(np.mean((xs - pts[:, 1]) ** 2 + (ys - pts[:, 2]) ** 2)))

    d, z, ok, status = shape.solve(scene, pts, nlp.design_vector(h=1.6, phi=0.5), start.z, margin=margin,
                                   bounds=DesignSettings().bounds(), certified=True)
    assert ok, status
    Pd = sv.parameter_vector(nlp.scene_for(scene, d))
    assert sv.stability(z, Pd).eigenvalues[0] >= margin * (1 - 1e-6)
    assert rms(z, Pd) < rms(start.z, P)
