"""The centreline at given arc lengths as exact linear maps of a transcription's nodal angles.

r(s_i) = ∫₀^{s_i} (cos θ, sin θ) dσ is evaluated by a 16-point Gauss–Legendre rule on every element
piece of [0, s_i] (θ is one polynomial on each piece, so the rule's error is that of integrating
cos θ and sin θ of a smooth polynomial: round-off for the pieces of a resolved mesh), and θ at those
Gauss points is a linear map of the nodal values z: θ(σ) = L z. Then

    x_i = Σ_j W_ij cos((L z)_j),    y_i = Σ_j W_ij sin((L z)_j).

Used by the shape designs (:mod:`actuator_design.inverse.shape`, :mod:`actuator_design.hardware.current_shape`).
"""
from __future__ import annotations

from typing import Sequence, Tuple

import casadi as ca
import numpy as np

__all__ = ["arc_point_maps", "arc_points_function", "GAUSS_POINTS"]

#: Gauss–Legendre points per element piece
GAUSS_POINTS = 16


def arc_point_maps(transcription, s_points: Sequence[float]) -> Tuple[np.ndarray, np.ndarray]:
    """(L, W): θ at the Gauss points of every element piece of [0, s_i] as ``L @ z`` (shape
    (g, n_nodes)), and the weights that sum cos θ and sin θ there into x_i and y_i (shape (k, g)),
    for the arc lengths ``s_points`` (k,) in (0, 1]."""
    gx, gw = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    bps = np.asarray(transcription.breakpoints, float)
    sig, blocks = [], []
    for i, si in enumerate(s_points):
        for a, b in zip(bps[:-1], bps[1:]):
            if a >= si:
                break
            b2 = min(b, si)
            sig.append(0.5 * (a + b2) + 0.5 * (b2 - a) * gx)
            blocks.append((i, 0.5 * (b2 - a) * gw))
    sig = np.concatenate(sig)
    W = np.zeros((len(s_points), sig.size))
    col = 0
    for i, w in blocks:
        W[i, col:col + w.size] = w
        col += w.size
    n_nodes = int(np.asarray(transcription.nodes).size)
    eye = np.eye(n_nodes)
    L = np.column_stack([transcription.theta_dense(eye[j], sig)[0] for j in range(n_nodes)])
    return L, W


def arc_points_function(transcription, s_points: Sequence[float]) -> ca.Function:
    """z (n_nodes,) → (x (k,), y (k,), ∂x/∂z (k, n_nodes), ∂y/∂z (k, n_nodes)) at ``s_points``."""
    L, W = arc_point_maps(transcription, s_points)
    z = ca.SX.sym("z", L.shape[1])
    th = ca.mtimes(ca.DM(L), z)
    xs, ys = ca.mtimes(ca.DM(W), ca.cos(th)), ca.mtimes(ca.DM(W), ca.sin(th))
    return ca.Function("arc_points", [z], [xs, ys, ca.densify(ca.jacobian(xs, z)), ca.densify(ca.jacobian(ys, z))])
