"""The forward solver against closed forms, conservation laws, symmetries and balance laws.

Every reference here is independent of the solver: a spectrum known in closed form, a first
integral of the Euler–Lagrange equation, a mirror symmetry, a global balance of forces, or the
virtual-work identity between a field-gradient force and the energy's sensitivity to the source.
"""
import math
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import constant_profile, expression_profile
from actuator_design.model.scene import DipoleField, Scene, UniformField, default_scene

LGL = SolverOptions()
MID = SolverOptions(transcription="midpoint", elements=400)


@pytest.mark.parametrize("h", [0.3, 1.0, 1.9])
def test_straight_rod_spectrum_in_transverse_field(h):
    """φ = π/2, p = 0: the straight rod is an equilibrium whose second variation
    −η'' − 2h²η, η(0) = 0, η'(1) = 0 has eigenvalues ((k − ½)π)² − 2h² (THEORY §7)."""
    r = solve(default_scene(h=h, phi=math.pi / 2), replace(LGL, ensure_stable=False))
    assert r.success
    np.testing.assert_allclose(r.theta, 0.0, atol=1e-12)
    exact = np.array([((k - 0.5) * math.pi) ** 2 - 2 * h**2 for k in (1, 2, 3)])
    np.testing.assert_allclose(r.eigenvalues, exact, rtol=1e-9)
    assert r.morse_index == int(np.sum(exact < 0))
    assert r.stable == bool(exact[0] > 0)


def test_saddle_escape_reaches_stable_buckled_state():
    """Above h_crit^(1) = π/(2√2) the straight rod is a saddle (index 1): the default solve must
    leave it and report that it did; with ensure_stable=False it must report the saddle."""
    h = 1.5
    saddle = solve(default_scene(h=h, phi=math.pi / 2), replace(LGL, ensure_stable=False))
    assert saddle.success and saddle.morse_index == 1 and not saddle.stable
    r = solve(default_scene(h=h, phi=math.pi / 2), LGL)
    assert r.success and r.stable and r.morse_index == 0 and r.escaped_saddle
    assert abs(r.tip["angle"]) > 0.5
    assert r.energy < saddle.energy - 1e-3


@pytest.mark.parametrize("opts", [LGL, MID], ids=["lgl", "midpoint"])
@pytest.mark.parametrize("h,phi,p", [(1.2, 0.4, 1.5), (1.5, math.pi / 2, 0.0), (0.0, 0.0, 3.0), (2.0, 2.5, -1.0)])
def test_first_integral_is_conserved(opts, h, phi, p):
    """For b ≡ 1, α ≡ 0 and a uniform field, θ'' = h² sin(2(θ−φ)) − p cos θ has the first
    integral H(s) = ½θ'² + h² cos²(θ−φ) + p sin θ, constant along the rod."""
    r = solve(default_scene(h=h, phi=phi, p=p), opts)
    assert r.success and r.stable
    s = np.linspace(0.01, 0.99, 97)
    d = r.evaluate(s)
    H = 0.5 * d["dtheta"] ** 2 + h**2 * np.cos(d["theta"] - phi) ** 2 + p * np.sin(d["theta"])
    tol = 1e-9 if opts.transcription == "lgl" else 5e-4
    assert np.ptp(H) < tol * max(1.0, abs(H).max())
    # the free end: θ'(1) = 0, and H(1) = h² cos²(β−φ) + p sin β
    assert abs(r.evaluate(np.array([1.0]))["dtheta"][0]) < (1e-8 if opts.transcription == "lgl" else 1e-2)


def test_mirror_symmetry_transverse_field():
    """φ = π/2, p = 0 is symmetric under θ → −θ: both buckled states exist, mirror images with
    equal energy; y flips sign, x is unchanged."""
    sc = default_scene(h=1.5, phi=math.pi / 2)
    up = solve(sc, LGL)
    down = solve(sc, LGL, initial=-up.theta)
    assert up.success and down.success
    np.testing.assert_allclose(down.theta, -up.theta, atol=1e-10)
    assert down.tip["x"] == pytest.approx(up.tip["x"], abs=1e-12)
    assert down.tip["y"] == pytest.approx(-up.tip["y"], abs=1e-12)
    assert down.energy == pytest.approx(up.energy, abs=1e-12)


