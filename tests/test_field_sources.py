"""Fields of real magnets and coils (issue 19 item 1): the fitted solid harmonics against magpylib.

The references are magpylib objects built here by hand (their own positions and rotations, not the
package's builder): at random points of the rod's reach where a fit holds, the CasADi field and its
gradient agree with magpylib to the reported fit errors (≤ 1e-6 relative to H0 for the default
tolerance); the represented field is divergence- and curl-free in three dimensions to round-off.
"""
import math

import casadi as ca
import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from actuator_design.model.field_sources import CoilSource, MagnetSource, source_field
from actuator_design.physics.fields import field_model
from actuator_design.physics.harmonic import field_function

MU0 = 4e-7 * math.pi
L = 20e-3  # rod length, m


def _axis(angle):  # magpylib's local z (a cylinder's or loop's axis) turned to `angle` in the plane
    return Rotation.from_rotvec([0.0, 0.5 * math.pi, 0.0]) if angle == 0 else \
        Rotation.from_euler("z", angle) * Rotation.from_rotvec([0.0, 0.5 * math.pi, 0.0])


CASES = {
    # a cylinder magnet beside the rod, its reach wholly outside the magnet's sphere
    "cylinder": ((MagnetSource("cylinder", 10e-3, 10e-3, (25e-3, -15e-3), 0.5 * math.pi, 1.2 / MU0),),
                 lambda: [magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                                position=(25e-3, -15e-3, 0),
                                                orientation=Rotation.from_rotvec([-0.5 * math.pi, 0, 0]))]),
    # a cylinder the rod can come close to: the fit's region is smaller than the reach
    "near cylinder": ((MagnetSource("cylinder", 10e-3, 10e-3, (15e-3, -12e-3), 1.0, 1.2 / MU0),),
                      lambda: [magpy.magnet.Cylinder(dimension=(10e-3, 10e-3), magnetization=(0, 0, 1.2 / MU0),
                                                     position=(15e-3, -12e-3, 0), orientation=_axis(1.0))]),
    "sphere": ((MagnetSource("sphere", 8e-3, 0.0, (-5e-3, 30e-3), 2.0, 1.0 / MU0),),
               lambda: [magpy.magnet.Sphere(diameter=8e-3, magnetization=(0, 0, 1.0 / MU0),
                                            position=(-5e-3, 30e-3, 0), orientation=_axis(2.0))]),
    # a block magnet magnetised along +y (magpylib's cuboid unrotated: x wide, y along the axis, z
    # thick), its field not axisymmetric (the tesseral expansion)
    "cuboid": ((MagnetSource("cuboid", 0.0, 5e-3, (25e-3, -15e-3), 0.5 * math.pi, 1.2 / MU0, (), 10e-3, 10e-3),),
               lambda: [magpy.magnet.Cuboid(dimension=(10e-3, 5e-3, 10e-3), magnetization=(0, 1.2 / MU0, 0),
                                            position=(25e-3, -15e-3, 0))]),
    # an elongated block at an oblique angle the rod can come close to (magpylib's turned about z)
    "near cuboid": ((MagnetSource("cuboid", 0.0, 12e-3, (15e-3, -12e-3), 1.0, 1.0 / MU0, (), 6e-3, 4e-3),),
                    lambda: [magpy.magnet.Cuboid(dimension=(12e-3, 6e-3, 4e-3), magnetization=(1.0 / MU0, 0, 0),
                                                 position=(15e-3, -12e-3, 0),
                                                 orientation=Rotation.from_euler("z", 1.0))]),
    # a disc standing on the rod's plane (its own axis z), magnetised across a diameter at 30°
    "diametric cylinder": ((MagnetSource("diametric_cylinder", 12e-3, 4e-3, (20e-3, 16e-3), math.pi / 6, 1.1 / MU0),),
                           lambda: [magpy.magnet.Cylinder(dimension=(12e-3, 4e-3), position=(20e-3, 16e-3, 0),
                                                          magnetization=(1.1 / MU0 * math.cos(math.pi / 6),
                                                                         1.1 / MU0 * math.sin(math.pi / 6), 0))]),
    # Helmholtz coils around the rod (the interior expansion)
    "helmholtz": ((CoilSource("helmholtz", 50e-3, (10e-3, 0.0), 70 * math.pi / 180, 5.0, 200, 0.0, 50e-3),),
                  lambda: [magpy.current.Circle(diameter=0.1, current=1000.0, orientation=_axis(70 * math.pi / 180),
                                                position=(10e-3 + z * math.cos(70 * math.pi / 180),
                                                          z * math.sin(70 * math.pi / 180), 0))
                           for z in (-25e-3, 25e-3)]),
    # a Maxwell pair (zero field at its centre) and a solenoid beside the rod, together
    "maxwell + solenoid": ((CoilSource("maxwell", 40e-3, (5e-3, 5e-3), 0.0, 3.0, 50, 0.0, math.sqrt(3) * 40e-3),
                            CoilSource("solenoid", 6e-3, (0.0, -35e-3), 0.3, 2.0, 20, 15e-3, 0.0)),
                           lambda: [magpy.current.Circle(diameter=80e-3, current=s * 150.0,
                                                         position=(5e-3 + z, 5e-3, 0), orientation=_axis(0))
                                    for s, z in ((1, -math.sqrt(3) * 20e-3), (-1, math.sqrt(3) * 20e-3))]
                           + [magpy.current.Circle(diameter=12e-3, current=2.0, orientation=_axis(0.3),
                                                   position=(z * math.cos(0.3), -35e-3 + z * math.sin(0.3), 0))
                              for z in np.linspace(-7.5e-3, 7.5e-3, 20)]),
}


