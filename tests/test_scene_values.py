"""A scene's term values (issue 18): declared by the terms (``physics.registration.SCENE_VALUES``),
given as keywords, read as attributes, and checked when the scene is built, so that a NaN or a
wrong shape from Python is one clear error naming the value, as it is from a config."""
import dataclasses
import math
import pickle

import numpy as np
import pytest

import actuator_design as ad
from actuator_design.model.scene import Scene
from actuator_design.physics.registration import SCENE_VALUES

SAMPLES = {"h_pos": 0.25, "tip_force": (0.5, -1.0), "tip_moment": 2.0, "distributed_load": (0.0, -0.3),
           "h_r": 1.5, "magnetization": ad.constant_profile(0.2)}


def test_every_declared_value_has_a_sample_here():
    assert set(SAMPLES) == set(SCENE_VALUES)


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_a_value_given_is_read_back_and_replace_keeps_the_others(name):
    scene = Scene(**{name: SAMPLES[name]})
    assert getattr(scene, name) == SAMPLES[name]
    other = next(n for n in SAMPLES if n != name)
    moved = dataclasses.replace(scene, **{other: SAMPLES[other]})
    assert getattr(moved, name) == SAMPLES[name] and getattr(moved, other) == SAMPLES[other]
    assert pickle.loads(pickle.dumps(moved)) == moved
    for n, spec in SCENE_VALUES.items():  # the rest keep their declared defaults
        if n != name:
            assert getattr(scene, n) == spec.default


def test_equal_meaning_is_equal_scenes_with_equal_hashes():
    assert Scene(h_r=0) == Scene() and hash(Scene(h_r=0)) == hash(Scene())
    assert Scene(tip_force=[0, 1]) == Scene(tip_force=(0.0, 1.0))  # a list is kept as a tuple (hashable)
    assert hash(Scene(tip_force=np.array([0.0, 1.0]))) == hash(Scene(tip_force=(0.0, 1.0)))


@pytest.mark.parametrize("kwargs, names", [
    (dict(h=math.nan), "h must be a finite number"),
    (dict(theta0=math.inf), "theta0 must be a finite number"),
    (dict(contact_gap=-0.01), "contact_gap must be a finite number >= 0"),
    (dict(tip_force=(math.nan, 0.0)), "tip_force must be an (x, y) pair of finite numbers"),
    (dict(tip_force=(0.0, 1.0, 2.0)), "tip_force must be an (x, y) pair"),
    (dict(distributed_load="down"), "distributed_load must be an (x, y) pair"),
    (dict(tip_moment=math.inf), "tip_moment must be a finite number or None"),
    (dict(h_r=True), "h_r must be a finite number, got True"),
    (dict(h_pos=None), "h_pos must be a finite number, got None"),
    (dict(magnetization=0.3), "magnetization must be a Profile"),
    (dict(h_r="1.5"), "h_r must be a finite number"),                 # text is no number
    (dict(tip_moment=10**400), "tip_moment must be a finite number"),  # an int beyond float (OverflowError)
    (dict(tip_force=np.array(1.0)), "tip_force must be an (x, y) pair"),
    (dict(tip_force=np.eye(2)), "tip_force must be an (x, y) pair"),    # its repr spans lines
    (dict(tip_force=list(range(500))), "tip_force must be an (x, y) pair"),
])
def test_bad_values_are_one_error_naming_the_value(kwargs, names):
    with pytest.raises(ValueError) as err:
        Scene(**kwargs)
    assert str(err.value).startswith(f"Scene: {names}") and "\n" not in str(err.value)
    assert len(str(err.value)) < 300  # the value is quoted short


def test_any_real_scalar_is_a_number():
    """numpy's 0-d arrays, CasADi's DM and fractions are numbers (the lens' writes take them too):
    the scene keeps them as floats, so that it hashes and compares as any other."""
    from fractions import Fraction

    import casadi as ca

    assert Scene(theta0=np.array(0.3)) == Scene(theta0=0.3)
    assert Scene(tip_moment=ca.DM(0.3)).tip_moment == 0.3
    assert Scene(h_r=Fraction(3, 2)).h_r == 1.5
    assert Scene(tip_force=(np.array(0.0), np.array(1.0))).tip_force == (0.0, 1.0)
    assert Scene(tip_force=ca.DM([0.0, 1.0])).tip_force == (0.0, 1.0)
    assert type(Scene(h=np.float32(1.5)).h) is float


def test_unknown_and_positional_arguments_are_refused():
    with pytest.raises(TypeError, match="unknown keyword.*'?tip_forse'?.*the terms': .*tip_force"):
        Scene(tip_forse=(0.0, 1.0))
    with pytest.raises(TypeError, match="unknown keyword.*'bogus'"):
        Scene(values=(("bogus", 1.0),))
    with pytest.raises(TypeError):
        Scene(None, 1.0)  # the fields' order is no interface


def test_solve_of_a_nan_scene_never_starts():
    """From Python a NaN field strength crashed deep in the mesh grading (IndexError); it is now
    refused where the scene is built."""
    with pytest.raises(ValueError, match="Scene: h must be a finite number"):
        ad.solve(ad.Scene(h=float("nan")))


def test_plug_in_terms_share_the_one_store_and_survive_replace_pickle_and_equality():
    """A plug-in term's values live in ``values`` after the built-in ones (one store, issue 18):
    ``extra_terms`` reads them, replace and pickling keep them, and they take part in equality."""
    from actuator_design.model.scene import TermValues

    tv = TermValues("foundation", (("k_foundation", 2.0),))
    scene = Scene(extra_terms=(tv,), h_r=1.0)
    assert scene.extra_terms == (tv,) and scene.values[-1] == ("foundation", tv)
    assert [k for k, _ in scene.values[:len(SCENE_VALUES)]] == list(SCENE_VALUES)
    moved = dataclasses.replace(scene, h=2.0, tip_moment=0.5)
    assert moved.extra_terms == (tv,) and moved.h_r == 1.0 and moved.tip_moment == 0.5
    assert pickle.loads(pickle.dumps(moved)) == moved
    assert dataclasses.replace(scene, extra_terms=()) == Scene(h_r=1.0) != scene
    assert scene.with_term("foundation", k_foundation=3.0).term_values("foundation") == {"k_foundation": 3.0}
    assert scene.without_term("foundation") == Scene(h_r=1.0)
    # a values tuple given by hand is the whole store: what it leaves out is default or absent
    assert dataclasses.replace(scene, values=(("h_r", 2.0),)) == Scene(h_r=2.0)


@pytest.mark.parametrize("kwargs, match", [
    ({"extra_terms": ({"name": "foundation"},)}, "must hold TermValues"),
    ({"extra_terms": ("foundation",)}, "must hold TermValues"),
    ({"extra_terms": (("tip_force", ()),)}, "must hold TermValues"),
])
def test_plug_in_terms_that_are_not_term_values_are_refused(kwargs, match):
    with pytest.raises(TypeError, match=match):
        Scene(**kwargs)


def test_a_plug_in_term_twice_or_named_as_a_built_in_value_or_given_twice_is_refused():
    from actuator_design.model.scene import TermValues

    tv = TermValues("foundation", (("k_foundation", 2.0),))
    with pytest.raises(ValueError, match="lists a term twice"):
        Scene(extra_terms=(tv, tv))
    with pytest.raises(ValueError, match="built-in term value's name"):
        Scene(extra_terms=(TermValues("tip_force"),))
    with pytest.raises(ValueError, match="not in both"):
        Scene(values=(("foundation", tv),), extra_terms=(tv,))
