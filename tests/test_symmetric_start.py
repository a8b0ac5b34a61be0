"""A rod pointing at a small magnet along the magnet's axis (a common bench set-up): by symmetry the
straight rod is an equilibrium, and close to the magnet the energy's curvature is so large (~1e7)
that the gradient's round-off exceeds IPOPT's absolute tolerance. IPOPT, handed that equilibrium (or
a point next to it) by the path from rest, stopped with Search_Direction_Becomes_Too_Small, where its
own gradient scaling does not act; it is now run once more on the energy scaled so that its rounding
is below the tolerance (``EquilibriumSolver.objective_weight``), and Newton confirms the answer.
References: the symmetry (the straight rod, and mirrored answers for mirrored requests); the energy,
written here by hand with the dipole's field, rises when the straight rod is bent either way (it is
stable); the rod turned slightly off the axis stays near it."""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.solver import get_solver
from actuator_design.model.scene import DipoleField, Scene

DIPOLE = (0.0, -1.1)  # 0.1 rod lengths beyond the tip of a rod clamped pointing down at it


def _dipole_field(points):
    """ĥ = [3 (m̂·ρ̂) ρ̂ − m̂]/|ρ|³ of a moment along +y at DIPOLE (THEORY §3), by hand."""
    rho = np.asarray(points, float) - np.array(DIPOLE)
    r = np.linalg.norm(rho, axis=1)[:, None]
    m = np.array([0.0, 1.0])
    return (3 * (rho @ m)[:, None] * rho / r ** 2 - m) / r ** 3


def _scene(h, turn=0.0, load=None):
    return Scene(field=DipoleField(x0=DIPOLE[0], y0=DIPOLE[1], moment_angle=0.5 * math.pi), h=h,
                 theta0=-0.5 * math.pi + turn, tip_force=load)


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
    assert "then with the energy weighted by" in r.message  # the rescue ran, and says so
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


@pytest.mark.parametrize("turn, load", [(1e-6, None), (0.0, (0.01, 0.0))])
def test_a_request_next_to_the_axis_and_its_mirror_image_give_mirrored_rods(turn, load):
    """A clamp turned by 1e-6 rad, or a transverse tip load of 0.01 (a start that is not an
    equilibrium, but within 1e-10 rad of one): both converge, and the mirrored request (about the
    magnet's axis, x -> -x) gives the mirrored rod."""
    h = 30.0
    mirrored = None if load is None else (-load[0], load[1])
    a, b = solve(_scene(h, turn, load)), solve(_scene(h, -turn, mirrored))
    assert a.success and b.success and a.stable and b.stable, (a.message, b.message)
    assert a.tip["x"] == pytest.approx(-b.tip["x"], abs=1e-12)
    assert a.tip["y"] == pytest.approx(b.tip["y"], abs=1e-12)
    assert np.allclose(a.theta + 0.5 * math.pi, -(b.theta + 0.5 * math.pi), atol=1e-10)
    if load is not None:
        assert a.tip["x"] > 0.0  # pushed the way it is loaded


def test_the_energy_is_weighted_only_where_its_rounding_is_above_the_tolerance():
    """Near the magnet the gradient's rounding at the straight rod is above IPOPT's 1e-10, so the
    rescue weights the energy; the default uniform-field cantilever is never weighted."""
    opts = SolverOptions()
    near = _scene(30.0)
    sv = get_solver(near, opts)
    z = np.full(sv.transcription.nodes.size, -0.5 * math.pi)
    assert sv.objective_weight(z, sv.parameter_vector(near)) < 1e-2
    plain = Scene(h=3.0)
    sv = get_solver(plain, opts)
    z = np.zeros(sv.transcription.nodes.size)
    assert sv.objective_weight(z, sv.parameter_vector(plain)) == 1.0
