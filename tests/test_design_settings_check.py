"""Design settings validate themselves on construction (issue 18: ``DesignSettings(h_max=-1)`` from
Python ended in a raw CasADi error): one ValueError naming the setting and its range; the CLI reports
the same line with exit 2."""
import contextlib
import io
import math

import pytest

from actuator_design.inverse.settings import DesignSettings
from actuator_design.cli.main import main
from cli_checks import assert_rejected


@pytest.mark.parametrize("kw,name", [
    ({"h_max": -1.0}, "h_max"), ({"h_max": 1e5}, "h_max"), ({"h_max": float("nan")}, "h_max"),
    ({"p_max": -1.0}, "p_max"), ({"alpha_max": 0.0}, "alpha_max"), ({"alpha_max": 2.0}, "alpha_max"),
    ({"alpha_terms": 0}, "alpha_terms"), ({"alpha_terms": 2.5}, "alpha_terms"),
    ({"magnetization_max": 4.0}, "magnetization_max"), ({"margin": -0.1}, "margin"),
    ({"margin": math.inf}, "margin"), ({"reach_tol": 0.0}, "reach_tol"), ({"ramp_steps": 1}, "ramp_steps"),
    ({"time_limit": 0.0}, "time_limit"), ({"time_limit": 1e6}, "time_limit"), ({"tolerances": "5%"}, "tolerances"),
])
def test_a_setting_out_of_range_is_one_error_naming_it(kw, name):
    with pytest.raises(ValueError) as err:
        DesignSettings(**kw)
    assert str(err.value).startswith(name)
    assert "\n" not in str(err.value)


def test_the_defaults_and_the_range_ends_are_accepted():
    DesignSettings()
    DesignSettings(h_max=1e4, alpha_max=math.pi / 2, alpha_terms=12, margin=0.0, time_limit=86400.0)


def test_replace_checks_too():
    """The settings are frozen; a changed copy is constructed, so it is checked."""
    import dataclasses

    with pytest.raises(ValueError, match="^h_max"):
        dataclasses.replace(DesignSettings(), h_max=-1.0)


def test_the_cli_reports_the_same_line(tmp_path):
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        code = main(["design", "--target-tip", "0.3,0.5", "--alpha-terms", "0", "--out", str(tmp_path / "out")])
    assert_rejected((code, o.getvalue(), e.getvalue()), tmp_path, "alpha_terms", "[1, 12]")


def test_a_design_bound_in_degrees_is_refused_with_its_own_range(capsys):
    """--alpha-max-deg is a bound in (0, 90] deg, not any angle: 1e9 names that range (it used to
    name the generic angle range ±1e6 deg)."""
    assert main(["design", "--target-tip", "0.3,0.5", "--alpha-max-deg", "1e9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "alpha_max must lie in (0, 90] deg, got 1e+09 deg" in err[0], err


def test_each_built_in_designed_profile_has_a_bound_setting_with_its_term_s_default():
    """The profile bounds are settings the terms declare (issue 18: the settings name no term): one
    ``<name>_max`` per built-in designed profile, after ``p_max``, defaulting to the term's own
    largest bound; keywords only, so no positional call shifts a value into another setting."""
    import dataclasses

    from actuator_design.physics.parameters import designed_profiles
    from actuator_design.physics.registry import is_builtin, term_class

    names = [f.name for f in dataclasses.fields(DesignSettings)]
    built_in = {n: p for n, p in designed_profiles().items() if is_builtin(term_class(p.term))}
    assert {"alpha", "magnetization"} <= set(built_in)
    assert names[:2 + len(built_in)] == ["h_max", "p_max", *[f"{n}_max" for n in built_in]]
    for n, p in built_in.items():
        assert getattr(DesignSettings(), f"{n}_max") == p.design_bound
    with pytest.raises(TypeError):
        DesignSettings(10.0, 20.0)
