"""The fibre-layout gauge of a uniform soft field: (α + c, φ + c) is one actuator state.

In a uniform field the soft-magnetic energy reads cos²(θ + α − φ) (THEORY §5): shifting the whole
fibre layout and the field angle by one constant c leaves every equilibrium, its stability and its
tolerance box unchanged. A design that varies both then has a flat valley along that orbit (the
smoothness effort does not see α's mean), and which point of it IPOPT returns depends on
round-off: on the default scene the BLAS kernel picked h = 7.048, 6.848 or 6.861 for the target
(0.5, 0.5) (issue 17). The design fixes the orbit by a stated rule, α's mean c_0 = 0
(:meth:`~actuator_design.inverse.nlp.DesignNLP.fix_gauge`).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

__all__ = ["has_fibre_gauge"]


def has_fibre_gauge(zr, d, P0, E, dmap, P_scene: np.ndarray, trials: int = 3) -> bool:
    """Does the energy depend on φ and the fibre layout only through α(s) − φ?

    Parameters
    ----------
    zr, d, P0 : casadi.SX
        The design NLP's free nodes (n,), design vector (nd,) and base parameters.
    E : casadi.SX
        The discrete energy in them.
    dmap : DesignVector
        Where the design vector holds ``"phi"`` and ``"alpha"`` (α's Legendre coefficients).
    P_scene : ndarray
        The base scene's parameter vector (scaled at random around it).
    trials : int

    A hard-magnetic term (θ + β − φ), body anisotropy (θ − φ) or a non-uniform field breaks the
    symmetry; it is detected here, whatever the terms, by the identity ∂E/∂φ + ∂E/∂c_0 = 0 at
    random states, designs and parameters (the NLP is cached per structure, not per value).
    """
    if "alpha" not in dmap or "phi" not in dmap:
        return False
    gE = ca.gradient(E, d)
    f = ca.Function("gauge", [zr, d, P0], [gE[dmap["phi"].start] + gE[dmap["alpha"].start],
                                          gE[dmap["phi"].start]])
    rng = np.random.default_rng(20261202)  # fixed seed: the same verdict on every run
    for _ in range(trials):
        z = rng.uniform(-1.0, 1.0, zr.shape[0])
        dd = rng.uniform(0.2, 1.5, d.shape[0])
        P = np.asarray(P_scene, float) * rng.uniform(0.5, 1.5, P0.shape[0]) + rng.uniform(0.1, 0.5, P0.shape[0])
        both, alone = (float(v) for v in f(z, dd, P))
        if not (math.isfinite(both) and abs(both) <= 1e-9 * (1.0 + abs(alone))):
            return False
    return True
