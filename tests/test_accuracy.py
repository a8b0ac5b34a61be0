"""Accuracy as an input (``actuator_design.equilibrium.accuracy``): the a-posteriori error estimate bounds the
true error against THEORY §6 closed forms, and the selection reacts to tolerance and length scale."""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.accuracy import choose_options, scene_wavenumber
from actuator_design.equilibrium.pipeline import solve_to_tolerance
from actuator_design.benchmarks.problems import elastica_tip
from actuator_design.reference.closed_forms import lowload_stiffness, transverse_mode
from actuator_design.model.scene import Scene, default_scene


def _err(r, ref):
    tip = np.array([r.tip["x"], abs(r.tip["y"]), abs(r.tip["angle"])])
    return float(np.max(np.abs(tip - np.asarray(ref))))


@pytest.mark.parametrize("h,tol", [(1.5, 1e-4), (1.5, 1e-9), (6.0, 1e-6), (30.0, 1e-5)])
def test_estimate_bounds_true_error_transverse(h, tol):
    ref = transverse_mode(h, 1)
    r = solve_to_tolerance(default_scene(h=h, phi=math.pi / 2), tol)
    assert r.success and r.stable
    err = _err(r, (1 + ref.u1, ref.v1, ref.beta))
    assert err <= r.error_estimate <= tol, (err, r.error_estimate)
    assert r.stats["error_estimate"] == r.error_estimate


@pytest.mark.parametrize("p,tol", [(3.0, 1e-7), (9.0, 1e-10)])
def test_estimate_bounds_true_error_elastica(p, tol):
    r = solve_to_tolerance(Scene(field=None, tip_force=(0.0, p)), tol, initial=None)
    assert r.success and r.stable
    assert _err(r, elastica_tip(p)) <= r.error_estimate <= tol


def test_estimate_bounds_error_of_lowload_stiffness():
    """φ = 0, small p: y(1) = p/s(h) + O(p³) (THEORY §6); the estimate covers the tip error."""
    h, p = 4.0, 1e-4
    r = solve_to_tolerance(default_scene(h=h, phi=0.0, p=p), 1e-10)
    assert r.success
    assert abs(r.tip["y"] - p / lowload_stiffness(h)) <= r.error_estimate + 1e-12


def test_selection_grows_with_accuracy_and_field():
    sc = default_scene(h=1.0, phi=math.pi / 2)
    coarse, fine = choose_options(sc, 1e-3), choose_options(sc, 1e-10)
    assert fine.degree > coarse.degree and fine.tol <= coarse.tol
    weak, strong = choose_options(sc, 1e-6), choose_options(sc.with_values(h=100.0), 1e-6)
    assert strong.elements > weak.elements
    # the boundary layer of width ~1/(√2 h) is covered by elements of length <= 3/k
    assert 1.0 / strong.elements <= 3.0 / scene_wavenumber(sc.with_values(h=100.0)) + 1e-12


@pytest.mark.parametrize("tol", [0.0, -1e-3, 1.0, float("nan")])
def test_bad_tolerance_is_rejected_naming_it(tol):
    with pytest.raises(ValueError, match="tol"):
        choose_options(default_scene(), tol)


def test_unreachable_tolerance_says_so():
    """A tolerance below what the refinement budget can certify is reported, not faked."""
    r = solve_to_tolerance(default_scene(h=1.5, phi=math.pi / 2), 1e-15, max_refinements=0)
    if not r.success:
        assert "accuracy" in r.message and r.error_estimate > 1e-15
    else:
        ref = transverse_mode(1.5, 1)
        assert _err(r, (1 + ref.u1, ref.v1, ref.beta)) <= max(r.error_estimate, 1e-14)


def test_accuracy_option_routes_solve_through_the_estimate():
    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.equilibrium.options import SolverOptions
    h = 2.0
    ref = transverse_mode(h, 1)
    r = solve(default_scene(h=h, phi=math.pi / 2), SolverOptions(accuracy=1e-7, method="fast"))
    assert r.success and r.stats["accuracy_tol"] == 1e-7
    assert _err(r, (1 + ref.u1, ref.v1, ref.beta)) <= r.error_estimate <= 1e-7
    with pytest.raises(ValueError, match="accuracy"):
        SolverOptions(accuracy=2.0)