def _random_points(field, n=200, seed=7):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-1, 1, (20 * n, 2))
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= 1]
    keep = np.all([t.contains(pts[:, 0], pts[:, 1]) for t in field.terms], axis=0)
    return pts[keep][:n]


def _magpylib(objs, pts, h0):
    p = np.column_stack([pts * L, np.zeros(len(pts))])
    return np.asarray(magpy.getH(objs, p, sumup=True), float).reshape(-1, 3) / h0


@pytest.mark.parametrize("name", list(CASES))
def test_field_and_gradient_agree_with_magpylib(name):
    sources, build = CASES[name]
    field, h0 = source_field(sources, L)
    objs = build()
    pts = _random_points(field)
    assert len(pts) >= 100
    H = _magpylib(objs, pts, h0)
    assert np.max(np.abs(H[:, 2])) <= 1e-9 * np.max(np.abs(H))  # in-plane: the symmetry z → −z
    model = field_model(field)
    h = model.evaluate(pts[:, 0], pts[:, 1], {}).T
    err = np.max(np.linalg.norm(h - H[:, :2], axis=1))
    assert err <= 2 * field.fit_error + 1e-12 and field.fit_error <= 1e-6, (err, field.fit_error)
    # the gradient against magpylib's by 4th-order central differences (their own error ~1e-9)
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    J = ca.Function("J", [x, y], [model.jet(x, y, {})[1]])
    d = 1e-3
    for j, e in enumerate(np.eye(2)):
        fd = (_magpylib(objs, pts - 2 * d * e, h0) - 8 * _magpylib(objs, pts - d * e, h0)
              + 8 * _magpylib(objs, pts + d * e, h0) - _magpylib(objs, pts + 2 * d * e, h0))[:, :2] / (12 * d)
        ours = np.array([np.asarray(J(px, py), float)[:, j] for px, py in pts])
        gerr = np.max(np.abs(ours - fd))
        assert gerr <= 2 * field.gradient_error + 1e-8 and field.gradient_error <= 1e-6, (gerr, field.gradient_error)


@pytest.mark.parametrize("name", ["cylinder", "helmholtz", "cuboid"])
def test_field_is_divergence_and_curl_free_in_three_dimensions(name):
    field, _ = source_field(CASES[name][0], L)
    f3 = field_function(field.terms, with_z=True)
    x, y, z = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("z")
    r = ca.vertcat(x, y, z)
    J = ca.Function("J", [x, y, z], [ca.jacobian(ca.vertcat(*f3(x, y, z)), r)])
    rng = np.random.default_rng(3)
    n = 0
    for p in rng.uniform(-1, 1, (400, 3)) * [1, 1, 0.3]:
        if not all(t.contains([p[0]], [p[1]])[0] for t in field.terms):
            continue
        if np.hypot(p[0], p[1]) > 1 or field.terms[0].kind == "exterior" and \
                np.linalg.norm(p - [*field.terms[0].centre, 0]) < field.terms[0].valid_radius:
            continue
        Jp = np.asarray(J(*p), float)
        scale = np.linalg.norm(Jp)
        assert abs(np.trace(Jp)) <= 1e-12 * scale  # div
        assert np.max(np.abs(Jp - Jp.T)) <= 1e-12 * scale  # curl
        n += 1
    assert n >= 50


