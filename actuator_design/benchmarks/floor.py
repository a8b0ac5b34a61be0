"""The floor: a plain dense Newton on the same LGL collocation system, written in numpy.

Uniform fields only (the paper's cases): the discrete energy of
:class:`actuator_design.transcription.lgl.LGL` (THEORY §5) is

    Ê(z) = ½ Σ_q w_q b_q (Dz)_q² − h² Σ_q w_q cos²(θ_q + α_q − φ) − f·(Σ_q w_q cos θ_q, Σ_q w_q sin θ_q)
           − m θ_n,          θ_q = (Gz)_q,

with D the spectral differentiation at the quadrature points and G the node gather, so

    ∇Ê = K z + Gᵀ w∘(h² sin 2ψ + f_x sin θ − f_y cos θ) − m e_n,   ψ = θ + α − φ,
    ∇²Ê = K + Gᵀ diag(w∘(2h² cos 2ψ + f_x cos θ + f_y sin θ)) G,   K = Dᵀ diag(w b) D.

Every Newton iteration assembles these with numpy and calls ``numpy.linalg.solve``: what a careful
hand-written implementation costs per solve, the yardstick of the fast path.
"""
from __future__ import annotations

import numpy as np

from actuator_design.transcription.lgl import LGL, differentiation_matrix

__all__ = ["NumpyNewton"]


class NumpyNewton:
    """Dense numpy Newton for a uniform-field scene on ``elements`` × ``degree`` LGL.

    Parameters
    ----------
    elements, degree : int
    """

    def __init__(self, elements: int, degree: int):
        tr = LGL(elements, degree)
        self.tr = tr
        n, nq = tr.nodes.size, tr.quadrature_points.size
        G = np.zeros((nq, n))
        G[np.arange(nq), tr._gidx] = 1.0
        D = np.zeros((nq, n))
        De = differentiation_matrix(degree) / tr.J
        for e in range(elements):
            D[e * (degree + 1):(e + 1) * (degree + 1), e * degree:e * degree + degree + 1] = De
        self.G, self.D, self.w = G, D, tr.quadrature_weights
        self.mass = tr.mass[1:]

    def prepare(self, scene) -> dict:
        """Numbers of a uniform-field scene (no distributed load), including K = Dᵀ diag(w b) D."""
        if scene.field is not None and not scene.field.is_uniform:
            raise ValueError("NumpyNewton: uniform fields only")
        if scene.distributed_load is not None:
            raise ValueError("NumpyNewton: no distributed load")
        s = self.tr.quadrature_points
        b = scene.stiffness(s)
        fx, fy = scene.tip_force or (0.0, 0.0)
        return {"K": self.D.T @ ((self.w * b)[:, None] * self.D),
                "alpha_phi": scene.fibres(s) - scene.phi,
                "h2": scene.h**2 if scene.field is not None else 0.0,
                "fx": float(fx), "fy": float(fy), "m": float(scene.tip_moment or 0.0),
                "theta0": float(scene.theta0)}

    def solve(self, z0: np.ndarray, prep: dict, tol: float = 1e-10, max_iter: int = 30):
        """Full Newton steps from ``z0`` (nodes) for the prepared numbers ``prep``;
        returns (z, converged, iterations)."""
        G, w, K = self.G, self.w, prep["K"]
        h2, fx, fy, ap = prep["h2"], prep["fx"], prep["fy"], prep["alpha_phi"]
        z = np.array(z0, float)
        z[0] = prep["theta0"]
        for it in range(max_iter + 1):
            th = G @ z
            psi2 = 2.0 * (th + ap)
            c, s = np.cos(th), np.sin(th)
            g = K @ z + G.T @ (w * (h2 * np.sin(psi2) + fx * s - fy * c))
            g[-1] -= prep["m"]
            res = np.max(np.abs(g[1:] / self.mass))
            if res <= tol:
                return z, True, it
            if it == max_iter or not np.isfinite(res):
                break
            H = K + G.T @ ((w * (2.0 * h2 * np.cos(psi2) + fx * c + fy * s))[:, None] * G)
            z[1:] -= np.linalg.solve(H[1:, 1:], g[1:])
        return z, False, it
