"""The package's face (issue 18 item 4): ``import actuator_design as ad`` gives every public name,
lazily, and results print as one line."""
import subprocess
import sys

import actuator_design as ad


def test_every_public_name_resolves_to_the_object_its_module_defines():
    import importlib

    for name, (module, attribute) in ad._EXPORTS.items():
        assert getattr(ad, name) is getattr(importlib.import_module(f"actuator_design.{module}"), attribute), name
    assert set(ad.__all__) == {"__version__", *ad._EXPORTS}
    assert set(ad.__all__) <= set(dir(ad))


def test_an_unknown_name_is_an_attribute_error():
    try:
        ad.no_such_thing  # noqa: B018
    except AttributeError as err:
        assert "no_such_thing" in str(err)
    else:
        raise AssertionError("expected AttributeError")


def test_importing_the_package_loads_no_numerics():
    """The CLI's --version imports the package: it must not pull in CasADi, SciPy or matplotlib."""
    code = ("import sys, actuator_design as ad; ad.__version__; "
            "print(sorted(m for m in ('casadi', 'scipy', 'matplotlib', 'numpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_results_print_as_one_line_with_the_verdict():
    r = ad.solve(ad.default_scene(h=1.5, phi=1.5707963267948966))
    text = repr(r)
    assert "\n" not in text and len(text) < 300
    assert "success=True" in text and "stable=True" in text and "morse_index=0" in text
    assert f"x={r.tip['x']:.6g}" in text
    eq = ad.equilibria(ad.default_scene(h=1.5, phi=1.5707963267948966))
    assert repr(eq).startswith(f"EquilibriaResult(count={len(eq.equilibria)}, ")


def test_hardware_designs_and_schedules_print_as_one_line_with_the_verdict():
    from actuator_design.hardware.pose_stiffness import PoseStiffnessDesign

    coil = ad.CurrentShapeDesign(success=True, status="success", message="m" * 500, target=(0.8, 0.5),
                                 currents=(3.2, 5.1), power=77.6, rms_error=4e-9, box=[{"tip": {}}] * 50)
    pose = PoseStiffnessDesign(success=False, status="unreachable", message="", target=(), position=(0.022, -0.014),
                               axis_angle=1.92, move=0.06, stiffness_target=6.0, achieved_stiffness=5.5)
    schedule = ad.ScheduleResult(success=True, verified=True, snap_free=True, all_stable=True,
                                 waypoints=[(0.3, 0.5)] * 3, rows=[{}] * 400, schedule=[{}] * 40,
                                 waypoint_index=[0, 1, 2], message="m" * 500, scene=ad.default_scene())
    for r, words in ((coil, ["CurrentShapeDesign(status='success', success=True", "currents_A=(3.2, 5.1)",
                             "power_W=77.6", "rms_error=4e-09"]),
                     (pose, ["PoseStiffnessDesign(status='unreachable', success=False", "position_mm=(22, -14)",
                             "stiffness=5.5", "stiffness_target=6"]),
                     (schedule, ["ScheduleResult(success=True", "waypoints=3", "steps=40"])):
        text = repr(r)
        assert "\n" not in text and len(text) < 300, text
        assert all(w in text for w in words), text