def test_a_sphere_is_a_dipole_fitted_exactly():
    field, _ = source_field(CASES["sphere"][0], L)
    assert len(field.terms[0].coefficients) == 1 and field.fit_error <= 1e-12


def test_tesseral_terms_are_the_normalised_associated_legendre_functions():
    """Each tesseral basis potential (the recurrence of physics/tesseral.py, in and off the plane)
    against SciPy's associated Legendre functions: ±√((l−m)!/(l+m)!) P_l^m(cos ϑ) cos mφ / ρ^(l+1)
    (the sign is the Condon–Shortley phase, which a fit absorbs)."""
    from scipy.special import lpmv

    from actuator_design.physics.tesseral import tesseral_modes, tesseral_potentials

    modes = tesseral_modes(41)
    rng = np.random.default_rng(11)
    centre, axis, radius = (0.3, -0.2), 0.7, 0.45
    p = rng.normal(size=(40, 3)) * [1, 1, 0.5]
    p *= (0.5 + rng.uniform(0, 1.5, 40) / np.linalg.norm(p, axis=1))[:, None] * radius
    for z in (p[:, 2], 0.0):
        x, y = centre[0] + p[:, 0], centre[1] + p[:, 1]
        ours = np.array(tesseral_potentials(centre, axis, radius, modes, x, y, z))
        u = p[:, 0] * math.cos(axis) + p[:, 1] * math.sin(axis)
        v = -p[:, 0] * math.sin(axis) + p[:, 1] * math.cos(axis)
        w = np.broadcast_to(z, u.shape)
        rho = np.sqrt(u * u + v * v + w * w) / radius
        cos_t, phi = w / radius / rho, np.arctan2(v, u)
        ref = np.array([math.exp(0.5 * (math.lgamma(l - m + 1) - math.lgamma(l + m + 1))) * lpmv(m, l, cos_t)
                        * np.cos(m * phi) / rho ** (l + 1) for l, m in modes])
        scale = np.max(np.abs(ref), axis=1, keepdims=True)
        assert np.max(np.abs(np.abs(ours) - np.abs(ref)) / scale) <= 1e-12
        sign = np.sign(np.sum(ours * ref, axis=1))
        assert np.max(np.abs(ours - sign[:, None] * ref) / scale) <= 1e-12


def test_a_tesseral_term_in_the_plane_nested_equals_its_sum_of_terms():
    """The solver's in-plane form (Horner's rule in 1/|x|², physics/tesseral.py) against the sum of
    the unit-coefficient terms times their coefficients, for coefficients decaying as a fit's do."""
    from actuator_design.physics.harmonic import potential
    from actuator_design.physics.tesseral import TesseralTerm, tesseral_modes, tesseral_potentials

    modes = tesseral_modes(59)
    rng = np.random.default_rng(5)
    coefficients = tuple(rng.normal(size=len(modes)) * 0.8 ** np.array([l for l, _ in modes]))
    term = TesseralTerm("exterior", (0.3, -0.4), 0.7, 0.5, coefficients, 0.5, modes)
    x, y = rng.uniform(-1, 1, (2, 200))
    keep = term.contains(x, y)
    x, y = x[keep], y[keep]
    nested = potential(term, x, y)
    summed = sum(c * b for c, b in zip(coefficients, tesseral_potentials(term.centre, term.axis_angle, term.radius,
                                                                          modes, x, y, np.zeros(len(x)))))
    assert len(x) >= 100 and np.max(np.abs(nested - summed)) <= 1e-13 * np.max(np.abs(summed))


def test_a_small_sphere_next_to_the_clamp_is_an_exact_dipole_down_to_its_body():
    """A uniformly magnetised sphere's field is exactly a dipole's: order 1 holds to round-off right
    down to the sphere, however close it sits to the clamp and however strongly its field varies
    there (the gradient is checked by differences whose step shrinks with the distance to the body,
    and rounding in the higher coefficients is not taken for content)."""
    sphere = MagnetSource("sphere", 0.6e-3, 0.0, (1.2e-3, 0.0), 0.0, 1.2 / MU0)
    field, _ = source_field((sphere,), L)
    term = field.terms[0]
    assert len(term.coefficients) == 1 and term.valid_radius * L <= 1.03 * 0.3e-3
    assert field.fit_error <= 1e-12 and field.gradient_error <= 1e-7