def test_mirror_symmetry_general_scene():
    """Reflecting the whole scene in the rod axis (φ → −φ, p → −p, α → −α, θ0 → −θ0) reflects
    the equilibrium: θ → −θ."""
    sc = replace(default_scene(h=1.1, phi=0.7, p=1.3, alpha=0.2), theta0=0.15)
    mirror = replace(default_scene(h=1.1, phi=-0.7, p=-1.3, alpha=-0.2), theta0=-0.15)
    a, b = solve(sc, LGL), solve(mirror, LGL)
    np.testing.assert_allclose(b.theta, -a.theta, atol=1e-10)
    assert b.energy == pytest.approx(a.energy, abs=1e-12)


def test_no_field_no_load_is_straight_at_clamp_angle():
    sc = Scene(field=None, tip_force=None, theta0=0.3)
    r = solve(sc, LGL)
    np.testing.assert_allclose(r.theta, 0.3, atol=1e-14)
    assert r.tip["x"] == pytest.approx(math.cos(0.3), abs=1e-14)
    assert r.energy == pytest.approx(0.0, abs=1e-14)


def test_pure_tip_moment_gives_circular_arc():
    """A tip moment m alone bends the rod into an arc of curvature m/b: θ = m s (closed form)."""
    m = 2.0
    r = solve(Scene(field=None, tip_force=None, tip_moment=m), LGL)
    s = np.linspace(0, 1, 11)
    d = r.evaluate(s)
    np.testing.assert_allclose(d["theta"], m * s, atol=1e-12)
    np.testing.assert_allclose(d["x"], np.sin(m * s) / m, atol=1e-12)
    np.testing.assert_allclose(d["y"], (1 - np.cos(m * s)) / m, atol=1e-12)
    assert r.energy == pytest.approx(0.5 * m**2 - m * m, abs=1e-12)


def test_varying_stiffness_tip_moment():
    """With b(s) = 1 + s and a tip moment m, the moment is constant, b θ' = m: θ = m ln(1 + s)."""
    m = 0.7
    sc = Scene(field=None, tip_force=None, tip_moment=m, stiffness=expression_profile("1 + s"))
    r = solve(sc, LGL)
    s = np.linspace(0, 1, 11)
    np.testing.assert_allclose(r.evaluate(s)["theta"], m * np.log1p(s), atol=1e-9)


@pytest.mark.parametrize("opts", [LGL, MID], ids=["lgl", "midpoint"])
def test_clamp_reaction_balances_loads(opts):
    """The clamp reaction balances the tip force and the distributed load, and its moment equals
    −b(0)θ'(0) (the moment balance of the whole rod; THEORY §4)."""
    sc = Scene(field=UniformField(phi=0.3), h=0.8, tip_force=(0.4, -1.2), distributed_load=(0.1, -2.0),
               tip_moment=0.3)
    r = solve(sc, opts)
    assert r.success and r.stable
    np.testing.assert_allclose(r.clamp_force, [-(0.4 + 0.1), -(-1.2 - 2.0)], atol=1e-12)
    gamma = r.evaluate(np.array([0.0]))["dtheta"][0]
    assert r.clamp_moment == pytest.approx(-gamma, abs=1e-8 if opts.transcription == "lgl" else 2e-2)
    assert r.el_residual < (1e-9 if opts.transcription == "lgl" else 1e-3)


def test_dipole_gradient_force_by_virtual_work():
    """Translating the magnet by δ is translating the rod by −δ in a fixed field, so the total
    field-gradient force on the rod, −(clamp force), equals dÊ*/dx0 (the envelope theorem applied
    to the equilibrium energy); checked by central differences of independent solves."""
    base = Scene(field=DipoleField(x0=0.5, y0=-1.3, moment_angle=math.pi / 2), h=0.8, h_pos=0.4,
                 tip_force=None)
    r = solve(base, LGL)
    assert r.success and r.stable
    eps = 1e-5
    grads = []
    for name in ("x0", "y0"):
        e = []
        for sgn in (+1, -1):
            f = replace(base.field, **{name: getattr(base.field, name) + sgn * eps})
            e.append(solve(replace(base, field=f), LGL, initial=r).energy)
        grads.append((e[0] - e[1]) / (2 * eps))
    np.testing.assert_allclose(-r.clamp_force, grads, rtol=1e-6, atol=1e-9)
    assert r.el_residual < 1e-8


