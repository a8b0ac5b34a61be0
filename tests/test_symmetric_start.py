"""A rod pointing at a small magnet along the magnet's axis (a common bench set-up): by symmetry the
straight rod is an equilibrium, and close to the magnet the energy's curvature is so large (~1e7)
that the gradient's round-off exceeds IPOPT's absolute tolerance. IPOPT, handed that equilibrium by
the path from rest, stops with Search_Direction_Becomes_Too_Small; Newton confirms the start without
moving from it. That is an equilibrium found, not a failed minimisation (issue 10 keeps every other
IPOPT failure a failure). References: the symmetry; the energy, written here by hand with the
dipole's field, rises when the straight rod is bent either way (it is stable); the rod turned
slightly off the axis stays near it."""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import DipoleField, Scene

DIPOLE = (0.0, -1.1)  # 0.1 rod lengths beyond the tip of a rod clamped pointing down at it


def _dipole_field(points):
    """ĥ = [3 (m̂·ρ̂) ρ̂ − m̂]/|ρ|³ of a moment along +y at DIPOLE (THEORY §3), by hand."""
    rho = np.asarray(points, float) - np.array(DIPOLE)
    r = np.linalg.norm(rho, axis=1)[:, None]
    m = np.array([0.0, 1.0])
    return (3 * (rho @ m)[:, None] * rho / r ** 2 - m) / r ** 3


def _scene(h, turn=0.0):
    return Scene(field=DipoleField(x0=DIPOLE[0], y0=DIPOLE[1], moment_angle=0.5 * math.pi), h=h,
                 theta0=-0.5 * math.pi + turn)


def _energy(theta_of_s, h, n=20001):
    """∫ ½θ'² − h² (t·ĥ)² ds by the trapezoidal rule on a fine grid (no h_pos, no loads; the soft
    rod of THEORY §5 with fibres along it), the shape r = ∫ t ds, all by hand."""
    s = np.linspace(0.0, 1.0, n)
    th = theta_of_s(s)
    t = np.column_stack([np.cos(th), np.sin(th)])
    ds = s[1] - s[0]
    r = np.vstack([[0.0, 0.0], np.cumsum(0.5 * (t[1:] + t[:-1]) * ds, axis=0)])
    dth = np.gradient(th, ds)
    e = 0.5 * dth ** 2 - h ** 2 * np.sum(t * _dipole_field(r), axis=1) ** 2
    return float(np.sum(0.5 * (e[1:] + e[:-1])) * ds)


@pytest.mark.parametrize("h", [3.0, 30.0])
def test_the_straight_rod_on_the_magnets_axis_is_found_and_stable(h):
    r = solve(_scene(h))
    assert r.success and r.status == "converged" and r.stable, r.message
    assert "the start is an equilibrium" in r.message
    assert np.allclose(r.theta, -0.5 * math.pi, atol=1e-12)  # the symmetric state, exactly
    assert r.tip["y"] == pytest.approx(-1.0, abs=1e-12)
    # stable: bending it either way, at the tip or along the whole rod, raises the energy (by hand)
    e0 = _energy(lambda s: np.full_like(s, -0.5 * math.pi), h)
    for eps in (1e-3, -1e-3):
        for mode in (lambda s: s ** 2, lambda s: np.sin(0.5 * math.pi * s)):
            assert _energy(lambda s: -0.5 * math.pi + eps * mode(s), h) > e0
    # turned off the axis the rod stays near it: the straight rod is the limit of the turned ones
    for turn in (1e-3, 1e-4):
        off = solve(_scene(h, turn))
        assert off.success and off.stable, off.message
        assert abs(off.tip["x"]) <= 10 * turn
