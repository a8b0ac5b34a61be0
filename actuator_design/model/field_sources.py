"""Magnets and coils as field sources: magpylib builds them, solid harmonics represent them.

The public face of real field sources: :class:`MagnetSource` and :class:`CoilSource`
(:mod:`actuator_design.model.sources`, with magpylib's field of them), their fit over the rod's reach
(:mod:`actuator_design.model.source_fit`: zonal harmonics for sources axisymmetric about an axis in the
plane, tesseral ones for a cuboid or a diametric cylinder), and the fit's errors measured against
magpylib at random points of the reach and on the edges of the reach and of each fit's region:
those errors are reported with the scene.

Units: SI in (m, A/m, A); the fitted field is dimensionless, positions in units of the rod length ℓ
and the field in units of H0, the largest |H| over the part of the reach disc (|r| ≤ ℓ) outside
every source (THEORY §5: H0 sets the groups h, h_pos and h_r).
"""
from __future__ import annotations

import functools
import math
from dataclasses import replace
from typing import Tuple

import numpy as np

from actuator_design.model.coil_map import fit_map
from actuator_design.model.scene import SourceField
from actuator_design.model.source_fit import (FittedField, checked_gradient, fit_one, geometry,
                                              outside_sources, reach_grid)
from actuator_design.model.sources import (CoilSource, MagnetSource, MappedCoil, magpylib_field,
                                           magpylib_objects)
from actuator_design.physics.harmonic import field_function

__all__ = ["MagnetSource", "CoilSource", "MappedCoil", "FittedField", "fit_sources", "source_field", "magpylib_field",
           "magpylib_objects", "FIT_TOLERANCE"]

#: Default fit tolerance per source, relative to H0 (the total over a few sources stays ≤ 1e-6).
FIT_TOLERANCE = 1e-7


@functools.lru_cache(maxsize=32)
def fit_sources(sources: Tuple, length: float, tol: float = FIT_TOLERANCE, checks: int = 400) -> FittedField:
    """Fit every source and measure the total's error against magpylib at ``checks`` random points
    and along the edges of the reach and of each fit's region.

    Parameters
    ----------
    sources : tuple of MagnetSource or CoilSource, or of MappedCoil (:func:`~actuator_design.model.coil_map.fit_map`)
    length : float
        ℓ, m.
    tol : float
        Fit tolerance per source relative to H0.
    checks : int
        Random points (fixed seed) of the reach where the fit holds, for the reported errors, with
        checks/2 points on the edge of the reach and on that of each fit's region (within the reach).

    Raises
    ------
    ValueError
        When the rod's reach has no point outside the sources, the field there is zero, or a source
        cannot be fitted anywhere in the reach.
    """
    import casadi as ca

    if any(isinstance(s, MappedCoil) for s in sources):
        if not all(isinstance(s, MappedCoil) for s in sources):
            raise ValueError("coils from a calibration map cannot be mixed with magnets or modelled coils")

        return fit_map(sources, length, tol)
    geo = [geometry(s, length) for s in sources]
    grid = reach_grid()
    grid = grid[outside_sources(grid, geo)]
    if len(grid) == 0:
        raise ValueError("the rod's reach lies inside the sources: no point of it is outside every magnet and coil")
    H = magpylib_field(sources, np.column_stack([grid * length, np.zeros(len(grid))]))
    h0 = float(np.max(np.linalg.norm(H[:, :2], axis=1)))
    if not (h0 > 0 and math.isfinite(h0)):
        raise ValueError("the sources give no field in the rod's plane over its reach")
    fits = [fit_one(s, length, h0, tol) for s in sources]
    terms = tuple(replace(t, coefficients=tuple(v / h0 for v in t.coefficients)) for t, _ in fits)
    # the reported errors: random points of the reach where every fit holds
    rng = np.random.default_rng(20261204)
    pts = rng.uniform(-1.0, 1.0, (8 * checks, 2))
    pts = pts[(np.hypot(pts[:, 0], pts[:, 1]) <= 1.0)]
    # and the edges of the reach and of the fits' regions, where a truncated series errs most
    # (random points alone under-reported a cylinder's error 100-fold)
    turn = np.linspace(0.0, 2 * np.pi, checks // 2, endpoint=False)
    circles = [((0.0, 0.0), 1.0)] + [(t.centre, t.valid_radius) for t in terms]
    edges = [np.column_stack([c[0] + r * np.cos(turn), c[1] + r * np.sin(turn)]) for c, r in circles]
    edges = np.concatenate(edges) if edges else np.zeros((0, 2))
    edges = edges[np.hypot(edges[:, 0], edges[:, 1]) <= 1.0]
    pts = pts[np.all([t.contains(pts[:, 0], pts[:, 1]) for t in terms], axis=0)][:checks]
    edges = edges[np.all([t.contains(edges[:, 0], edges[:, 1]) for t in terms], axis=0)]
    pts = np.concatenate([pts, edges])
    f = field_function(terms)
    xs, ys = ca.SX.sym("x"), ca.SX.sym("y")
    hx, hy = f(xs, ys)
    J = ca.Function("J", [xs, ys], [ca.vertcat(hx, hy), ca.jacobian(ca.vertcat(hx, hy), ca.vertcat(xs, ys))])
    Jm = J.map(len(pts))
    h_fit, g_fit = (np.asarray(v, float) for v in Jm(pts[:, 0], pts[:, 1]))
    h_fit = h_fit.T
    g_fit = g_fit.reshape(2, len(pts), 2).transpose(1, 0, 2)
    h_true = magpylib_field(sources, np.column_stack([pts * length, np.zeros(len(pts))]))[:, :2] / h0
    g_true = checked_gradient(sources, pts, length)[0] / h0
    fit_error = float(np.max(np.linalg.norm(h_fit - h_true, axis=1)))
    grad_error = float(np.max(np.abs(g_fit - g_true)))
    return FittedField(terms, h0, fit_error, grad_error, tuple(o for _, o in fits))


def source_field(sources, length: float, tol: float = FIT_TOLERANCE):
    """The scene field of ``sources`` for a rod of ``length`` (m), and its H0 (A/m).

    Returns
    -------
    (SourceField, float)
    """
    sources = tuple(sources)
    fit = fit_sources(sources, float(length), float(tol))
    return SourceField(terms=fit.terms, sources=sources, length=float(length), fit_error=fit.fit_error,
                       gradient_error=fit.gradient_error, fit_tolerance=float(tol)), fit.h0