def test_fibres_along_field_give_no_torque():
    """Fibres at α with a uniform field at φ = α exert no torque on the straight rod: it stays
    straight and stable (the fibres already align with the field; THEORY §5)."""
    alpha = 0.6
    r = solve(default_scene(h=2.0, phi=alpha, alpha=alpha), LGL)
    np.testing.assert_allclose(r.theta, 0.0, atol=1e-12)
    assert r.stable


def test_terms_absent_from_scene_are_not_built():
    from actuator_design.physics.registry import build_terms

    assert [t.name for t in build_terms(Scene(field=None, tip_force=None))] == ["bending"]
    names = [t.name for t in build_terms(default_scene(1.0, 0.3, 1.0))]
    assert names == ["bending", "field_orientation", "tip_force"]
    names = [t.name for t in build_terms(Scene(field=DipoleField(), h=1, h_pos=0.5, tip_force=None))]
    assert names == ["bending", "field_orientation", "field_position"]
    # uniform field: the χ̂ term is a constant and must not be built
    names = [t.name for t in build_terms(Scene(field=UniformField(), h=1, h_pos=0.5, tip_force=None))]
    assert "field_position" not in names


def test_new_values_reuse_the_built_nlp():
    from actuator_design.equilibrium.solver import get_solver

    opts = SolverOptions(elements=3, degree=9)
    s1 = get_solver(default_scene(1.0, 0.2, 0.5), opts)
    s2 = get_solver(default_scene(2.0, 1.2, -3.0, alpha=0.4), opts)
    assert s1 is s2
    r = solve(default_scene(2.0, 1.2, -3.0, alpha=0.4), opts)
    assert r.stats["nlp_reused"]


def test_rod_pulled_into_a_reachable_magnet_is_not_a_success():
    """A magnet within the rod's reach makes the energy unbounded below (|ĥ|² ~ |ρ|⁻⁶): there is
    no equilibrium to find, and the result must say so instead of returning the last iterate."""
    sc = Scene(field=DipoleField(x0=0.9, y0=-0.45, moment_angle=math.pi / 2), h=0.6, h_pos=0.3, tip_force=None)
    r = solve(sc, LGL)
    assert not r.success and r.status != "converged"


def test_nonconvergence_is_reported_not_hidden():
    """An iteration limit too small to converge ends with success False and a message."""
    opts = SolverOptions(max_iter=1, method="ipopt")
    r = solve(default_scene(h=3.0, phi=2.0, p=8.0), opts)
    assert not r.success
    assert r.status != "converged"
    assert r.message


@pytest.mark.parametrize("turns", [83, 2778, -2778])
def test_a_clamp_angle_whole_turns_away_gives_the_same_rod(turns):
    """θ0 and θ0 + 2πk clamp the same rod (every term is 2π-periodic in θ; a tip moment's −m θ(1)
    up to a constant): the same tip position, the tip angle 2πk away, the same stability, for k up to
    the ±1e6 deg a clamp angle may take (IPOPT, whose step tests are relative to |θ|, stopped early
    there before)."""
    base = replace(default_scene(h=40.0, phi=math.radians(170.0), p=3.0), theta0=math.radians(120.0),
                   tip_moment=0.4)
    far = replace(base, theta0=base.theta0 + 2.0 * math.pi * turns)
    a, b = solve(base), solve(far)
    assert a.success and b.success and a.stable and b.stable
    assert (b.tip["x"], b.tip["y"]) == pytest.approx((a.tip["x"], a.tip["y"]), abs=1e-9)
    assert b.tip["angle"] - 2.0 * math.pi * turns == pytest.approx(a.tip["angle"], abs=1e-9 * (1 + abs(turns)))
